//! Fault injection end to end (issue 8): every fault kind on the office
//! scenario cut to 9.5 s (seed 3), against the fault-free run of the same
//! seed. Each test shows
//! - no panic; every nominal state value finite and the covariance
//!   symmetric positive definite after every IMU step (`Health`);
//! - every spoiled sample ended in the expected outcome, and the counts in
//!   `report.json` grew by exactly the number injected under that reason
//!   (against the fault-free run, for every reason other than `gated`);
//! - recovery: the EKF's planar position error at the end of the fault
//!   window + 2 s is at most 1.2 x the fault-free run's at the same time,
//!   with a 2 cm floor (`host_sim::faults::recovery`);
//! - no lockout: in the last second of the run the wheel and flow samples
//!   are fused again.
//!
//! Numbers: `cargo test -p host-sim --test faults -- --nocapture` prints one
//! line per fault.

use host_sim::asl::read_dataset;
use host_sim::faults::recovery::Recovery;
use host_sim::faults::{Expected, FaultKind, FaultPlan, Stream};
use host_sim::replay::replay;
use host_sim::simulate::{FaultRun, simulate_faults};

use host_sim::sim::scenario::Scenario;
use serde_json::Value;
use std::collections::BTreeMap;
use std::sync::OnceLock;
use traction::vslam_core::Reject;

mod common;

const SEED: u64 = 3;
const DURATION_S: f64 = 9.5;

fn scenario() -> Scenario {
    let mut s = Scenario::by_name("short").unwrap();
    s.script.duration = DURATION_S;
    s
}

/// A run and its `report.json` as written.
struct Run {
    run: FaultRun,
    report_json: String,
}

impl std::ops::Deref for Run {
    type Target = FaultRun;
    fn deref(&self) -> &FaultRun {
        &self.run
    }
}

impl Run {
    fn report_json_value(&self) -> Value {
        serde_json::from_str(&self.report_json).unwrap()
    }
}

fn run(plan: &str) -> Run {
    let name: String = plan
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    // Two tests may run the same plan at once: each run gets its own folder.
    let dir = common::scratch(
        "host-sim-faults",
        if name.is_empty() { "free" } else { &name },
    );
    let plan: FaultPlan = plan.parse().unwrap();
    let run = simulate_faults(&scenario(), SEED, &dir, false, &plan).unwrap();
    let report_json = std::fs::read_to_string(dir.join("report.json")).unwrap();
    Run { run, report_json }
}

fn free() -> &'static Run {
    static FREE: OnceLock<Run> = OnceLock::new();
    FREE.get_or_init(|| run(""))
}

fn count(report: &Value, stream: Stream, reason: Reject) -> u64 {
    report["counts"][stream.name()]["rejected"][reason.name()]
        .as_u64()
        .unwrap_or(0)
}

fn fused_share_at_end(run: &Run, stream: Stream) -> f64 {
    let end = run.output.outcomes.iter().map(|o| o.1.0).max().unwrap_or(0);
    let last: Vec<_> = run
        .output
        .outcomes
        .iter()
        .filter(|o| o.0 == stream && o.1.0 + 1_000_000_000 >= end)
        .collect();
    last.iter().filter(|o| o.2 == "fused").count() as f64 / last.len().max(1) as f64
}

