//! Each sensor's adverse-memory weight reaches the filter where that
//! sensor is used (`Estimator::process_camera` hands the weights of the
//! place to the EKF, `ego_ekf::SensorWeights`): the `slip` scenario's
//! first 12 s are replayed with an empty memory and with memories that
//! hold repeated events of one sensor at every place the robot passes.
//! A camera remembered as misleading corrects the filter less (its
//! normalised innovations shrink), the wheels' and the flow sensor's
//! predicted innovation variances grow with their noise, and an IMU
//! remembered as misleading leaves the propagated attitude less certain
//! (the camera's rotation rows see it). Each test fails when its link is
//! cut.

mod common;

use common::{replay, report, simulate_slip_12s, succeed};
use serde_json::Value;
use std::sync::OnceLock;
use traction::vslam_core::Timestamp;
use traction::vslam_core::adverse::{AdverseKind, SensorKind};
use traction::vslam_core::geometry::Vec2;
use traction::vslam_core::scale::PipelineConfig;
use traction::vslam_core::scale::pipeline::PipelineMemory;

/// Events recorded per sensor and place (weight `1 / (1 + 0.5 (n - 1))`).
const EVENTS: usize = 6;

struct Run {
    /// Its folder, in the target's folder for test files (the static lives
    /// to the end of the process, so nothing would remove a scratch folder;
    /// this one is replaced by the next run).
    dir: std::path::PathBuf,
    /// The camera path's poses of the replay with an empty memory: `(t, x, y)`.
    poses: Vec<(u64, f32, f32)>,
    /// report.json of that replay.
    report: Value,
}

/// `simulate --scenario slip --duration 12 --seed 1` once, replayed with
/// an empty memory.
fn base() -> &'static Run {
    static RUN: OnceLock<Run> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("memory-weights-base");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        succeed(simulate_slip_12s().arg("--out").arg(dir.join("sim")));
        let out = dir.join("empty");
        replay(&dir.join("sim/dataset"), &out, &[]);
        let poses = std::fs::read_to_string(out.join("vslam.tum"))
            .unwrap()
            .lines()
            .map(|l| {
                let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                ((v[0] * 1e9).round() as u64, v[1] as f32, v[2] as f32)
            })
            .collect();
        Run {
            report: report(&out),
            poses,
            dir,
        }
    })
}

/// Replays the base dataset with a memory holding [`EVENTS`] disagreement
/// events of `sensor` at every camera pose of the base run, at its time.
fn replay_remembering(sensor: SensorKind, name: &str) -> Value {
    let run = base();
    let mut memory = PipelineMemory::new(PipelineConfig::default().adverse).unwrap();
    for &(t, x, y) in &run.poses {
        for _ in 0..EVENTS {
            memory
                .record(
                    sensor,
                    AdverseKind::Disagreement,
                    &Vec2::new(x, y),
                    Timestamp(t),
                )
                .unwrap();
        }
    }
    let mut bytes = vec![0u8; PipelineMemory::RECORD_LEN];
    let n = memory.export(&mut bytes).unwrap();
    let file = run.dir.join(format!("{name}.memory"));
    std::fs::write(&file, &bytes[..n]).unwrap();
    let out = run.dir.join(name);
    let log = replay(
        &run.dir.join("sim/dataset"),
        &out,
        &["--memory", file.to_str().unwrap()],
    );
    assert!(log.contains("restored"), "{log}");
    report(&out)
}

fn nis(report: &Value, aid: &str) -> f64 {
    report["aids"][aid]["nis_mean"]
        .as_f64()
        .unwrap_or_else(|| panic!("{aid}: {}", report["aids"][aid]))
}

/// The mean predicted variance `H P H^T + R` of an aid's component.
fn innovation_var(report: &Value, aid: &str, name: &str) -> f64 {
    report["aids"][aid]["components"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == name)
        .and_then(|c| c["innovation_var_mean"].as_f64())
        .unwrap_or_else(|| panic!("{aid}.{name}: {}", report["aids"][aid]))
}

/// The weight of `key` in the frames after the first second (the memory
/// holds the places of the base run; the replay's own camera path).
fn frame_weights(report: &Value, key: &str) -> Vec<f64> {
    report["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["t"].as_u64().unwrap() > 1_000_000_000)
        .map(|f| f[key].as_f64().unwrap())
        .collect()
}

fn mostly_low(weights: &[f64]) -> bool {
    let low = weights.iter().filter(|w| **w < 0.5).count();
    low * 10 >= weights.len() * 9
}

#[test]
fn the_camera_weight_softens_the_camera_update() {
    let empty = &base().report;
    let r = replay_remembering(SensorKind::Camera, "camera");
    assert!(mostly_low(&frame_weights(&r, "camera_weight")));
    let (a, b) = (nis(empty, "camera"), nis(&r, "camera"));
    eprintln!("camera NIS {a:.3} -> {b:.3}");
    assert!(b < 0.5 * a, "camera NIS {a} -> {b}");
}

/// Replays with `sensor` remembered, checks its frames' `weight_key` is
/// low, and gives the predicted variance of `aid`'s `row` without and with
/// the memory.
fn variance_without_and_with(
    sensor: SensorKind,
    name: &str,
    weight_key: &str,
    aid: &str,
    row: &str,
) -> (f64, f64) {
    let r = replay_remembering(sensor, name);
    assert!(mostly_low(&frame_weights(&r, weight_key)));
    let (a, b) = (
        innovation_var(&base().report, aid, row),
        innovation_var(&r, aid, row),
    );
    eprintln!("{aid} {row} innovation variance, {name} remembered: {a:.3e} -> {b:.3e}");
    (a, b)
}

#[test]
fn the_wheel_and_flow_weights_soften_their_updates() {
    let (a, b) = variance_without_and_with(
        SensorKind::Wheel,
        "wheel",
        "wheel_weight",
        "wheel",
        "forward",
    );
    assert!(b > 2.0 * a, "wheel {a} -> {b}");
    let (a, b) = variance_without_and_with(SensorKind::Flow, "flow", "flow_weight", "flow", "vx");
    assert!(b > 2.0 * a, "flow {a} -> {b}");
}

#[test]
fn the_imu_weight_loosens_the_propagation() {
    let empty = &base().report;
    let r = replay_remembering(SensorKind::Imu, "imu");
    assert!(mostly_low(&frame_weights(&r, "imu_weight")));
    assert!(r["final"]["sensor_weights"]["imu"].as_f64().unwrap() < 0.5);
    // The propagated attitude is less certain: the camera's rotation
    // rows, whose own noise is small, see a larger predicted variance
    // (the gyro's noise over the frame interval is most of it).
    let (a, b) = (
        innovation_var(empty, "camera", "rz"),
        innovation_var(&r, "camera", "rz"),
    );
    eprintln!("camera rz innovation variance against the propagation {a:.3e} -> {b:.3e}");
    assert!(b > 1.5 * a, "camera rz {a} -> {b}");
}
