//! `sensor.yaml` reading: the first byte picks the sensor kind (IMU, wheels,
//! flow, camera, segmentation), the rest is the file. A read either gives
//! values in their documented ranges or an exit-2 error naming the file.
#![no_main]

use host_sim::asl::{CameraMeta, FlowMeta, ImuMeta, SegMeta, WheelMeta};
use host_sim::error::CliError;
use libfuzzer_sys::fuzz_target;
use traction_fuzz::scratch_dir;

fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, text)) = data.split_first() else {
        return;
    };
    let path = scratch_dir("yaml").join("sensor.yaml");
    std::fs::write(&path, text).unwrap();
    let outcome: Result<(), CliError> = match which % 5 {
        0 => ImuMeta::read(&path).map(|m| {
            assert!(positive(m.rate_hz) && positive(m.gyroscope_noise_density));
            assert!(
                positive(m.accelerometer_noise_density) && positive(m.accelerometer_random_walk)
            );
            assert!(m.t_bs.iter().all(|x| x.is_finite()));
        }),
        1 => WheelMeta::read(&path).map(|m| {
            assert!(positive(m.rate_hz) && m.ticks_per_revolution.is_none_or(positive));
            assert!(positive(m.track_factor));
            assert!(positive(m.wheel_radius_left) && positive(m.wheel_radius_right));
            assert!(positive(m.wheel_base));
        }),
        2 => FlowMeta::read(&path).map(|m| {
            assert!(positive(m.rate_hz) && positive(m.height) && positive(m.counts_per_radian));
        }),
        3 => CameraMeta::read(&path).map(|m| {
            assert!(m.resolution.iter().all(|&r| r >= 1));
            assert!(positive(m.intrinsics[0]) && positive(m.intrinsics[1]));
        }),
        _ => SegMeta::read(&path).map(|m| {
            assert!(m.resolution.iter().all(|&r| r >= 1));
            assert!(positive(m.rate_hz));
        }),
    };
    if let Err(e) = outcome {
        assert_eq!(e.exit_code(), 2);
        let msg = e.to_string();
        assert!(
            msg.contains("sensor.yaml"),
            "error does not name the file: {msg}"
        );
    }
});
