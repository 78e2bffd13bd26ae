//! The flow sensor on demand (`--flow on-demand`, `traction::flow_demand`)
//! on the slip scenario: the log of one simulated run is replayed with the
//! sensor always on and on demand. On demand it is on for clearly less than
//! the whole run, woken by the slip episodes, and the filter's trajectory
//! error stays within 5 % of the always-on run's (or below it).

mod common;

use host_sim::asl::read_dataset;
use host_sim::replay::{ReplayOptions, ReplayOutput, replay_with};
use host_sim::simulate::run_simulate;
use traction::flow_demand::FlowDemandConfig;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-flow-demand", name)
}

fn ekf_error(o: &ReplayOutput) -> (f64, f64) {
    let e = &o.errors.iter().find(|(n, _)| *n == "ekf").unwrap().1;
    (e.ate_rmse, e.ate_se2_rmse)
}

#[test]
fn on_demand_saves_flow_time_and_keeps_the_slip_accuracy() {
    let root = tmp("slip");
    let always = run_simulate("slip", 1, &root, false).unwrap();
    let ds = read_dataset(&root.join("dataset")).unwrap();
    let on_demand = replay_with(
        &ds,
        &root.join("dataset"),
        false,
        ReplayOptions {
            flow_demand: Some(FlowDemandConfig::default()),
            ..ReplayOptions::default()
        },
    )
    .unwrap();

    let a = &always.report["flow_power"];
    let d = &on_demand.report["flow_power"];
    assert_eq!(a["mode"], "always");
    assert_eq!(d["mode"], "on-demand");
    let flow_s = a["flow_s"].as_f64().unwrap();
    let on_s = d["on_s"].as_f64().unwrap();
    assert!(flow_s > 50.0, "{a}");
    assert!(on_s > 0.0 && on_s < 0.9 * flow_s, "{d}");
    assert!(d["wakes"].as_u64().unwrap() >= 1, "{d}");
    assert!(d["reports_off"].as_u64().unwrap() > 0, "{d}");
    // The reports that reached the filter are the ones passed.
    assert_eq!(
        on_demand.report["counts"]["flow"]["seen"].as_u64(),
        d["reports_passed"].as_u64(),
        "{}",
        on_demand.report["counts"]["flow"]
    );

    let (a_first, a_se2) = ekf_error(&always);
    let (d_first, d_se2) = ekf_error(&on_demand);
    assert!(d_first <= 1.05 * a_first, "ATE {d_first} vs {a_first}");
    assert!(d_se2 <= 1.05 * a_se2, "SE(2) ATE {d_se2} vs {a_se2}");
}
