//! Chaos in CI: five minutes of the shuttle drive with faults of every kind
//! drawn at random (seed 1, six a minute, several at once at times), against
//! the fault-free run of the same drive (`host-sim simulate --chaos 1
//! --duration 300`). Asserted: at every IMU step the state finite, the
//! covariance (the pose clone's rows included) symmetric positive definite, each stream's
//! count equal to the samples that reached the estimator and no count going
//! backwards; after every cluster of faults the wheels and the flow sensor
//! fused again within 2 s; every spoiled sample ended as its fault's kind
//! expects; every cluster's error within 1.2x the fault-free run's (2 cm
//! floor); the report's `chaos` section consistent with the run.

use host_sim::chaos::{ChaosConfig, run_chaos};
use serde_json::Value;

mod common;

#[test]
fn five_minutes_of_chaos_keep_every_invariant() {
    let out = common::scratch("traction-chaos", "300s");
    let config = ChaosConfig {
        seed: 1,
        duration_s: 300.0,
        per_minute: 6.0,
    };
    let run = run_chaos(config, 1, &out, false).unwrap();
    eprint!("{}", run.summary());
    let h = run.health();
    assert!(h.steps > 70_000, "{h:?}");
    assert_eq!(
        (h.non_finite, h.not_spd, h.clone_not_spd),
        (0, 0, 0),
        "{h:?}"
    );
    assert_eq!((h.counts_unbalanced, h.counts_backwards), (0, 0), "{h:?}");
    assert!(
        run.lockouts().is_empty(),
        "wheels or flow out for more than 2 s"
    );
    // A draw of this size meets most kinds, overlapping.
    assert!(run.plan.faults.len() >= 20, "{}", run.plan.faults.len());
    assert!(run.most_at_once >= 2);
    assert!(run.clusters.len() >= 10);
    // Every spoiled sample ends as its kind expects.
    let injected: u32 = run.run.results.iter().map(|r| r.injected).sum();
    let expected: u32 = run.run.results.iter().map(|r| r.as_expected).sum();
    assert!(
        injected > 200 && expected == injected,
        "{expected} of {injected}"
    );
    // Every cluster recovered.
    let over = run.not_recovered();
    assert!(over.is_empty(), "{over:?}");
    assert!(run.ok());
    // report.json as written.
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let c = &report["chaos"];
    assert_eq!(c["faults"], run.plan.faults.len());
    assert_eq!(c["clusters"].as_array().unwrap().len(), run.clusters.len());
    assert_eq!(c["ok"], run.ok());
    assert_eq!(report["faults"]["plan"], run.plan.to_string());
    let worst = c["worst"]["command"].as_str().unwrap();
    assert!(
        worst.starts_with("host-sim simulate --scenario shuttle --duration 300 --seed 1 --faults ")
    );
    // The fault-free run is beside it.
    assert!(out.join("free/report.json").exists());
}

/// An hour's chaos plans, through the simulated encoders and the real
/// driver: every read either gives ticks or fails with a reason that a
/// fault of the plan explains (the read just after a wrap-around window
/// still sees its last jump); none aborts the generation.
#[test]
fn an_hour_of_chaos_plans_goes_through_the_encoder_driver() {
    use host_sim::chaos::draw;
    use host_sim::sim::drivers::wheels_through_driver_with;
    use host_sim::sim::motion::integrate;
    use host_sim::sim::sensors::wheel_angles;
    use host_sim::simulate::scenario_for;
    for seed in 1..=3 {
        let sc = scenario_for("shuttle", Some(3600.0)).unwrap();
        let config = ChaosConfig {
            seed,
            duration_s: 3600.0,
            per_minute: 6.0,
        };
        let plan = draw(&config, &sc);
        let driven = host_sim::faults::scenario::apply(&plan, &sc);
        let truth = integrate(&driven.world, &driven.script, &driven.robot);
        let reads = wheels_through_driver_with(&wheel_angles(&truth, driven.wheel_rate_hz), &plan)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert!(
            !reads.failed.is_empty() && reads.samples.len() > 170_000,
            "seed {seed}"
        );
    }
}
