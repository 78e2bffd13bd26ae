//! ASL `data.csv` reading through `host_sim::asl::read_dataset`: the first
//! byte picks the sensor folder (IMU, wheels, flow, camera, segmentation,
//! ground truth, the flow sensor's raw frames, or the wheels' failed reads), the rest is that
//! folder's `data.csv` (for `wheel0`, counts or, after the rates header, the wheel angular-rate
//! variant) or, for the failed reads, `wheel0/failed.csv` beside a valid `data.csv`; the
//! `sensor.yaml` next to it is valid. The first byte also picks how bad sample values are
//! read (`BadSamples`): refused, a read either gives strictly increasing
//! time stamps and finite values, or an exit-2 error that names the file;
//! passed on, the sample streams keep every row in file order (NaN,
//! infinities, any time order), the ground truth and image lists are still
//! finite and increasing, and errors are exit 2 naming the file.
#![no_main]

use host_sim::asl::{
    BadSamples, CameraMeta, FlowMeta, ImuMeta, SegMeta, WheelMeta, read_dataset_with,
};
use libfuzzer_sys::fuzz_target;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use traction::vslam_core::Stream;
use traction_fuzz::scratch_dir;

/// The sensor folder and the file the input becomes.
const FILES: [(&str, &str); 8] = [
    ("imu0", "data.csv"),
    ("wheel0", "data.csv"),
    ("flow0", "data.csv"),
    ("cam0", "data.csv"),
    ("seg0", "data.csv"),
    ("state_groundtruth_estimate0", "data.csv"),
    ("flowraw0", "data.csv"),
    ("wheel0", "failed.csv"),
];

const IDENTITY: [f32; 16] = [
    1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
];

/// One dataset root per file, each with only that sensor's folder and a
/// valid `sensor.yaml` (cameras get two image files, `a.png` and `b.png`;
/// the failed reads' folder a valid `data.csv`).
fn roots() -> &'static Vec<PathBuf> {
    static ROOTS: OnceLock<Vec<PathBuf>> = OnceLock::new();
    ROOTS.get_or_init(|| {
        let base = scratch_dir("asl");
        FILES
            .iter()
            .map(|(s, file)| {
                let root = base.join(format!("{s}-{file}"));
                let dir = root.join("mav0").join(s);
                std::fs::create_dir_all(dir.join("data")).unwrap();
                write_meta(s, &dir.join("sensor.yaml"));
                for f in ["a.png", "b.png"] {
                    std::fs::write(dir.join("data").join(f), b"not read").unwrap();
                }
                if *file != "data.csv" {
                    std::fs::write(
                        dir.join("data.csv"),
                        "#timestamp [ns],left [ticks],right [ticks]\n0,0,0\n",
                    )
                    .unwrap();
                }
                root
            })
            .collect()
    })
}

fn write_meta(sensor: &str, path: &Path) {
    let camera = CameraMeta {
        rate_hz: 10.0,
        t_bs: IDENTITY,
        resolution: [64, 48],
        intrinsics: [50.0, 50.0, 32.0, 24.0],
        distortion_model: "radtan".into(),
        distortion_coefficients: vec![0.0; 4],
    };
    match sensor {
        "imu0" => ImuMeta {
            t_bs: IDENTITY,
            rate_hz: 250.0,
            gyroscope_noise_density: 2e-4,
            gyroscope_random_walk: 2e-5,
            accelerometer_noise_density: 2e-3,
            accelerometer_random_walk: 3e-4,
        }
        .write(path),
        "wheel0" => WheelMeta {
            rate_hz: 50.0,
            ticks_per_revolution: Some(16384.0),
            wheel_radius_left: 0.035,
            wheel_radius_right: 0.035,
            wheel_base: 0.23,
            track_factor: 1.0,
            steering: vslam_core::robot::Steering::Differential,
            wheel_type: "soft_rubber".into(),
        }
        .write(path),
        "flow0" | "flowraw0" => FlowMeta {
            rate_hz: 100.0,
            t_bs: IDENTITY,
            height: 0.03,
            counts_per_radian: 48.8,
        }
        .write(path),
        "cam0" => camera.write(path),
        "seg0" => SegMeta {
            rate_hz: 4.0,
            t_bs: IDENTITY,
            resolution: [64, 48],
            intrinsics: [50.0, 50.0, 32.0, 24.0],
            classes: [(0, "unknown".to_string()), (2, "wood".to_string())].into(),
            ground_classes: vec![2],
        }
        .write(path),
        _ => Ok(()),
    }
    .unwrap();
}

fn increasing(ts: impl Iterator<Item = u64>) -> bool {
    let v: Vec<u64> = ts.collect();
    v.windows(2).all(|w| w[0] < w[1])
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, csv)) = data.split_first() else {
        return;
    };
    let k = usize::from(which) % FILES.len();
    let bad = if (usize::from(which) / FILES.len()) % 2 == 0 {
        BadSamples::Refuse
    } else {
        BadSamples::PassOn
    };
    let strict = bad == BadSamples::Refuse;
    let root = &roots()[k];
    let (sensor, file) = FILES[k];
    let path = root.join("mav0").join(sensor).join(file);
    std::fs::write(&path, csv).unwrap();
    match read_dataset_with(root, bad) {
        Ok(ds) => {
            if let Some((_, v)) = &ds.imu
                && strict
            {
                assert!(increasing(v.iter().map(|s| s.t.0)));
                assert!(
                    v.iter()
                        .all(|s| s.gyro.iter().chain(&s.accel).all(|x| !x.is_nan()))
                );
            }
            if let Some((_, v)) = &ds.wheel
                && strict
            {
                assert!(increasing(v.iter().map(|s| s.t.0)));
            }
            if let Some((_, v)) = &ds.wheel_rates
                && strict
            {
                assert!(increasing(v.iter().map(|s| s.t.0)));
                assert!(v.iter().all(|s| s.left.is_finite() && s.right.is_finite()));
            }
            if let Some((_, v)) = &ds.flow
                && strict
            {
                assert!(increasing(v.iter().map(|s| s.t.0)));
            }
            if let Some((_, v)) = &ds.cam {
                assert!(increasing(v.iter().map(|s| s.t.0)));
                assert!(v.iter().all(|e| e.path.is_file()));
            }
            if let Some((_, v)) = &ds.flowraw {
                assert!(increasing(v.iter().map(|s| s.t.0)));
                assert!(v.iter().all(|e| e.path.is_file()));
            }
            if strict {
                assert!(increasing(ds.failed.iter().map(|f| f.t.0)));
            }
            assert!(ds.failed.iter().all(|f| f.stream == Stream::Wheel));
            if let Some(v) = &ds.groundtruth {
                assert!(increasing(v.iter().map(|s| s.t.0)));
                assert!(
                    v.iter()
                        .all(|g| g.p.iter().chain(&g.q_wxyz).all(|x| x.is_finite()))
                );
            }
        }
        Err(e) => {
            assert_eq!(e.exit_code(), 2);
            let msg = e.to_string();
            assert!(msg.contains(file), "error does not name the file: {msg}");
        }
    }
});
