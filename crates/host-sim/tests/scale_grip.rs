//! The floor informs the scale: the surface model's grip under the wheels
//! scales the scale pipeline's wheel confidence (`Estimator::process_camera`
//! hands it to `ScalePipeline::set_wheel_grip`). The simulated office run
//! (wood, carpet, tile and threshold strips) is replayed with and without the
//! surface model: on carpet the wheels get clearly less confidence with it,
//! on wood the same.

mod common;

use host_sim::asl::read_dataset;
use host_sim::replay::{ReplayOptions, replay_with};
use host_sim::simulate::run_simulate;
use serde_json::Value;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-scale-grip", name)
}

/// `(t ns, wheel confidence)` of every frame pair.
fn wheel_confidences(report: &Value) -> Vec<(u64, f64)> {
    report["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            (
                f["t"].as_u64().unwrap(),
                f["wheel_confidence"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// The grip of the surface timeline's latest entry at or before `t`.
fn grip_at(timeline: &[Value], t: u64) -> Option<f64> {
    timeline
        .iter()
        .take_while(|e| e["t"].as_u64().is_some_and(|s| s <= t))
        .last()
        .and_then(|e| e["grip"].as_f64())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn low_grip_floors_lower_the_wheel_confidence() {
    let root = tmp("office");
    let with = run_simulate("office", 1, &root, false).unwrap();
    let ds = read_dataset(&root.join("dataset")).unwrap();
    let without = replay_with(
        &ds,
        &root.join("dataset"),
        false,
        ReplayOptions {
            surface_model: false,
            ..ReplayOptions::default()
        },
    )
    .unwrap();
    let timeline = with.report["surface_timeline"].as_array().unwrap().clone();
    let (a, b) = (
        wheel_confidences(&with.report),
        wheel_confidences(&without.report),
    );
    assert_eq!(a.len(), b.len());
    let (mut low, mut firm) = (Vec::new(), Vec::new());
    for ((t, ca), (tb, cb)) in a.iter().zip(&b) {
        assert_eq!(t, tb);
        if *cb < 0.2 {
            continue; // slipping: both near zero
        }
        match grip_at(&timeline, *t) {
            Some(g) if g < 0.75 => low.push(ca / cb),
            Some(g) if g >= 0.9 => firm.push(ca / cb),
            _ => {}
        }
    }
    println!("low-grip pairs {}, firm pairs {}", low.len(), firm.len());
    assert!(low.len() >= 20 && firm.len() >= 100);
    let (ml, mf) = (median(low), median(firm));
    println!(
        "median wheel confidence with / without the surface model: low grip {ml:.3}, firm {mf:.3}"
    );
    assert!(ml < 0.85, "low grip: {ml}");
    assert!((mf - 1.0).abs() < 0.02, "firm: {mf}");
}
