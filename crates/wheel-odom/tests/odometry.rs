//! Differential-drive odometry: exact straight lines, rotations and arcs;
//! rejections with reasons, counted; no input panics.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::f32::consts::{PI, TAU};
use vslam_core::Reject;
use vslam_core::Timestamp;
use vslam_core::sensors::WheelTicks;
use wheel_odom::{DiffDriveOdometry, DiffDriveParams, ParamsError};

const MS: u64 = 1_000_000;
const TPR: u32 = 1_000;
const R: f32 = 0.035;
const BASE: f32 = 0.23;

fn odo() -> DiffDriveOdometry {
    DiffDriveOdometry::new(DiffDriveParams::new(TPR, R, R, BASE, 2.0, 500 * MS).unwrap())
}

fn ticks(ms: u64, left: i64, right: i64) -> WheelTicks {
    WheelTicks {
        t: Timestamp(ms * MS),
        left,
        right,
    }
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn straight_line_is_exact() {
    let mut o = odo();
    assert_eq!(o.update(ticks(0, 0, 0)), Ok(None));
    let s = o.update(ticks(20, 100, 100)).unwrap().unwrap();
    let d = 100.0 / TPR as f32 * TAU * R; // 0.02199 m
    assert!(close(s.delta.translation.x, d, 1e-7));
    assert_eq!(s.delta.translation.y, 0.0);
    assert_eq!(s.delta.dyaw, 0.0);
    assert!(close(s.delta.path_length, d, 1e-7));
    assert_eq!((s.delta.t0, s.delta.t1), (Timestamp(0), Timestamp(20 * MS)));
    let rate = 100.0 / TPR as f32 * TAU / 0.02;
    assert!(close(s.rates.left(), rate, 1e-4) && close(s.rates.right(), rate, 1e-4));
    assert!(close(s.velocity.forward, d / 0.02, 1e-5));
    assert_eq!(s.velocity.yaw_rate, 0.0);
    assert_eq!(o.counts().fused(), 2);
}

#[test]
fn pure_rotation_is_exact() {
    let mut o = odo();
    o.update(ticks(0, 0, 0)).unwrap();
    // Each wheel travels a quarter of the circle of radius BASE/2: a quarter turn.
    let wheel_m = PI / 2.0 * BASE / 2.0;
    let n = (wheel_m / (TAU * R) * TPR as f32).round() as i64; // 821
    let s = o.update(ticks(200, -n, n)).unwrap().unwrap();
    let dyaw = 2.0 * (n as f32 / TPR as f32 * TAU * R) / BASE;
    assert!(close(s.delta.dyaw, dyaw, 1e-6));
    assert!(close(s.delta.dyaw, PI / 2.0, 2e-3));
    assert_eq!(s.delta.translation.x, 0.0);
    assert_eq!(s.delta.translation.y, 0.0);
    assert_eq!(s.delta.path_length, 0.0);
    assert!(close(s.velocity.yaw_rate, dyaw / 0.2, 1e-4));
    assert_eq!(s.velocity.forward, 0.0);
}

#[test]
fn arc_chord_is_exact() {
    // Left wheel still, right wheel moves: pivot about the left wheel.
    // dyaw = d / BASE; the body origin (BASE/2 from the pivot) moves on a
    // circle of radius BASE/2: chord (r sin dyaw, r (1 - cos dyaw)).
    let mut o = odo();
    o.update(ticks(0, 0, 0)).unwrap();
    let s = o.update(ticks(90, 0, 400)).unwrap().unwrap();
    let d = 400.0 / TPR as f32 * TAU * R;
    let dyaw = d / BASE;
    let r = BASE / 2.0;
    assert!(close(s.delta.dyaw, dyaw, 1e-6));
    assert!(close(s.delta.translation.x, r * dyaw.sin(), 1e-6));
    assert!(close(s.delta.translation.y, r * (1.0 - dyaw.cos()), 1e-6));
    assert!(close(s.delta.path_length, d / 2.0, 1e-6));
    assert!(s.delta.path_length >= s.delta.translation.norm());
}

#[test]
fn unequal_radii_scale_each_wheel() {
    let mut o = DiffDriveOdometry::new(
        DiffDriveParams::new(TPR, 0.030, 0.040, BASE, 2.0, 500 * MS).unwrap(),
    );
    o.update(ticks(0, 0, 0)).unwrap();
    // Equal travel needs 4:3 counts.
    let s = o.update(ticks(50, 400, 300)).unwrap().unwrap();
    assert!(close(s.delta.dyaw, 0.0, 1e-6));
    assert!(close(s.delta.translation.x, 0.4 * TAU * 0.030, 1e-6));
}

#[test]
fn time_rejections_have_reasons_and_are_counted() {
    let mut o = odo();
    o.update(ticks(10, 0, 0)).unwrap();
    assert_eq!(o.update(ticks(10, 1, 1)), Err(Reject::Duplicate));
    assert_eq!(o.update(ticks(5, 1, 1)), Err(Reject::OutOfOrder));
    // A gap re-anchors: the next step counts from the gap sample.
    assert_eq!(o.update(ticks(2_000, 50, 50)), Err(Reject::Gap));
    let s = o.update(ticks(2_010, 60, 60)).unwrap().unwrap();
    assert!(close(
        s.delta.path_length,
        10.0 / TPR as f32 * TAU * R,
        1e-7
    ));
    let c = o.counts();
    assert_eq!(c.fused(), 2);
    assert_eq!(c.rejected(Reject::Duplicate), 1);
    assert_eq!(c.rejected(Reject::OutOfOrder), 1);
    assert_eq!(c.rejected(Reject::Gap), 1);
    assert_eq!(c.seen(), 5);
}

#[test]
fn impossible_jump_is_rejected_and_the_anchor_kept() {
    let mut o = odo();
    o.update(ticks(0, 0, 0)).unwrap();
    // 2 m/s over 10 ms is 2 cm: 91 counts. A glitch of 5000 is impossible.
    assert_eq!(o.update(ticks(10, 5_000, 10)), Err(Reject::OutOfRange));
    assert_eq!(o.last(), Some(ticks(0, 0, 0)));
    // The next good sample is measured from the kept anchor over 20 ms.
    let s = o.update(ticks(20, 20, 20)).unwrap().unwrap();
    assert_eq!(s.delta.t0, Timestamp(0));
    assert!(close(
        s.velocity.forward,
        20.0 / TPR as f32 * TAU * R / 0.02,
        1e-5
    ));
    // Count differences that overflow are impossible too.
    assert_eq!(o.update(ticks(30, i64::MIN, 0)), Err(Reject::OutOfRange));
    assert_eq!(o.counts().rejected(Reject::OutOfRange), 2);
}

#[test]
fn no_step_spans_a_failed_read() {
    let mut o = odo();
    o.update(ticks(0, 0, 0)).unwrap();
    o.update(ticks(20, 50, 50)).unwrap().unwrap();
    // The reads at 40 and 60 ms failed; the left's counter extension held
    // its position across them, so the counts at 80 ms miss 40 ms of the
    // left's motion: no step from 20 ms, the sample anchors afresh.
    o.read_failed(Timestamp(40 * MS));
    o.read_failed(Timestamp(60 * MS));
    assert_eq!(o.update(ticks(80, 75, 150)), Ok(None));
    assert_eq!(o.last(), Some(ticks(80, 75, 150)));
    let s = o.update(ticks(100, 125, 200)).unwrap().unwrap();
    assert_eq!(s.delta.t0, Timestamp(80 * MS));
    assert!(close(s.delta.dyaw, 0.0, 1e-7));
    // A failure reported while an older sample still waits (in the caller's
    // ordering window) breaks the step after it, not the older one.
    o.read_failed(Timestamp(130 * MS));
    assert!(o.update(ticks(120, 175, 250)).unwrap().is_some());
    assert_eq!(o.update(ticks(140, 400, 400)), Ok(None));
    assert!(o.update(ticks(160, 450, 450)).unwrap().is_some());
    // Every sample counted: two anchors after breaks count as fused, like
    // the first.
    assert_eq!(o.counts().fused(), 7);
}

#[test]
fn a_step_spans_missed_reads_when_it_continues_the_last_one() {
    let mut o = odo();
    o.update(ticks(0, 0, 0)).unwrap();
    o.update(ticks(20, 50, 40)).unwrap().unwrap();
    // The reads at 40, 60 and 80 ms were missed (bus, parity): the counts
    // continue, and the step from 20 ms carries their motion, the wheels
    // speeding up a little.
    for ms in [40, 60, 80] {
        o.read_missed(Timestamp(ms * MS));
    }
    let s = o.update(ticks(100, 260, 210)).unwrap().unwrap();
    assert_eq!(s.delta.t0, Timestamp(20 * MS));
    let rad = |n: f32| n / TPR as f32 * TAU;
    assert!(close(s.rates.left(), rad(210.0) / 0.08, 1e-3));
    assert!(close(s.rates.right(), rad(170.0) / 0.08, 1e-3));
    // An alias: across missed reads the left counts a whole revolution
    // more than its rate allows (a counter of one revolution's range that
    // wrapped). The sample anchors afresh, and the next is a step again.
    for ms in (120..400).step_by(20) {
        o.read_missed(Timestamp(ms * MS));
    }
    // (1.3 m/s over the 300 ms: within the wheels' largest speed.)
    let alias = 260 + 787 + TPR as i64;
    assert_eq!(o.update(ticks(400, alias, 847)), Ok(None));
    let s = o.update(ticks(420, alias + 53, 900)).unwrap().unwrap();
    assert_eq!(s.delta.t0, Timestamp(400 * MS));
    // Without a step before it (the first after an anchor), a step across
    // a missed read cannot be checked: it anchors too.
    o.read_failed(Timestamp(430 * MS));
    assert_eq!(o.update(ticks(440, alias + 106, 953)), Ok(None));
    o.read_missed(Timestamp(450 * MS));
    assert_eq!(o.update(ticks(460, alias + 159, 1006)), Ok(None));
    assert!(o.update(ticks(480, alias + 212, 1059)).unwrap().is_some());
}

#[test]
fn an_alias_refused_as_too_fast_is_still_checked_later() {
    // Across missed reads the left wheel is a revolution ahead: the first
    // samples after them are refused as too fast, which keeps the anchor;
    // the first that is not still spans the missed reads and is checked.
    let mut o = odo();
    o.update(ticks(0, 0, 0)).unwrap();
    o.update(ticks(20, 50, 40)).unwrap().unwrap();
    for ms in [40, 60, 80] {
        o.read_missed(Timestamp(ms * MS));
    }
    for (k, ms) in [100, 120, 140, 160].into_iter().enumerate() {
        let n = k as i64 + 4;
        let t = ticks(ms, 50 + n * 50 + TPR as i64, 40 + n * 40);
        assert_eq!(o.update(t), Err(Reject::OutOfRange), "{ms} ms");
    }
    assert_eq!(o.update(ticks(180, 1450, 360)), Ok(None));
    let s = o.update(ticks(200, 1500, 400)).unwrap().unwrap();
    assert_eq!(s.delta.t0, Timestamp(180 * MS));
}

#[test]
fn parameters_are_checked() {
    assert_eq!(
        DiffDriveParams::new(0, R, R, BASE, 1.0, MS),
        Err(ParamsError::BadTicksPerRevolution)
    );
    assert_eq!(
        DiffDriveParams::new(TPR, f32::NAN, R, BASE, 1.0, MS),
        Err(ParamsError::BadWheelRadius)
    );
    assert_eq!(
        DiffDriveParams::new(TPR, R, R, 0.0, 1.0, MS),
        Err(ParamsError::BadWheelBase)
    );
    assert_eq!(
        DiffDriveParams::new(TPR, R, R, BASE, f32::INFINITY, MS),
        Err(ParamsError::BadMaxWheelSpeed)
    );
    assert_eq!(
        DiffDriveParams::new(TPR, R, R, BASE, 1.0, 0),
        Err(ParamsError::BadMaxStep)
    );
}

proptest! {
    #![proptest_config(ProptestConfig { rng_seed: RngSeed::Fixed(77), cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn straight_lines_are_exact(n in -40i64..=40, dt_ms in 10u64..=100) {
        let mut o = odo();
        o.update(ticks(0, 0, 0)).unwrap();
        let s = o.update(ticks(dt_ms, n, n)).unwrap().unwrap();
        let d = n as f32 / TPR as f32 * TAU * R;
        prop_assert!(close(s.delta.translation.x, d, 1e-6));
        prop_assert_eq!(s.delta.translation.y, 0.0);
        prop_assert_eq!(s.delta.dyaw, 0.0);
        prop_assert!(close(s.delta.path_length, d.abs(), 1e-6));
    }

    #[test]
    fn pure_rotations_are_exact(n in -40i64..=40, dt_ms in 10u64..=100) {
        let mut o = odo();
        o.update(ticks(0, 0, 0)).unwrap();
        let s = o.update(ticks(dt_ms, -n, n)).unwrap().unwrap();
        let dyaw = 2.0 * (n as f32 / TPR as f32 * TAU * R) / BASE;
        prop_assert!(close(s.delta.dyaw, dyaw, 1e-6));
        prop_assert_eq!(s.delta.translation.norm(), 0.0);
        prop_assert_eq!(s.delta.path_length, 0.0);
    }

    #[test]
    fn path_length_bounds_the_chord(l in -40i64..=40, r in -40i64..=40) {
        let mut o = odo();
        o.update(ticks(0, 0, 0)).unwrap();
        let s = o.update(ticks(100, l, r)).unwrap().unwrap();
        prop_assert!(s.delta.path_length + 1e-7 >= s.delta.translation.norm());
    }

    #[test]
    fn no_input_panics_and_every_sample_is_counted(
        samples in prop::collection::vec((any::<u64>(), any::<i64>(), any::<i64>()), 0..100)) {
        let mut o = odo();
        for &(t, l, r) in &samples {
            let _ = o.update(WheelTicks { t: Timestamp(t), left: l, right: r });
        }
        prop_assert_eq!(o.counts().seen() as usize, samples.len());
    }
}

