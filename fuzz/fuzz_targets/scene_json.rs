//! `world.json` (the simulated scene beside a dataset) reading and drawing:
//! a read either gives a checked scene or an exit-2 error naming the file;
//! a checked scene draws a top view and an error plot without panicking and
//! without a non-finite number in the SVG.
#![no_main]

use host_sim::asl::GroundTruth;
use host_sim::plot::errors::errors_svg;
use host_sim::plot::trajectory::trajectory_svg;
use host_sim::plot::{PlotInputs, Scene};
use host_sim::tum::TumPose;
use libfuzzer_sys::fuzz_target;
use traction::Timestamp;
use traction_fuzz::scratch_dir;

fuzz_target!(|data: &[u8]| {
    let dir = scratch_dir("scene");
    std::fs::write(dir.join("world.json"), data).unwrap();
    match Scene::read(&dir) {
        Ok(Some(scene)) => {
            assert!(scene.check().is_ok());
            let est: Vec<TumPose> = (0..20u64)
                .map(|i| TumPose {
                    t: Timestamp(i * 100_000_000),
                    p: [i as f64 * 0.05, 0.0, 0.0],
                    q_xyzw: [0.0, 0.0, 0.0, 1.0],
                })
                .collect();
            let truth: Vec<GroundTruth> = est
                .iter()
                .map(|p| GroundTruth {
                    t: p.t,
                    p: p.p,
                    q_wxyz: [1.0, 0.0, 0.0, 0.0],
                    v: [0.0; 3],
                    bias_gyro: [0.0; 3],
                    bias_accel: [0.0; 3],
                })
                .collect();
            let report = serde_json::Value::Null;
            let inputs = PlotInputs {
                ekf: &est,
                vslam: &est,
                wheel_only: &est,
                truth: Some(&truth),
                scene: Some(&scene),
                report: &report,
            };
            for svg in [trajectory_svg(&inputs), errors_svg(&inputs)] {
                for bad in ["NaN", "=\"inf", "=\"-inf", ",inf", ",-inf", " inf,", " -inf,"] {
                    assert!(!svg.contains(bad), "non-finite number drawn: {bad}");
                }
            }
        }
        Ok(None) => unreachable!("the file was written"),
        Err(e) => {
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().contains("world.json"), "{e}");
        }
    }
});