/// Runs `plan` and checks everything the module docs list; returns the run
/// and its recovery judgement.
fn check(plan: &str) -> (Run, Recovery) {
    let free = free();
    let run = run(plan);
    let h = run.output.health;
    assert!(h.steps > 1000, "{plan}: only {} steps checked", h.steps);
    assert!(h.ok(), "{plan}: unhealthy filter {h:?}");
    // report.json as written.
    let on_disk: Value = serde_json::from_str(&run.report_json).unwrap();
    assert_eq!(on_disk["faults"]["plan"], plan);
    let mut injected_by: BTreeMap<(Stream, Reject), u64> = BTreeMap::new();
    for (spec, r) in run.log.plan.faults.iter().zip(&run.results) {
        // A cable is a change of the floor, not a spoiled sample; a rate
        // spike within what the robot can do is not judged.
        if !matches!(spec.kind, FaultKind::Bump | FaultKind::ImuOutlier) {
            assert!(r.injected > 0, "{plan}: nothing injected: {r:?}");
        }
        assert_eq!(
            r.as_expected, r.injected,
            "{plan}: {} spoiled samples, {} as expected ({}): {:?}",
            r.injected, r.as_expected, r.expected, r.observed
        );
        if let Expected::Reject(reason) = spec.kind.expected()
            && reason != Reject::Gated
            && let Some(stream) = spec.kind.stream()
        {
            *injected_by.entry((stream, reason)).or_default() += r.injected as u64;
        }
    }
    for ((stream, reason), n) in injected_by {
        let grown =
            count(&on_disk, stream, reason) - count(&free.report_json_value(), stream, reason);
        assert_eq!(
            grown,
            n,
            "{plan}: report.json counts {} {} grew by {grown}, {n} injected",
            stream.name(),
            reason.name(),
        );
    }
    let end = run.results.iter().map(|r| r.window_end_ns).max().unwrap();
    let rec = Recovery::judge(
        (&run.output.ekf, &run.truth),
        (&free.output.ekf, &free.truth),
        end,
    )
    .unwrap();
    // One entry per fault of the plan: spoiled samples, expected outcome, observed.
    let per_fault: Vec<String> = run
        .results
        .iter()
        .map(|r| format!("{} x {} observed {:?}", r.injected, r.expected, r.observed))
        .collect();
    eprintln!(
        "{plan:<24} {}; e_fault({:.1} s) = {:.3} m, e_free = {:.3} m, bound {:.3} m",
        per_fault.join(" | "),
        rec.at_ns as f64 * 1e-9,
        rec.faulted,
        rec.free,
        rec.bound()
    );
    (run, rec)
}

fn check_recovers(plan: &str) -> Run {
    let (run, rec) = check(plan);
    assert!(
        rec.recovered(),
        "{plan}: error {:.3} m at {:.1} s, fault-free {:.3} m, bound {:.3} m",
        rec.faulted,
        rec.at_ns as f64 * 1e-9,
        rec.free,
        rec.bound()
    );
    for s in [Stream::Wheel, Stream::Flow] {
        let share = fused_share_at_end(&run, s);
        assert!(share > 0.5, "{plan}: {} locked out? {share}", s.name());
    }
    run
}

#[test]
fn fault_free_run_is_healthy_and_injects_nothing() {
    let f = free();
    assert!(f.output.health.ok() && f.output.health.steps > 2000);
    assert!(f.log.injected.is_empty());
    assert_eq!(f.output.report["faults"]["faults"], serde_json::json!([]));
}

// ---- values ----

#[test]
fn imu_nan_and_inf() {
    check_recovers("imu-nan@4x3,imu-inf@4.5");
}

#[test]
fn imu_outlier_in_the_yaw_rate_is_refused_while_driving_straight() {
    // Driving straight (yaw rate about 0.005 rad/s), a hundredfold yaw rate
    // (about 0.5 rad/s) is within what the whole rate may change between
    // two readings (0.7 rad/s) but not the yaw rate (0.18 rad/s): refused.
    // (A spike while turning is beyond both: `ego-ekf/tests/accounting.rs`,
    // and the chaos runs' turns.)
    let run = check_recovers("imu-outlier@4x3");
    let r = &run.results[0];
    println!("{r:?}");
    assert!(r.injected >= 1, "{r:?}");
    assert_eq!(r.observed.get("out_of_range"), Some(&r.injected), "{r:?}");
    let fused = |r: &Run| r.output.report["counts"]["imu"]["fused"].as_u64().unwrap();
    assert_eq!(fused(&run), fused(free()) - 3);
}

#[test]
fn imu_stuck_is_refused_once_frozen_for_20_ms() {
    let run = check_recovers("imu-stuck@4+0.5");
    let r = &run.results[0];
    // 0.5 s at 250 Hz: the repeats after the first 20 ms.
    assert!((115..=121).contains(&r.injected), "{r:?}");
    assert_eq!(r.observed.get("low_quality"), Some(&r.injected), "{r:?}");
}

// 0.2 s of saturated samples are rejected (counted `saturated`): an IMU gap
// for the filter, bridged like `imu_half_second_gap`.
#[test]
fn imu_saturated_recovers() {
    check_recovers("imu-saturated@4+0.2");
}

