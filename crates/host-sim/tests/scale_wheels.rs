//! The scale informs the filter: a camera frame pair in which the scale
//! pipeline finds the wheels slipping or an outlier makes the EKF refuse the
//! wheels' forward rows over the next frame interval
//! (`traction::estimator::wheel_distrust`, `EgoEkf::distrust_wheels_until`).
//! The simulated slip run (wheel-spin episodes, a stuck episode, carpet) is
//! replayed with and without the link: with it, every wheel sample inside a
//! verdict's window is counted as distrusted and none of them is fused on
//! its forward rows; without it, none is distrusted and the filter fuses
//! wheel samples the scale pipeline had judged.

mod common;

use host_sim::asl::read_dataset;
use host_sim::replay::{ReplayOptions, replay_with};
use host_sim::simulate::run_simulate;
use serde_json::Value;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-scale-wheels", name)
}

/// `(from, until]` of every verdict against the wheels: one frame interval
/// after the pair's second frame.
fn windows(report: &Value) -> Vec<(u64, u64)> {
    report["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["slip_exceeded"] == true || f["wheel_outlier"] == true)
        .map(|f| {
            let (t0, t1) = (f["t0"].as_u64().unwrap(), f["t"].as_u64().unwrap());
            (t1, t1 + (t1 - t0))
        })
        .collect()
}

fn counts(report: &Value, key: &str) -> (u64, u64, u64) {
    let c = &report["final"][key];
    (
        c["seen"].as_u64().unwrap(),
        c["fused"].as_u64().unwrap(),
        c["gated"].as_u64().unwrap(),
    )
}

#[test]
fn slip_verdicts_refuse_the_wheels_in_the_filter() {
    let root = tmp("slip");
    let with = run_simulate("slip", 1, &root, false).unwrap();
    let ds = read_dataset(&root.join("dataset")).unwrap();
    let cut = replay_with(
        &ds,
        &root.join("dataset"),
        false,
        ReplayOptions {
            wheel_distrust: false,
            ..ReplayOptions::default()
        },
    )
    .unwrap();

    // The wheel samples (after the first, which only anchors the counts)
    // the verdicts' windows cover; windows overlap when verdicts follow
    // each other, a sample counts once.
    let w = windows(&with.report);
    println!("frame pairs judging the wheels: {}", w.len());
    assert!(w.len() >= 20);
    let (_, ticks) = ds.wheel.as_ref().unwrap();
    let covered = ticks
        .iter()
        .skip(1)
        .filter(|s| w.iter().any(|&(a, b)| s.t.0 > a && s.t.0 <= b))
        .count() as u64;

    let (seen, fused, gated) = counts(&with.report, "wheel_distrusted");
    println!("distrusted wheel samples: {seen} (fused {fused}, gated {gated}); covered {covered}");
    assert_eq!(seen, covered);
    assert_eq!((fused, gated), (0, seen));
    assert_eq!(counts(&cut.report, "wheel_distrusted").0, 0);

    // Cut, the filter fuses some of those samples: its gate alone passes
    // wheels the scale pipeline had found slipping.
    let fused_of = |r: &Value| r["filter_counts"]["wheel"]["fused"].as_u64().unwrap();
    let (a, b) = (fused_of(&with.report), fused_of(&cut.report));
    println!("wheel samples fused: with the link {a}, cut {b}");
    assert!(b > a, "with {a}, cut {b}");
    // Every sample still ends in one count of the estimator's wheel tally.
    for r in [&with.report, &cut.report] {
        let c = &r["counts"]["wheel"];
        assert_eq!(c["seen"].as_u64().unwrap(), ticks.len() as u64);
    }
}
