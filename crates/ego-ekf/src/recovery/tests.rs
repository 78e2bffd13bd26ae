//! Unit tests of the parent module.
use super::*;

fn evidence<'a>(run: &'a GatedRun, flow: Option<FlowWitness>) -> Evidence<'a> {
    Evidence {
        filter_velocity: Vector2::new(0.6, 0.0),
        filter_var: 1e-4,
        wheel_speed: 0.3,
        wheel_rim_speed: 0.3,
        wheel_std: 0.02,
        wheel_gate: 6.63,
        grip: 0.95,
        flow,
        flow_gate: 9.21,
        run,
    }
}

fn steady_run(config: &RecoveryConfig, silence: bool) -> GatedRun {
    let mut run = GatedRun::default();
    run.push(config, -0.3, silence);
    for k in 1..WheelConfig::default().reexamine_after_gated {
        // A slow drift inside the tolerance.
        run.push(config, -0.3 - 0.001 * f32::from(k), false);
    }
    run
}

fn witness(vx: f32, std: f32) -> Option<FlowWitness> {
    Some(FlowWitness {
        t: Timestamp(0),
        velocity: Vector2::new(vx, 0.0),
        std,
        reports: 1,
    })
}

#[test]
fn the_window_averages_recent_reports_only() {
    let mut w = FlowWindow::new(200_000_000, 0.001);
    assert_eq!(w.witness(Timestamp(0)), None);
    // 0.1 m/s for a while, then 0.3 m/s: 10 ms apart, std 0.1 each.
    for k in 0..100u64 {
        let v = if k < 50 { 0.1 } else { 0.3 };
        w.push(Timestamp(k * 10_000_000), Vector2::new(v, 0.0), 0.1);
    }
    let now = Timestamp(990_000_000);
    let m = w.witness(now).unwrap();
    // Only the last 100-200 ms: all at 0.3 m/s.
    assert!((m.velocity.x - 0.3).abs() < 1e-5, "{m:?}");
    assert!((10..=20).contains(&m.reports), "{m:?}");
    assert!((m.std - 0.1 / f32::from(m.reports).sqrt()).abs() < 1e-5);
    // Noise below the floor is not believed.
    let mut f = FlowWindow::new(200_000_000, 0.05);
    for k in 0..20u64 {
        f.push(Timestamp(k * 10_000_000), Vector2::new(0.2, 0.0), 0.1);
    }
    assert_eq!(f.witness(Timestamp(200_000_000)).unwrap().std, 0.05);
    // Bad noise is ignored.
    f.push(Timestamp(210_000_000), Vector2::new(9.0, 0.0), f32::NAN);
    assert_eq!(f.witness(Timestamp(210_000_000)).unwrap().velocity.x, 0.2);
}

/// A robot stuck (the flow sees the floor stand still) that drives on at
/// 0.3 m/s: the window's older half, half still and half moving, is stale,
/// and the witness is the newer half's 0.3 m/s, not a mean of both.
#[test]
fn a_change_of_velocity_leaves_the_older_half_out() {
    let mut w = FlowWindow::new(250_000_000, 0.01);
    for k in 0..=110u64 {
        let v = if k < 100 { 0.0 } else { 0.3 };
        w.push(Timestamp(k * 10_000_000), Vector2::new(v, 0.0), 0.02);
    }
    let m = w.witness(Timestamp(1_100_000_000)).unwrap();
    assert!((m.velocity.x - 0.3).abs() < 1e-4, "{m:?}");
    assert!(m.reports < 10, "{m:?}");
    // A steady velocity keeps both halves.
    let mut s = FlowWindow::new(250_000_000, 0.01);
    for k in 0..=110u64 {
        let v = if k % 2 == 0 { 0.29 } else { 0.31 };
        s.push(Timestamp(k * 10_000_000), Vector2::new(v, 0.0), 0.02);
    }
    let m = s.witness(Timestamp(1_100_000_000)).unwrap();
    assert!(m.reports > 15, "{m:?}");
    assert!((m.velocity.x - 0.3).abs() < 0.005, "{m:?}");
}