#[test]
fn imu_saturated() {
    check("imu-saturated@4+0.2");
}

#[test]
fn wheel_outlier() {
    // At 0.3 m/s a hundredfold increment is beyond any wheel speed.
    let run = check_recovers("wheel-outlier@4x3");
    let r = &run.results[0];
    assert_eq!(r.observed.get("out_of_range"), Some(&3), "{r:?}");
}

#[test]
fn flow_outlier_is_gated() {
    check_recovers("flow-outlier@4");
}

#[test]
fn flow_stuck() {
    check_recovers("flow-stuck@4+0.5");
}

#[test]
fn flow_counts_at_the_limit() {
    check_recovers("flow-limit@4x2");
}

#[test]
fn flow_low_squal_is_noise() {
    check_recovers("flow-lowsqual@4+1");
}

#[test]
fn flow_textureless_floor() {
    check_recovers("flow-textureless@4+0.5");
}

// ---- time ----

#[test]
fn duplicates() {
    check_recovers("imu-dup@4x2,wheel-dup@4.3,flow-dup@4.6");
}

#[test]
fn zero_dt() {
    check_recovers("imu-dt0@4,wheel-dt0@4.3,flow-dt0@4.6");
}

#[test]
fn out_of_order() {
    check_recovers("imu-late@4,wheel-late@4.3,flow-late@4.6");
}

#[test]
fn half_second_gaps() {
    check_recovers("wheel-gap@4+0.5,flow-gap@4+0.5");
}

// A wheel gap shorter than the odometry's largest step (0.5 s) but longer
// than the filter's (0.2 s): the odometry integrates across it, the filter
// refuses the one step over it.
#[test]
fn short_wheel_gap_costs_one_sample() {
    let run = check_recovers("wheel-gap@4+0.3");
    assert_eq!(run.results[0].injected, 1, "{:?}", run.results[0]);
}

// While the IMU is silent the filter does not propagate; the first sample
// after the silence is refused as a gap (dt > imu_max_dt, 20 ms) and first
// bridges it: the wheel samples that arrived meanwhile dead-reckon the
// heading and the path (`ego_ekf::gap`), so the turn driven during the
// silence is not lost. Counted as `gap`, the state finite, the covariance
// SPD, and the error back within the bound.
#[test]
fn imu_half_second_gap() {
    check_recovers("imu-gap@4+0.5");
}

#[test]
fn imu_gaps_are_counted_and_harmless_to_the_state() {
    check("imu-gap@4+0.5");
    check("imu-gap@2+5");
}

#[test]
fn imu_silent_for_five_seconds() {
    check_recovers("imu-gap@2+5");
}

#[test]
fn wheels_and_flow_silent_for_five_seconds() {
    check_recovers("wheel-gap@2+5");
    check_recovers("flow-gap@2+5");
}

// ---- bus and chip ----

#[test]
fn encoder_wrap_around_at_high_speed() {
    check_recovers("wheel-wrap@4+0.1");
}

#[test]
fn encoder_wrap_while_the_imu_is_stuck() {
    // The IMU refused, the wheels bridge the gap: the first wheel sample
    // after the wrap must not span the failed reads (the left's counts held
    // across them would read as a slow wheel and a turn).
    check_recovers("imu-stuck@4.03+0.74,wheel-wrap@4.275+0.15");
}

#[test]
fn a_replayed_log_breaks_the_odometry_where_its_reads_failed() {
    // The log keeps the drivers' failed reads (`mav0/wheel0/failed.csv`):
    // replaying it gives the run's estimate. Without them the first wheel
    // row after the wrap is a step across the failed reads, with the left's
    // counts held through them: a turn the robot did not make, while the
    // wheels bridge the refused IMU.
    let plan_text = "imu-stuck@4.03+0.74,wheel-wrap@4.275+0.15";
    let dir = common::scratch("host-sim-faults", "logged");
    let plan: FaultPlan = plan_text.parse().unwrap();
    let run = simulate_faults(&scenario(), SEED, &dir, false, &plan).unwrap();
    let root = dir.join("dataset");
    let mut ds = read_dataset(&root).unwrap();
    let wheel_failures = ds
        .failed
        .iter()
        .filter(|f| f.stream == Stream::Wheel)
        .count();
    assert!(wheel_failures > 0, "{:?}", ds.failed);
    let replayed = replay(&ds, &root, false).unwrap();
    ds.failed.clear();
    let cut = replay(&ds, &root, false).unwrap();
    assert_eq!(replayed.ekf, run.output.ekf);
    let end = run.results.iter().map(|r| r.window_end_ns).max().unwrap();
    let judge = |ekf: &[host_sim::tum::TumPose]| {
        Recovery::judge((ekf, &run.truth), (&free().output.ekf, &free().truth), end).unwrap()
    };
    let (with, without) = (judge(&replayed.ekf), judge(&cut.ekf));
    eprintln!(
        "{plan_text}: replayed {:.3} m, without failed.csv {:.3} m, bound {:.3} m",
        with.faulted,
        without.faulted,
        with.bound()
    );
    assert!(with.recovered() && !without.recovered());
}

