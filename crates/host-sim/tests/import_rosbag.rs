//! `host-sim import rosbag` on the committed bag (`data/real/rl/test2.bag`,
//! robot_localization's test bag, BSD-3-Clause; bz2 chunks), then `replay`.
//! Figures checked against the data's README: message counts, the stamp
//! grids, the mean vertical specific force, the odometry's path length.

use std::path::{Path, PathBuf};
use std::process::Command;

fn host_sim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("host-sim-import-rb-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn bag() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/real/rl/test2.bag")
}

fn rows(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect()
}

fn import(bag: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    host_sim()
        .args(["import", "rosbag"])
        .arg(bag)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn the_bag_imports_and_replays() {
    let d = tmp("ok");
    let imp = import(&bag(), &d.join("ds"), &[]);
    assert!(
        imp.status.success(),
        "{}",
        String::from_utf8_lossy(&imp.stderr)
    );
    let imu = rows(&d.join("ds/mav0/imu0/data.csv"));
    let wheel = rows(&d.join("ds/mav0/wheel0/data.csv"));
    assert_eq!((imu.len(), wheel.len()), (3061, 3060));
    // Header stamps: IMU on a 20 ms grid from 47.58 s, odometry 4 ms after.
    assert_eq!(imu[0][0], 47_580_000_000.0);
    assert_eq!(wheel[0][0], 47_584_000_000.0);
    assert!(imu.windows(2).all(|w| w[1][0] - w[0][0] == 20_000_000.0));
    let mean_az = imu.iter().map(|r| r[6]).sum::<f64>() / imu.len() as f64;
    assert!((mean_az - 9.75).abs() < 0.01, "mean az {mean_az}");
    // The odometry's path length, 84 m, from the wheel rates' mean rim speed.
    let r = 0.098;
    let path: f64 = wheel
        .windows(2)
        .map(|w| 0.5 * r * (w[1][1] + w[1][2]).abs() * (w[1][0] - w[0][0]) * 1e-9)
        .sum();
    assert!((path - 84.0).abs() < 1.0, "path {path} m");
    let yaml = std::fs::read_to_string(d.join("ds/mav0/wheel0/sensor.yaml")).unwrap();
    assert!(yaml.contains("wheel_radius_left: 0.098") && yaml.contains("wheel_base: 0.37559"));
    let labels = std::fs::read_to_string(d.join("ds/labels.yaml")).unwrap();
    assert!(
        labels.contains("T_BS identity") && labels.contains("reference: \"none\""),
        "{labels}"
    );

    let rep = host_sim()
        .arg("replay")
        .arg(d.join("ds"))
        .arg("--out")
        .arg(d.join("out"))
        .output()
        .unwrap();
    assert!(
        rep.status.success(),
        "{}",
        String::from_utf8_lossy(&rep.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/report.json")).unwrap()).unwrap();
    assert_eq!(report["counts"]["imu"]["seen"], 3061);
    assert_eq!(report["counts"]["wheel"]["seen"], 3060);
}

#[test]
fn bad_bags_and_topics_exit_2() {
    let d = tmp("bad");
    let bytes = std::fs::read(bag()).unwrap();
    let cut = d.join("cut.bag");
    std::fs::write(&cut, &bytes[..100_000]).unwrap();
    let out = import(&cut, &d.join("a"), &[]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cut.bag") && err.contains("index_pos"),
        "{err}"
    );

    let text = d.join("text.bag");
    std::fs::write(&text, "time,a\n0,1\n").unwrap();
    let out = import(&text, &d.join("b"), &[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("format 2.0"));

    let out = import(&bag(), &d.join("c"), &["--imu-topic", "/nope"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no topic `/nope`"));
    let out = import(
        &bag(),
        &d.join("c"),
        &["--imu-topic", "/jackal_velocity_controller/odom"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not sensor_msgs/Imu"));
    assert!(!d.join("c").exists());
}