#[test]
fn flow_that_disagrees_with_the_filter_is_the_source() {
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    let run = steady_run(&c, false);
    let v = decide(&c, &w, &evidence(&run, witness(0.3, 0.02)));
    assert_eq!(v, Verdict::Reset(ResetSource::Flow));
}

#[test]
fn noisy_flow_that_the_wheels_confirm_is_the_source() {
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    let run = steady_run(&c, false);
    // 0.3 m/s off the filter is within a 0.15 m/s flow's gate, but the
    // wheels say the same as the flow.
    let v = decide(&c, &w, &evidence(&run, witness(0.32, 0.15)));
    assert_eq!(v, Verdict::Reset(ResetSource::Flow));
}

#[test]
fn a_vague_flow_mean_is_no_witness() {
    // A lifted robot: the flow sees no floor, its reports average to a
    // zero of 0.5 m/s std that the free-spinning wheels "agree" with.
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    let run = steady_run(&c, false);
    let lifted = Evidence {
        filter_velocity: Vector2::new(0.0, 0.0),
        ..evidence(&run, witness(0.0, 0.5))
    };
    assert_eq!(decide(&c, &w, &lifted), Verdict::NoTrustedSource);
}

#[test]
fn a_flow_nearer_the_filter_than_the_wheels_does_not_vouch_for_them() {
    // A lifted robot, the flow's mean just precise enough to be a witness:
    // it sees the floor stand still as the filter does; the free wheels at
    // 0.4 m/s pass its loose wheel test but it is far nearer the filter.
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    let run = steady_run(&c, false);
    let e = Evidence {
        filter_velocity: Vector2::new(0.02, 0.0),
        wheel_speed: 0.4,
        ..evidence(&run, witness(0.0, 0.19))
    };
    assert!(disagreement(0.4, 0.02 * 0.02, 0.0, 0.19 * 0.19) <= e.wheel_gate);
    assert_eq!(decide(&c, &w, &e), Verdict::WheelsSlip);
    // Nearer the wheels than the filter, the same flow vouches for them.
    let e = Evidence {
        filter_velocity: Vector2::new(0.0, 0.0),
        wheel_speed: 0.4,
        ..evidence(&run, witness(0.3, 0.19))
    };
    assert_eq!(decide(&c, &w, &e), Verdict::Reset(ResetSource::Flow));
}

#[test]
fn a_reset_to_a_flow_the_wheels_disagree_with_keeps_them_refuted() {
    let c = RecoveryConfig::default();
    let run = steady_run(&c, false);
    // The filter ran away (0.6 m/s); the flow sees 0.3; the wheels spin at 0.3
    // in `evidence`: they agree, nothing refuted.
    assert!(!wheels_refuted(&evidence(&run, witness(0.3, 0.02))));
    // Wheels at 0.3 against a flow of 0.0: refuted.
    assert!(wheels_refuted(&evidence(&run, witness(0.0, 0.02))));
    assert!(!wheels_refuted(&evidence(&run, None)));

    let mut r = Refutation::default();
    let t = |ms: u64| Timestamp(ms * 1_000_000);
    assert!(
        !r.holds(&c, t(0), 0.4, 0.02, 6.63, witness(0.0, 0.05)),
        "not refuted yet"
    );
    r.refute(t(0));
    // Still against a witness that disagrees, and through a short silence.
    assert!(r.holds(&c, t(100), 0.4, 0.02, 6.63, witness(0.0, 0.05)));
    assert!(r.holds(&c, t(300), 0.4, 0.02, 6.63, None));
    assert!(
        r.holds(&c, t(350), 0.4, 0.02, 6.63, witness(0.0, 0.5)),
        "a vague mean is silence"
    );
    // A long silence lifts it.
    assert!(!r.holds(&c, t(100 + 501), 0.4, 0.02, 6.63, None));
    assert!(!r.is_active());
    // So does a witness that agrees with the wheels.
    r.refute(t(1000));
    assert!(!r.holds(&c, t(1010), 0.01, 0.02, 6.63, witness(0.0, 0.05)));
    r.refute(t(2000));
    r.clear();
    assert!(!r.is_active());
}

#[test]
fn flow_that_agrees_with_the_filter_says_the_wheels_slip() {
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    let run = steady_run(&c, false);
    let v = decide(&c, &w, &evidence(&run, witness(0.6, 0.02)));
    assert_eq!(v, Verdict::WheelsSlip);
}

