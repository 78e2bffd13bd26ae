//! `host-sim import borealtc` on the committed excerpt (`data/real/borealtc`:
//! the first 10 s of BorealTC SNOW sequence 10, CC0 data), then `replay`:
//! the wheel speeds reach the estimator as the `wheel0` rates variant.

mod common;
use common::host_sim;

use std::path::{Path, PathBuf};

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-import-bt", name)
}

fn excerpt(file: &str) -> PathBuf {
    common::repo_data("real/borealtc/SNOW").join(file)
}

fn import(out: &Path, extra: &[&str]) -> std::process::Output {
    host_sim()
        .args(["import", "borealtc"])
        .arg(excerpt("imu_10.csv"))
        .arg(excerpt("pro_10.csv"))
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// `(t, velL, velR)` of the wheel-speed file.
fn speeds() -> Vec<(f64, f64, f64)> {
    std::fs::read_to_string(excerpt("pro_10.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|v| v.parse().unwrap()).collect();
            (f[0], f[3], f[4])
        })
        .collect()
}

#[test]
fn the_excerpt_replays_with_wheel_rates_and_its_terrain() {
    let d = tmp("ok");
    let imp = import(&d.join("ds"), &[]);
    common::assert_ok(&imp);
    let csv = std::fs::read_to_string(d.join("ds/mav0/wheel0/data.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("#timestamp [ns],left [rad s^-1],right [rad s^-1]")
    );
    let first: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let v = speeds();
    assert_eq!(first[0], 0.0);
    assert!((first[1] - v[0].1 / 0.13).abs() < 1e-6 && (first[2] - v[0].2 / 0.13).abs() < 1e-6);
    let yaml = std::fs::read_to_string(d.join("ds/mav0/wheel0/sensor.yaml")).unwrap();
    assert!(
        yaml.contains("wheel_base: 0.555")
            && yaml.contains("track_factor: 1.8018")
            && yaml.contains("steering: skid"),
        "{yaml}"
    );
    assert!(!yaml.contains("ticks_per_revolution"), "{yaml}");

    let text = common::replay(&d.join("ds"), &d.join("out"), &[]);
    assert!(text.contains("terrain: SNOW"), "{text}");
    assert!(
        text.contains("EKF: IMU at 100.0 Hz; started 0.51 s after the first IMU sample"),
        "{text}"
    );
    let report = common::report(&d.join("out"));
    assert_eq!(report["labels"]["terrain"], "SNOW");
    // Every wheel sample reaches the estimator; once the EKF runs it fuses
    // or gates them. The Husky drives off at once and vibrates: the filter
    // starts moving after 0.5 s of samples (`ego_ekf::init`; waiting for
    // still samples, it started 6.78 s into this log), and writes a pose
    // for every later IMU sample.
    let wheel = &report["counts"]["wheel"];
    assert_eq!(wheel["seen"], v.len() as u64);
    let used = wheel["fused"].as_u64().unwrap() + wheel["gated"].as_u64().unwrap();
    assert!(used as usize > v.len() * 9 / 10, "{wheel}");
    let imu = &report["counts"]["imu"];
    assert_eq!(imu["rejected"]["not_ready"], 51, "{imu}");
    let poses = std::fs::read_to_string(d.join("out/ekf.tum")).unwrap();
    assert_eq!(
        poses.lines().count() as u64,
        imu["fused"].as_u64().unwrap(),
        "one pose per fused IMU sample"
    );
    assert_eq!(imu["fused"], 1000 - 51, "{imu}");

    // The wheel-only heading is the trapezoid of (vR - vL) / 1.0 m (the
    // effective track) over the log.
    let yaw: f64 = v
        .windows(2)
        .map(|w| 0.5 * ((w[0].2 - w[0].1) + (w[1].2 - w[1].1)) * (w[1].0 - w[0].0))
        .sum();
    let tum = std::fs::read_to_string(d.join("out/wheel_only.tum")).unwrap();
    let last: Vec<f64> = tum
        .lines()
        .last()
        .unwrap()
        .split(' ')
        .map(|x| x.parse().unwrap())
        .collect();
    let got = 2.0 * last[6].atan2(last[7]);
    assert!(
        (got - yaw).sin().abs() < 2e-3,
        "wheel-only yaw {got}, trapezoid {yaw}"
    );
}

#[test]
fn the_terrain_can_be_named_and_bad_rows_exit_2() {
    let d = tmp("flags");
    assert!(
        import(&d.join("ds"), &["--terrain", "ICE"])
            .status
            .success()
    );
    let labels = std::fs::read_to_string(d.join("ds/labels.yaml")).unwrap();
    assert!(labels.contains("terrain: \"ICE\""), "{labels}");

    let pro = d.join("pro_10.csv");
    let text = std::fs::read_to_string(excerpt("pro_10.csv")).unwrap();
    std::fs::write(&pro, text.replacen("0.1811023622047244", "fast", 1)).unwrap();
    let out = host_sim()
        .args(["import", "borealtc"])
        .arg(excerpt("imu_10.csv"))
        .arg(&pro)
        .arg("--out")
        .arg(d.join("bad"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("pro_10.csv:2: velR: `fast` is not a number"),
        "{err}"
    );
    assert!(!d.join("bad").exists());
}
