//! `host-sim simulate` and `host-sim replay` as a user runs them.

mod common;
use common::host_sim;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-cli-replay", name)
}

#[test]
fn simulate_then_replay_prints_the_summary_and_writes_every_file() {
    let out = tmp("ok");
    let sim = host_sim()
        .args(["simulate", "--scenario", "short", "--seed", "4", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    common::assert_ok(&sim);
    let text = String::from_utf8_lossy(&sim.stdout);
    for row in [
        "ekf ",
        "vslam ",
        "wheel_only ",
        "scale decisions",
        "events:",
    ] {
        assert!(text.contains(row), "summary lacks `{row}`:\n{text}");
    }
    let again = out.join("again");
    common::replay(&out.join("dataset"), &again, &[]);
    for f in [
        "ekf.tum",
        "vslam.tum",
        "wheel_only.tum",
        "groundtruth.tum",
        "report.json",
        "trajectory.svg",
    ] {
        let (a, b) = (
            std::fs::read(out.join(f)).unwrap(),
            std::fs::read(again.join(f)).unwrap(),
        );
        assert!(a == b, "{f}: simulate's and replay's outputs differ");
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn bad_input_exits_2_naming_the_file() {
    let out = tmp("bad");
    let r = host_sim()
        .args(["replay", "/no/such/dataset", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("/no/such/dataset"));
    let r = host_sim()
        .args(["simulate", "--scenario", "moon", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("unknown scenario `moon`"));
    let _ = std::fs::remove_dir_all(&out);
}