/// Evidence without flow whose filter is slower than the wheels (a stuck
/// or spinning robot's signature): only the grip and the run decide.
fn behind<'a>(run: &'a GatedRun) -> Evidence<'a> {
    Evidence {
        filter_velocity: Vector2::new(0.05, 0.0),
        ..evidence(run, None)
    }
}

#[test]
fn without_flow_the_wheels_only_after_silence_on_high_grip() {
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    let jump = steady_run(&c, false);
    assert_eq!(decide(&c, &w, &behind(&jump)), Verdict::NoTrustedSource);
    let silence = steady_run(&c, true);
    assert_eq!(
        decide(&c, &w, &behind(&silence)),
        Verdict::Reset(ResetSource::Wheels)
    );
    let mut carpet = behind(&silence);
    carpet.grip = 0.7;
    assert_eq!(decide(&c, &w, &carpet), Verdict::NoTrustedSource);
}

#[test]
fn without_flow_a_filter_overrunning_turning_wheels_is_reset_to_them() {
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    // A run that says nothing for the wheels (no silence, on carpet).
    let run = steady_run(&c, false);
    let ahead = Evidence {
        grip: 0.7,
        ..evidence(&run, None)
    };
    // The filter at 0.6 m/s, the wheels at 0.3: wheels do not under-read.
    assert!(overruns(&c, &ahead));
    assert_eq!(decide(&c, &w, &ahead), Verdict::Reset(ResetSource::Wheels));
    // Against the wheels' direction.
    let against = Evidence {
        filter_velocity: Vector2::new(-0.2, 0.0),
        ..ahead
    };
    assert!(overruns(&c, &against));
    // A turn in place: no forward speed, but the wheels turn.
    let in_place = Evidence {
        filter_velocity: Vector2::new(0.4, 0.0),
        wheel_speed: 0.0,
        wheel_rim_speed: 0.25,
        ..ahead
    };
    assert!(overruns(&c, &in_place));
    // Frozen wheels prove nothing: the robot may be pushed, the counts stuck.
    let frozen = Evidence {
        wheel_rim_speed: 0.0,
        ..in_place
    };
    assert!(!overruns(&c, &frozen));
    assert_eq!(decide(&c, &w, &frozen), Verdict::NoTrustedSource);
    // A filter near rest with the other sign while the wheels spin (a
    // lifted robot's free wheels): not an overrun.
    let lifted = Evidence {
        filter_velocity: Vector2::new(-0.01, 0.0),
        wheel_speed: 0.4,
        wheel_rim_speed: 0.4,
        ..ahead
    };
    assert!(!overruns(&c, &lifted));
    // Within the wheels' gate, or slower than them: not an overrun.
    let close = Evidence {
        filter_velocity: Vector2::new(0.33, 0.0),
        ..ahead
    };
    assert!(!overruns(&c, &close));
    assert!(!overruns(&c, &behind(&run)));
    // Non-finite evidence resets nothing.
    let nan = Evidence {
        filter_velocity: Vector2::new(f32::NAN, 0.0),
        ..ahead
    };
    assert!(!overruns(&c, &nan));
    // A flow witness, when there is one, decides first.
    let with_flow = Evidence {
        flow: witness(0.6, 0.02),
        ..ahead
    };
    assert_eq!(decide(&c, &w, &with_flow), Verdict::WheelsSlip);
}

#[test]
fn an_unsteady_run_is_no_offset() {
    let c = RecoveryConfig::default();
    let w = WheelConfig::default();
    let mut run = GatedRun::default();
    run.push(&c, -0.1, true);
    for k in 1..w.reexamine_after_gated {
        // The wheels keep speeding up against the IMU: spinning up.
        run.push(&c, -0.1 - 0.03 * f32::from(k), false);
    }
    assert!(run.steady_len() < w.reexamine_after_gated);
    assert_eq!(decide(&c, &w, &behind(&run)), Verdict::NoTrustedSource);
    assert!(run.due(&w));
}

