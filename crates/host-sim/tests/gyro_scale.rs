//! The gyro's z scale factor estimated as part of the model: the `spin`
//! scenario (ten turns in place at 1 rad/s) simulated with a gyro that
//! reads 1 % too much, replayed with the scale-factor state
//! (`ImuConfig::estimate_gyro_scale`) and without it. With it, the heading
//! after the ten turns is several degrees closer to the truth, the
//! estimated factor is near the simulated one, and the yaw rate the
//! estimate reports is the corrected rate: within a fraction of the 1 %
//! error of the raw gyro's.

mod common;

use host_sim::asl::{Dataset, read_dataset};
use host_sim::replay::{ReplayOptions, ReplayOutput, replay_with};
use host_sim::sim::scenario::Scenario;
use host_sim::simulate::simulate_scenario_with;

const SCALE_ERROR: f64 = 0.01;

/// The span of the turns the rates are averaged over (the robot turns from
/// 1 s to about 64 s), ns.
const SPAN: (u64, u64) = (5_000_000_000, 60_000_000_000);

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-gyro-scale", name)
}

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

fn in_span(t: u64) -> bool {
    (SPAN.0..=SPAN.1).contains(&t)
}

/// The true mean yaw rate over [`SPAN`], from the ground truth's yaw.
fn true_rate(ds: &Dataset) -> f64 {
    let gt: Vec<_> = ds
        .groundtruth
        .as_ref()
        .unwrap()
        .iter()
        .filter(|g| in_span(g.t.0))
        .collect();
    let yaw = |q: [f64; 4]| 2.0 * q[3].atan2(q[0]);
    let turned: f64 = gt
        .windows(2)
        .map(|w| wrap(yaw(w[1].q_wxyz) - yaw(w[0].q_wxyz)))
        .sum();
    let (a, b) = (gt.first().unwrap().t.0, gt.last().unwrap().t.0);
    turned / ((b - a) as f64 * 1e-9)
}

/// The raw gyro's mean z rate over [`SPAN`] less the true bias.
fn raw_rate(ds: &Dataset) -> f64 {
    let bias = ds.groundtruth.as_ref().unwrap()[0].bias_gyro[2];
    let z: Vec<f64> = ds
        .imu
        .as_ref()
        .unwrap()
        .1
        .iter()
        .filter(|s| in_span(s.t.0))
        .map(|s| f64::from(s.gyro[2]))
        .collect();
    z.iter().sum::<f64>() / z.len() as f64 - bias
}

/// The estimate's mean reported yaw rate over [`SPAN`].
fn reported_rate(r: &ReplayOutput) -> f64 {
    let w: Vec<f64> = r
        .ekf
        .iter()
        .zip(&r.yaw_rate)
        .filter(|(p, _)| in_span(p.t.0))
        .map(|(_, w)| f64::from(*w))
        .collect();
    assert!(w.len() > 10_000, "{} rates", w.len());
    w.iter().sum::<f64>() / w.len() as f64
}

fn ekf_final_yaw_deg(r: &ReplayOutput) -> f64 {
    r.errors
        .iter()
        .find(|(n, _)| *n == "ekf")
        .unwrap()
        .1
        .final_yaw_error_deg
}

#[test]
fn the_scale_factor_state_removes_the_heading_error_of_ten_turns() {
    let root = tmp("spin");
    let mut sc = Scenario::by_name("spin").unwrap();
    sc.imu.gyro_scale_error = SCALE_ERROR;
    let on = ReplayOptions {
        gyro_scale: true,
        ..ReplayOptions::default()
    };
    let with = simulate_scenario_with(&sc, 1, &root, false, on).unwrap();
    let ds = read_dataset(&root.join("dataset")).unwrap();
    let without = replay_with(&ds, &root.join("dataset"), false, ReplayOptions::default()).unwrap();
    let k = |r: &ReplayOutput| r.report["final"]["gyro_scale"].as_f64().unwrap();
    let (yaw_with, yaw_without) = (ekf_final_yaw_deg(&with), ekf_final_yaw_deg(&without));
    let truth = true_rate(&ds);
    let rel = |w: f64| (w - truth) / truth;
    let (raw, rep_with, rep_without) = (
        rel(raw_rate(&ds)),
        rel(reported_rate(&with)),
        rel(reported_rate(&without)),
    );
    println!(
        "final yaw error: with the scale state {yaw_with:.2} deg (k = {:.5}), without {yaw_without:.2} deg (k = {:.5})",
        k(&with),
        k(&without)
    );
    println!(
        "mean yaw rate over the turns against the truth ({truth:.4} rad/s): raw gyro {:+.3} %, \
         reported with the state {:+.3} %, without {:+.3} %",
        100.0 * raw,
        100.0 * rep_with,
        100.0 * rep_without
    );
    // The simulated error is there: the raw gyro turns 1 % too fast.
    assert!((raw - SCALE_ERROR).abs() < 0.002, "raw gyro {raw}");
    // Estimated, near the simulated factor; not estimated, left at zero.
    assert!((k(&with) - SCALE_ERROR).abs() < 0.003, "k = {}", k(&with));
    assert_eq!(k(&without), 0.0);
    // The heading after ten turns: several degrees better with the state.
    assert!(
        yaw_with.abs() + 4.0 < yaw_without.abs(),
        "final yaw error {yaw_with} deg with the state, {yaw_without} deg without"
    );
    // The reported rate is the corrected one: a small fraction of the raw
    // gyro's error, and smaller than without the state.
    assert!(
        rep_with.abs() < 0.25 * raw.abs(),
        "reported {rep_with}, raw {raw}"
    );
    assert!(rep_with.abs() < rep_without.abs());
    let _ = std::fs::remove_dir_all(&root);
}