fn rates(ms: u64, left: f32, right: f32) -> vslam_core::sensors::RawWheelRates {
    vslam_core::sensors::RawWheelRates {
        t: Timestamp(ms * MS),
        left,
        right,
    }
}

#[test]
fn wheel_rates_integrate_by_the_trapezoid_and_pass_the_measured_rates() {
    let mut o = odo();
    assert_eq!(o.update_rates(rates(0, 10.0, 10.0)), Ok(None));
    // 10 then 20 rad/s over 0.1 s: 1.5 rad of wheel turn, 0.0525 m.
    let s = o.update_rates(rates(100, 20.0, 20.0)).unwrap().unwrap();
    assert!(close(s.delta.translation.x, 1.5 * R, 1e-6), "{:?}", s.delta);
    assert_eq!(s.delta.dyaw, 0.0);
    assert_eq!((s.rates.left(), s.rates.right()), (20.0, 20.0));
    assert_eq!(
        (s.delta.t0, s.delta.t1),
        (Timestamp(0), Timestamp(100 * MS))
    );
    // Opposite rates turn in place: dyaw = 2 * r * angle / base.
    let mut o = odo();
    o.update_rates(rates(0, -5.0, 5.0)).unwrap();
    let s = o.update_rates(rates(200, -5.0, 5.0)).unwrap().unwrap();
    assert!(
        close(s.delta.dyaw, 2.0 * R * 1.0 / BASE, 1e-6),
        "{}",
        s.delta.dyaw
    );
    assert!(close(s.velocity.yaw_rate, 2.0 * R * 5.0 / BASE, 1e-5));
}