#[test]
fn a_jump_back_towards_the_filter_is_a_trusted_onset() {
    let c = RecoveryConfig::default();
    let mut run = GatedRun::default();
    run.push(&c, 0.4, false);
    assert!(!run.trusted_onset());
    run.push(&c, 0.15, false);
    assert!(run.trusted_onset());
    run.push(&c, 0.5, false);
    assert!(!run.trusted_onset());
}

#[test]
fn counts_every_verdict() {
    let mut r = RecoveryCounts::default();
    r.record(Timestamp(1), Verdict::Reset(ResetSource::Flow));
    r.record(Timestamp(2), Verdict::Reset(ResetSource::Wheels));
    r.record(Timestamp(3), Verdict::WheelsSlip);
    r.record(Timestamp(4), Verdict::NoTrustedSource);
    assert_eq!(r.resets(), 2);
    assert_eq!((r.wheels_slip, r.no_trusted_source), (1, 1));
    assert_eq!(r.last, Some((Timestamp(4), Verdict::NoTrustedSource)));
    assert_eq!(Verdict::WheelsSlip.name(), "wheels_slip");
}

#[test]
fn a_reset_sets_the_robot_velocity_and_decouples_it() {
    use crate::state::{Quat, V};
    let mut x = NominalState {
        p_wb: Vec3::zeros(),
        v_wb: Vec3::new(0.9, -0.2, 0.05),
        q_wb: Quat::from_euler_angles(0.02, -0.01, 0.7),
        accel_bias: Vec3::zeros(),
        gyro_bias: Vec3::zeros(),
        gravity: Vec3::new(0.0, 0.0, -9.81),
        gyro_scale: 0.0,
        clone_p_wb: Vec3::zeros(),
        clone_q_wb: Quat::identity(),
        p_bl: Vec3::new(-0.05, 0.12, -0.04),
        p_br: Vec3::new(-0.05, -0.12, -0.04),
        q_rb: Quat::from_euler_angles(0.0, 0.01, 0.0),
        radius_left: 0.035,
        radius_right: 0.035,
    };
    let mut p = Covariance::identity() * 0.01;
    p[(V, 0)] = 0.004;
    p[(0, V)] = 0.004;
    let gyro = Vec3::new(0.0, 0.0, 0.4);
    let robot_velocity = |x: &NominalState| {
        let v_b = x.q_wb.inverse() * x.v_wb;
        x.q_rb * (v_b + gyro.cross(&x.p_b_robot()))
    };
    let before = robot_velocity(&x);
    reset_velocity(&mut x, &mut p, &gyro, &Vector2::new(0.3, 0.01), 0.05);
    let after = robot_velocity(&x);
    assert!((after.x - 0.3).abs() < 1e-5 && (after.y - 0.01).abs() < 1e-5);
    assert!((after.z - before.z).abs() < 1e-5, "{before} {after}");
    assert_eq!(p[(V, 0)], 0.0);
    assert_eq!(p[(0, V)], 0.0);
    assert!((p[(V + 1, V + 1)] - 0.0025).abs() < 1e-9);
    assert!(crate::covariance::is_positive_definite(&p));
}

#[test]
fn a_run_after_silence_is_a_trusted_onset() {
    let c = RecoveryConfig::default();
    let t = |ms: u64| Timestamp(ms * 1_000_000);
    let mut w = WheelWatch::default();
    // Nothing fused yet: the first gated update follows silence.
    w.gated(&c, t(0), 0.4);
    assert!(w.run().trusted_onset() && w.run().len() == 1);
    // Fused at a steady pace, then gated: no silence.
    let silence_ms = c.silence_ns / 1_000_000;
    for k in 1..=3 * silence_ms / 20 {
        w.fused(&c, t(1000 + 20 * k));
    }
    assert!(w.run().is_empty());
    let last = 1000 + 20 * (3 * silence_ms / 20);
    w.gated(&c, t(last + 20), 0.4);
    assert!(!w.run().trusted_onset());
    // A long pause, one fused sample (fusing resumes), then gated: the
    // first samples back count as after silence.
    let back = last + 40 + 2 * silence_ms;
    w.fused(&c, t(back));
    w.gated(&c, t(back + 20), 0.4);
    assert!(w.run().trusted_onset());
    w.end_run();
    assert!(w.run().is_empty());
}
