//! End to end on the simulator: a scenario is generated as an ASL dataset,
//! replayed through `traction::Estimator`, and judged against the truth.

mod common;

use host_sim::asl::{read_dataset, write_dataset};
use host_sim::replay::{ReplayOutput, replay, run_replay};
use host_sim::sim::scenario::{Scenario, generate};
use std::path::Path;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-it", name)
}

/// The slip scenario cut to its first `seconds` (its first slip episode is at 8-11 s).
fn slip_dataset(dir: &Path, seconds: f64, seed: u64) {
    let mut sc = Scenario::by_name("slip").unwrap();
    sc.script.duration = seconds;
    let (ds, _) = generate(&sc, seed, dir).unwrap();
    write_dataset(dir, &ds).unwrap();
}

fn error_of(r: &ReplayOutput, name: &str) -> host_sim::metrics::TrajectoryError {
    r.errors
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, e)| *e)
        .unwrap()
}

#[test]
fn slip_scenario_estimates_beat_wheel_only_and_replay_is_deterministic() {
    let root = tmp("slip");
    let data = root.join("dataset");
    slip_dataset(&data, 20.0, 3);
    let a = run_replay(&data, &root.join("a"), false).unwrap();
    let (ekf, vslam, wheel) = (
        error_of(&a, "ekf"),
        error_of(&a, "vslam"),
        error_of(&a, "wheel_only"),
    );
    println!(
        "final error / path: ekf {:.2} %, vslam {:.2} %, wheel only {:.2} % (path {:.2} m)",
        100.0 * ekf.final_relative(),
        100.0 * vslam.final_relative(),
        100.0 * wheel.final_relative(),
        wheel.path_length
    );
    println!(
        "ATE: ekf {:.3} m, vslam {:.3} m, wheel only {:.3} m",
        ekf.ate_rmse, vslam.ate_rmse, wheel.ate_rmse
    );
    assert!(
        wheel.path_length > 4.0,
        "the robot drove: {}",
        wheel.path_length
    );
    // Wide margins: each estimate's ATE is under a third of wheel-only's.
    assert!(
        ekf.ate_rmse * 3.0 < wheel.ate_rmse,
        "ekf {ekf:?} vs wheel {wheel:?}"
    );
    assert!(
        vslam.ate_rmse * 3.0 < wheel.ate_rmse,
        "vslam {vslam:?} vs wheel {wheel:?}"
    );
    assert!(vslam.final_relative() < 0.02, "{vslam:?}");

    // The slip episode is seen and the scale leaves the wheels during it.
    let frames = a.report["frames"].as_array().unwrap();
    let in_episode = |f: &&serde_json::Value| (8.2e9..11.0e9).contains(&f["t"].as_f64().unwrap());
    let slipping = frames
        .iter()
        .filter(in_episode)
        .filter(|f| f["slip_exceeded"] == true)
        .count();
    let on_wheels = frames
        .iter()
        .filter(in_episode)
        .filter(|f| f["source"] == "wheel")
        .count();
    assert!(slipping > 10, "slip frames in the episode: {slipping}");
    assert_eq!(on_wheels, 0);

    // Every sample offered is counted once.
    let ds = read_dataset(&data).unwrap();
    let counts = &a.report["counts"];
    assert_eq!(
        counts["imu"]["seen"].as_u64(),
        Some(ds.imu.as_ref().unwrap().1.len() as u64)
    );
    assert_eq!(
        counts["wheel"]["seen"].as_u64(),
        Some(ds.wheel.as_ref().unwrap().1.len() as u64)
    );
    assert_eq!(
        counts["flow"]["seen"].as_u64(),
        Some(ds.flow.as_ref().unwrap().1.len() as u64)
    );
    assert_eq!(
        counts["camera"]["seen"].as_u64(),
        Some(ds.cam.as_ref().unwrap().1.len() as u64 - 1)
    );

    // The camera's pairs reach the EKF (each pair the camera path measured
    // is fused, gated or refused with its reason there) and hold its heading
    // near the camera path's.
    let cam = &a.report["filter_counts"]["camera"];
    let (seen, fused) = (
        cam["seen"].as_u64().unwrap(),
        cam["fused"].as_u64().unwrap(),
    );
    assert!(seen <= counts["camera"]["seen"].as_u64().unwrap());
    assert!(fused * 10 > seen * 8, "camera pairs in the EKF: {cam}");
    println!(
        "yaw RMSE: ekf {:.3} deg, vslam {:.3} deg",
        ekf.yaw_rmse_deg, vslam.yaw_rmse_deg
    );
    assert!(ekf.yaw_rmse_deg < 3.0 * vslam.yaw_rmse_deg.max(0.05));

    // Replaying the same log again writes byte-identical files.
    run_replay(&data, &root.join("b"), false).unwrap();
    for f in [
        "ekf.tum",
        "vslam.tum",
        "wheel_only.tum",
        "groundtruth.tum",
        "report.json",
        "trajectory.svg",
    ] {
        let (x, y) = (
            std::fs::read(root.join("a").join(f)).unwrap(),
            std::fs::read(root.join("b").join(f)).unwrap(),
        );
        assert!(!x.is_empty(), "{f} is empty");
        assert!(x == y, "{f} differs between two replays");
    }
    let tum = std::fs::read_to_string(root.join("a/ekf.tum")).unwrap();
    let first = tum.lines().next().unwrap();
    assert_eq!(first.split_whitespace().count(), 8, "{first}");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn sensors_may_be_absent() {
    let root = tmp("absent");
    let data = root.join("dataset");
    slip_dataset(&data, 4.0, 5);
    std::fs::remove_dir_all(data.join("mav0/flow0")).unwrap();
    std::fs::remove_dir_all(data.join("mav0/seg0")).unwrap();
    let ds = read_dataset(&data).unwrap();
    let r = replay(&ds, &data, false).unwrap();
    let missing: Vec<&str> = r.report["missing_sensors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(missing, vec!["flow0", "seg0"]);
    assert!(!r.ekf.is_empty() && !r.vslam.is_empty());

    // No wheels: the EKF runs on IMU alone, the camera path still gives poses.
    std::fs::remove_dir_all(data.join("mav0/wheel0")).unwrap();
    let r = replay(&read_dataset(&data).unwrap(), &data, false).unwrap();
    assert!(!r.ekf.is_empty() && !r.vslam.is_empty() && r.wheel_only.is_empty());
    // No IMU either: no EKF trajectory, and the report says what is missing.
    std::fs::remove_dir_all(data.join("mav0/imu0")).unwrap();
    let r = replay(&read_dataset(&data).unwrap(), &data, false).unwrap();
    assert!(r.ekf.is_empty() && !r.vslam.is_empty());
    let missing = r.report["missing_sensors"].to_string();
    assert!(
        missing.contains("imu0") && missing.contains("wheel0"),
        "{missing}"
    );
    // No empty trajectory file is written.
    let out = root.join("out");
    run_replay(&data, &out, false).unwrap();
    assert!(!out.join("ekf.tum").exists() && !out.join("wheel_only.tum").exists());
    for f in ["vslam.tum", "groundtruth.tum"] {
        let text = std::fs::read_to_string(out.join(f)).unwrap();
        assert!(!text.is_empty(), "{f} is empty");
    }
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn malformed_logs_name_the_file_and_line() {
    let root = tmp("bad");
    let data = root.join("dataset");
    slip_dataset(&data, 1.0, 9);
    let csv = data.join("mav0/imu0/data.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[5] = "12,not,a,number,0,0,0";
    std::fs::write(&csv, lines.join("\n")).unwrap();
    let e = run_replay(&data, &root.join("out"), false).err().unwrap();
    assert!(e.to_string().contains("imu0/data.csv:6:"), "{e}");
    assert_eq!(e.exit_code(), 2);
    assert!(
        !root.join("out/report.json").exists(),
        "no partial output on bad input"
    );

    let e = run_replay(&root.join("nowhere"), &root.join("out"), false)
        .err()
        .unwrap();
    assert!(e.to_string().contains("nowhere"), "{e}");
    assert_eq!(e.exit_code(), 2);
    let _ = std::fs::remove_dir_all(&root);
}
