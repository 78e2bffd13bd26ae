//! `simulate --drive waypoints`: the navigator drives the simulated robot in
//! closed loop on the estimator's answers. It reaches a short route's
//! waypoints by the truth; cut from the estimates it never sets off; at the
//! office's cable it stops, backs off, goes round and still reaches the
//! waypoint beyond, while the fixed-threshold robot stops too.

mod common;

use host_sim::closed_loop::{LoopOptions, run_waypoints};
use host_sim::sim::scenario::Scenario;
use traction::navigate::Policy;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-closed-loop", name)
}

/// An L on the wood before the cable: 1.2 m ahead, a quarter turn, 0.5 m left.
const L_ROUTE: [[f32; 2]; 2] = [[1.2, 0.0], [1.2, -0.5]];

#[test]
fn the_navigator_reaches_a_route_on_the_estimates_and_not_without_them() {
    let sc = Scenario::by_name("office").unwrap();
    let options = LoopOptions {
        max_s: 20.0,
        ..LoopOptions::default()
    };
    let out = tmp("l");
    let run = run_waypoints(&sc, 1, &L_ROUTE, options, &out).unwrap();
    assert!(run.all_within(0.10), "{}", run.summary(&L_ROUTE));
    assert!(run.stops.is_empty(), "{}", run.summary(&L_ROUTE));
    assert!(run.duration_s < 20.0, "it finished: {}", run.duration_s);
    assert!(out.join("nav.json").is_file() && out.join("ekf.tum").is_file());

    let cut = LoopOptions {
        estimates: false,
        ..options
    };
    let run = run_waypoints(&sc, 1, &L_ROUTE, cut, &tmp("cut")).unwrap();
    assert!(
        run.reached.iter().all(Option::is_none),
        "{}",
        run.summary(&L_ROUTE)
    );
    let last = run.path.last().unwrap();
    assert!(last[1].hypot(last[2]) < 0.01, "the robot stood: {last:?}");
}

#[test]
fn at_the_cable_both_robots_stop_and_the_floor_aware_one_goes_round() {
    let sc = Scenario::by_name("office").unwrap();
    let route = [[2.8f32, 0.0]];
    let options = LoopOptions {
        max_s: 40.0,
        ..LoopOptions::default()
    };
    let run = run_waypoints(&sc, 2, &route, options, &tmp("cable")).unwrap();
    assert_eq!(run.stops_at("cable"), 1, "{}", run.summary(&route));
    assert_eq!(run.stops.len(), 1, "{}", run.summary(&route));
    assert!(run.all_within(0.10), "{}", run.summary(&route));
    // Round the cable's end (it lies from y = -0.6 m to 0.6 m).
    let widest = run.path.iter().map(|p| p[2].abs()).fold(0.0, f64::max);
    assert!(widest > 0.6, "{widest}");

    let fixed = LoopOptions {
        policy: Policy::FixedThreshold { threshold: 2.0 },
        ..options
    };
    let run = run_waypoints(&sc, 2, &route, fixed, &tmp("cable-fixed")).unwrap();
    assert!(run.stops_at("cable") >= 1, "{}", run.summary(&route));
}