#[test]
fn spi_errors() {
    check_recovers("wheel-spi@4x3,flow-spi@4.5x3");
}

#[test]
fn flow_chip_brownout_wrong_product_id() {
    check_recovers("flow-brownout@4");
}

#[test]
fn encoder_parity_and_error_flag() {
    check_recovers("wheel-parity@4x2,wheel-errflag@4.5");
}

// ---- vision ----

#[test]
fn bad_camera_frames() {
    for kind in ["cam-black", "cam-saturated", "cam-uniform", "cam-blur"] {
        check_recovers(&format!("{kind}@4"));
    }
    // Two in a row are bridged; four are not (the pair after is refused too).
    check_recovers("cam-black@4x2");
    check_recovers("cam-black@4x4");
}

#[test]
fn frozen_camera_frame() {
    check_recovers("cam-frozen@4");
}

#[test]
fn segmentation_without_ground() {
    check_recovers("seg-noground@4x2,seg-unknown@5.5x2");
}

// ---- motion ----

#[test]
fn stuck_with_wheels_spinning() {
    check_recovers("stuck@4+2");
}

#[test]
fn lifted_with_wheels_free() {
    check_recovers("lifted@4+2");
    // Longer than the re-examinations' rhythm: the flow's vague mean of
    // the floor standing still sides with the filter, not with the free
    // wheels, every 0.5 s the whole lift long.
    check_recovers("lifted@3+3");
}

// With the wheel counts frozen while the robot drives straight at constant
// speed on wood, the wheels say "stopped" and the IMU is quiet; a still
// detector that trusts those two runs zero-velocity updates while the valid
// flow reads 0.3 m/s (0.35 m off at window end + 2 s against 0.03 m
// fault-free, and it does not heal). The still detector also needs the flow,
// when recent and precise, not to see motion (`EgoEkf::flow_sees_motion`).
#[test]
fn wheel_counts_frozen() {
    check_recovers("wheel-stuck@4+0.5");
}

#[test]
fn wheel_counts_frozen_are_counted_and_harmless_to_the_state() {
    check("wheel-stuck@4+0.5");
}

#[test]
fn cable_bump_on_wood() {
    let (run, _) = check("bump@4");
    let jolts = run.output.report["events"].as_array().unwrap();
    assert!(
        jolts.iter().any(|e| e["t"]
            .as_u64()
            .is_some_and(|t| (3_800_000_000..4_600_000_000).contains(&t))),
        "no jolt at the cable: {jolts:?}"
    );
}

// A front end that takes a frame without trackable texture as its reference
// refuses the next good frame too: one black frame at 4 s costs the VSLAM
// trajectory 0.2 s of driving (final error 0.069 m against 0.009 m). The
// front end keeps the last good frame as the reference
// (`traction::frontend::MAX_BRIDGED_FRAMES`).
#[test]
fn one_bad_frame_costs_the_camera_path_nothing() {
    let run = run("cam-black@4");
    let final_error = |r: &Run| {
        r.output
            .errors
            .iter()
            .find(|(n, _)| *n == "vslam")
            .map(|(_, e)| e.final_error)
            .unwrap()
    };
    let (bad, good) = (final_error(&run), final_error(free()));
    assert!(
        bad <= 1.2 * good.max(0.02),
        "VSLAM final error {bad:.3} m with one black frame, {good:.3} m without"
    );
}
