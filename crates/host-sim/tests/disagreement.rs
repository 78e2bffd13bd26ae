//! Each sensor against the fused motion (`traction::disagreement`) on the
//! slip scenario: the wheels disagree on the frame pairs where they slip,
//! and only there; the camera, the flow sensor and the IMU hardly ever, and
//! never on a slipping pair; every check is counted once.

use host_sim::simulate::run_simulate;
use serde_json::Value;

mod common;

/// The frames on which `sensor` disagreed, and of them those whose pair the
/// scale pipeline found slipping.
fn disagreeing(frames: &[Value], sensor: &str) -> (usize, usize) {
    let on = |f: &&Value| {
        f["disagree"]
            .as_array()
            .is_some_and(|a| a.iter().any(|s| s == sensor))
    };
    let all = frames.iter().filter(on).count();
    let slipping = frames
        .iter()
        .filter(on)
        .filter(|f| f["slip_exceeded"] == true)
        .count();
    (all, slipping)
}

#[test]
fn on_the_slip_scenario_the_wheels_disagree_where_they_slip() {
    let root = common::scratch("host-sim-disagreement", "slip");
    let out = run_simulate("slip", 1, &root, false).unwrap();
    let r = &out.report;
    let frames = r["frames"].as_array().unwrap();
    let slipping = frames.iter().filter(|f| f["slip_exceeded"] == true).count();
    assert!(slipping > 50, "{slipping}");

    let (wheel, wheel_on_slip) = disagreeing(frames, "wheel");
    println!("wheel disagreements {wheel}, on slipping pairs {wheel_on_slip} of {slipping}");
    assert!(wheel >= slipping * 8 / 10, "{wheel} of {slipping}");
    assert!(
        wheel_on_slip * 10 >= wheel * 9,
        "{wheel_on_slip} of {wheel}"
    );
    for sensor in ["camera", "flow", "imu"] {
        let (n, on_slip) = disagreeing(frames, sensor);
        println!("{sensor} disagreements {n}, on slipping pairs {on_slip}");
        assert_eq!(on_slip, 0, "{sensor}");
        assert!(n * 20 < frames.len(), "{sensor}: {n}");
    }

    // Every pair checked once per sensor; the counts match the frames.
    let sensors = r["disagreement"]["sensors"].as_object().unwrap();
    for (name, c) in sensors {
        let skipped: u64 = c["skipped"]
            .as_object()
            .unwrap()
            .values()
            .map(|v| v.as_u64().unwrap())
            .sum();
        let total = c["agree"].as_u64().unwrap() + c["disagree"].as_u64().unwrap() + skipped;
        assert_eq!(total as usize, frames.len(), "{name}: {c}");
        let (n, _) = disagreeing(frames, name);
        assert_eq!(c["disagree"].as_u64().unwrap() as usize, n, "{name}");
    }
    // The wheels' disagreements reached the memory, one per episode.
    assert!(sensors["wheel"]["recorded"].as_u64().unwrap() >= 4);
}