#[test]
fn bad_wheel_rates_are_rejected_with_reasons_and_the_anchor_kept() {
    let mut o = odo();
    o.update_rates(rates(0, 1.0, 1.0)).unwrap();
    assert_eq!(
        o.update_rates(rates(20, f32::NAN, 1.0)),
        Err(Reject::NonFinite)
    );
    // 2 m/s is the fastest rim speed: 100 rad/s at 35 mm is 3.5 m/s.
    assert_eq!(
        o.update_rates(rates(40, 100.0, 1.0)),
        Err(Reject::OutOfRange)
    );
    assert_eq!(o.update_rates(rates(0, 1.0, 1.0)), Err(Reject::Duplicate));
    let s = o.update_rates(rates(60, 1.0, 1.0)).unwrap().unwrap();
    assert_eq!(
        s.delta.t0,
        Timestamp(0),
        "the anchor survived the rejections"
    );
    assert_eq!(o.update_rates(rates(1000, 1.0, 1.0)), Err(Reject::Gap));
    let s = o.update_rates(rates(1020, 1.0, 1.0)).unwrap().unwrap();
    assert_eq!(s.delta.t0, Timestamp(1000 * MS), "a gap re-anchors");
    assert_eq!(o.counts().fused(), 3);
    assert_eq!(o.counts().seen(), 7);
}
