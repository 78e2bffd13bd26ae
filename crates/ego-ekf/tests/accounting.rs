//! Accounting: initialisation, every rejection reason with its counter, and
//! that rejected samples leave the state untouched.

use ego_ekf::config::ImuConfig;
use ego_ekf::state::{Quat, STANDARD_GRAVITY, Vec3};
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, FlowConfig, GripParams, ImuPlausibility};
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, WheelRates};
use vslam_core::{Reject, Timestamp};

const DT: u64 = 4_000_000;

fn level_start(f: &mut EgoEkf, t: u64) {
    f.start(&ExplicitStart::at_rest(Timestamp(t))).unwrap();
}

fn rest(t: u64) -> ImuSample {
    ImuSample::new(Timestamp(t), [0.0; 3], [0.0, 0.0, STANDARD_GRAVITY]).unwrap()
}

fn flow_config() -> FilterConfig {
    let optics = FlowOptics::new(500.0, 0.03, Extrinsics::identity()).unwrap();
    FilterConfig {
        flow: Some(FlowConfig::new(optics)),
        ..FilterConfig::default()
    }
}

#[test]
fn initialises_from_still_samples_with_gravity_aligned_attitude() {
    let c = FilterConfig::default();
    let mut f = EgoEkf::new(c).unwrap();
    let (roll, pitch) = (0.1f32, -0.05f32);
    let q_true = Quat::from_euler_angles(roll, pitch, 0.3);
    let f_b = q_true.inverse() * Vec3::new(0.0, 0.0, STANDARD_GRAVITY);
    let bias = [0.003, -0.002, 0.001];
    // A moving sample in the middle restarts the average.
    let n = c.init.samples as u64;
    for k in 0..(n + 10) {
        let gyro = if k == 5 { [0.5, 0.0, 0.0] } else { bias };
        let s = ImuSample::new(Timestamp(k * DT), gyro, f_b.into()).unwrap();
        assert_eq!(f.propagate(&s), Err(Reject::NotReady), "sample {k}");
        assert_eq!(f.is_initialised(), k >= 5 + n, "sample {k}");
        if f.is_initialised() {
            break;
        }
    }
    assert!(f.is_initialised());
    let (r, p, _) = f.attitude().euler_angles();
    assert!(
        (r - roll).abs() < 1e-3 && (p - pitch).abs() < 1e-3,
        "{r} {p}"
    );
    assert!((f.gyro_bias() - Vec3::from(bias)).norm() < 1e-6);
    assert_eq!(f.imu_counts().rejected(Reject::NotReady) as u64, 6 + n);
    // Propagation now runs and reports the bias-corrected sample.
    let t = f.time().unwrap().0;
    let step = f
        .propagate(&ImuSample::new(Timestamp(t + DT), bias, f_b.into()).unwrap())
        .unwrap();
    assert!(step.gyro.norm() < 1e-6);
    assert!(
        step.vertical_deviation < 0.05,
        "{}",
        step.vertical_deviation
    );
    assert_eq!(f.imu_counts().fused(), 1);
}

#[test]
fn bad_imu_samples_are_rejected_with_reasons_and_change_nothing() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    level_start(&mut f, 1_000 * DT);
    f.propagate(&rest(1_001 * DT)).unwrap();
    let (x, p) = (*f.state(), *f.covariance());
    let cases = [
        (rest(1_001 * DT), Reject::Duplicate),
        (rest(1_000 * DT), Reject::OutOfOrder),
        (
            ImuSample::new(Timestamp(1_002 * DT), [0.0; 3], [0.0, 0.0, 500.0]).unwrap(),
            Reject::Saturated,
        ),
    ];
    for (s, reason) in cases {
        assert_eq!(f.propagate(&s), Err(reason));
        assert_eq!(*f.state(), x);
        assert_eq!(*f.covariance(), p);
    }
    // A gap re-anchors the clock: not integrated, and the next step works.
    assert_eq!(f.propagate(&rest(9_000 * DT)), Err(Reject::Gap));
    assert_eq!(*f.state(), x);
    assert!(f.propagate(&rest(9_001 * DT)).is_ok());
    let c = f.imu_counts();
    for r in [
        Reject::Duplicate,
        Reject::OutOfOrder,
        Reject::Saturated,
        Reject::Gap,
    ] {
        assert_eq!(c.rejected(r), 1, "{r}");
    }
    assert_eq!(c.fused(), 2);
    // Non-finite samples cannot be built: the checked constructor refuses them.
    assert_eq!(
        ImuSample::new(Timestamp(0), [f32::NAN, 0.0, 0.0], [0.0; 3]),
        Err(Reject::NonFinite)
    );
}

#[test]
fn implausible_imu_readings_are_refused_and_change_nothing() {
    let config = FilterConfig {
        imu: ImuConfig {
            plausibility: Some(ImuPlausibility::FIELD),
            ..ImuConfig::default()
        },
        ..FilterConfig::default()
    };
    let mut f = EgoEkf::new(config).unwrap();
    level_start(&mut f, 1_000 * DT);
    // Turning at 0.3 rad/s with a noisy accelerometer.
    let turning = |k: u64, gz: f32| {
        let noise = (k % 5) as f32 * 1e-3;
        ImuSample::new(
            Timestamp(k * DT),
            [0.0, 0.0, gz],
            [noise, 0.0, STANDARD_GRAVITY],
        )
        .unwrap()
    };
    for k in 1_001..1_010 {
        f.propagate(&turning(k, 0.3)).unwrap();
    }
    let (x, p) = (*f.state(), *f.covariance());
    // A hundredfold rate within full scale: a jump the robot cannot make.
    assert_eq!(f.propagate(&turning(1_010, 30.0)), Err(Reject::OutOfRange));
    assert_eq!((*f.state(), *f.covariance()), (x, p));
    // The next true reading: the last accepted rates held over the refused
    // step, its own reading integrated over its own.
    let step = f.propagate(&turning(1_011, 0.3)).unwrap();
    assert!((step.dt - DT as f32 * 1e-9).abs() < 1e-9, "{}", step.dt);
    // A frozen output: repeats are integrated for 20 ms, then refused.
    let frozen = turning(1_011, 0.3);
    let mut outcomes = Vec::new();
    for k in 1_012..1_020 {
        let s = ImuSample::new(
            Timestamp(k * DT),
            (*frozen.gyro()).into(),
            (*frozen.accel()).into(),
        )
        .unwrap();
        let before = (*f.state(), *f.covariance());
        let r = f.propagate(&s);
        if r.is_err() {
            assert_eq!((*f.state(), *f.covariance()), before);
        }
        outcomes.push(r.err());
    }
    let low = Some(Reject::LowQuality);
    assert_eq!(
        outcomes,
        [None, None, None, None, None, low, low, low],
        "refused from 24 ms after the reading"
    );
    let c = f.imu_counts();
    assert_eq!(
        (
            c.rejected(Reject::OutOfRange),
            c.rejected(Reject::LowQuality)
        ),
        (1, 3)
    );
    // The default configuration integrates repeats: noise-free readings
    // (a test bench) are not refused.
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    level_start(&mut f, 0);
    for k in 1..100 {
        f.propagate(&rest(k * DT)).unwrap();
    }
    assert_eq!(f.imu_counts().fused(), 99);
}

#[test]
fn wheel_samples_are_checked_gated_and_counted() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    let w = |t: u64, l: f32, r: f32| WheelRates::new(Timestamp(t), l, r).unwrap();
    assert_eq!(f.fuse_wheel(&w(0, 0.0, 0.0)), Err(Reject::NotReady));
    level_start(&mut f, 0);
    f.propagate(&rest(DT)).unwrap();
    let (x, p) = (*f.state(), *f.covariance());
    // Non-finite rates cannot be built: the checked constructor refuses them.
    assert_eq!(
        WheelRates::new(Timestamp(DT), f32::NAN, 0.0),
        Err(Reject::NonFinite)
    );
    assert_eq!(*f.state(), x);
    assert_eq!(*f.covariance(), p);
    let inn = f.fuse_wheel(&w(DT, 0.0, 0.0)).unwrap();
    assert!(!inn.gated && inn.forward.abs() < 1e-6 && inn.forward_var > 0.0);
    assert_eq!(f.fuse_wheel(&w(DT, 0.0, 0.0)), Err(Reject::Duplicate));
    assert_eq!(f.fuse_wheel(&w(0, 0.0, 0.0)), Err(Reject::OutOfOrder));
    // The robot stands, the wheels report 1 m/s: slip, forward gated.
    let radius = f.wheel_radii()[0];
    let before = f.velocity();
    let inn = f
        .fuse_wheel(&w(2 * DT, 1.0 / radius, 1.0 / radius))
        .unwrap();
    assert!(inn.gated);
    assert!((inn.forward - 1.0).abs() < 1e-3, "{}", inn.forward);
    assert!(
        (f.velocity() - before).norm() < 1e-3,
        "forward part not fused"
    );
    let c = f.wheel_counts();
    assert_eq!(c.fused(), 1);
    assert_eq!(c.gated(), 1);
    assert_eq!(c.rejected(Reject::NonFinite), 0);
    assert_eq!(c.rejected(Reject::NotReady), 1);
    assert_eq!(c.rejected(Reject::Duplicate), 1);
    assert_eq!(c.rejected(Reject::OutOfOrder), 1);
    assert_eq!(c.seen(), 5);
}

#[test]
fn grip_sets_the_wheel_gate_and_noise() {
    // 6 cm/s of disagreement: gated on a grippy floor, fused on a slippery one.
    let run = |grip: GripParams| {
        let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
        level_start(&mut f, 0);
        f.set_grip(grip);
        assert_eq!(f.grip(), grip);
        f.propagate(&rest(DT)).unwrap();
        let r = f.wheel_radii()[0];
        let inn = f
            .fuse_wheel(&WheelRates::new(Timestamp(DT), 0.06 / r, 0.06 / r).unwrap())
            .unwrap();
        (inn, f.velocity().norm())
    };
    let (hard, v_hard) = run(GripParams::new(0.95, 0.02, 0.01, 6.63, 2.0).unwrap());
    let (soft, v_soft) = run(GripParams::new(0.4, 0.08, 0.02, 6.63, 2.0).unwrap());
    assert!(hard.gated && !soft.gated);
    assert!(soft.forward_var > hard.forward_var);
    assert!(v_hard < 1e-5 && v_soft > 1e-3, "{v_hard} {v_soft}");
}

#[test]
fn standing_still_runs_zero_velocity_updates_against_the_clone() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    level_start(&mut f, 0);
    let start_std = f.velocity_std().norm();
    for k in 1..=500u64 {
        let step = f.propagate(&rest(k * DT)).unwrap();
        if k % 5 == 0 {
            f.fuse_wheel(&WheelRates::new(Timestamp(k * DT), 0.0, 0.0).unwrap())
                .unwrap();
        }
        if k > 100 {
            assert!(step.still);
        }
    }
    assert!(f.is_still());
    assert!(f.zupt_counts().fused() > 30, "{}", f.zupt_counts().fused());
    assert!(f.velocity_std().norm() < start_std);
    // The clone was frozen: pose and clone agree.
    let (clone_p, _) = f.clone_std();
    assert!(clone_p.norm() > 0.0);
    assert!((f.position() - f.state().clone_p_wb).norm() < 1e-3);
}

#[test]
fn vertical_deviation_reports_bumps() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    level_start(&mut f, 0);
    let s = ImuSample::new(Timestamp(DT), [0.0; 3], [0.0, 0.0, STANDARD_GRAVITY + 3.0]).unwrap();
    let step = f.propagate(&s).unwrap();
    assert!((step.vertical_deviation - 3.0).abs() < 1e-3);
}

#[test]
fn flow_reports_are_checked_gated_and_counted() {
    let sample = |t: u64, dx: i16, squal: u8, shutter: u16| FlowSample {
        t: Timestamp(t),
        dx,
        squal,
        shutter,
        motion: true,
        ..FlowSample::default()
    };
    // Without a flow sensor configured, reports are not usable.
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    level_start(&mut f, 0);
    assert_eq!(f.fuse_flow(&sample(DT, 0, 200, 100)), Err(Reject::NotReady));

    let mut f = EgoEkf::new(flow_config()).unwrap();
    level_start(&mut f, 0);
    f.propagate(&rest(DT)).unwrap();
    // The first report only opens the interval.
    assert_eq!(f.fuse_flow(&sample(DT, 0, 200, 100)), Err(Reject::NotReady));
    let ok = f.fuse_flow(&sample(11 * DT, 0, 200, 100)).unwrap();
    assert!(ok.velocity.norm() < 1e-6 && ok.nis < 1.0);
    // Low quality by the datasheet rule.
    assert_eq!(
        f.fuse_flow(&sample(21 * DT, 0, 0x10, 0x1F80)),
        Err(Reject::LowQuality)
    );
    assert_eq!(
        f.fuse_flow(&sample(31 * DT, i16::MAX, 200, 100)),
        Err(Reject::Saturated)
    );
    // 1000 counts in 40 ms at 3 cm: 1.5 m/s while the filter knows it stands.
    let x = *f.state();
    assert_eq!(
        f.fuse_flow(&sample(41 * DT, 1000, 200, 100)),
        Err(Reject::Gated)
    );
    assert_eq!(*f.state(), x);
    // Poor quality is noise, not an error.
    let poor = f.fuse_flow(&sample(51 * DT, 0, 30, 0x0800)).unwrap();
    assert!(poor.std > ok.std * 3.0, "{} {}", poor.std, ok.std);
    assert_eq!(
        f.fuse_flow(&sample(51 * DT, 0, 200, 100)),
        Err(Reject::Duplicate)
    );
    let c = f.flow_counts();
    assert_eq!(c.fused(), 2);
    assert_eq!(c.gated(), 1);
    for r in [
        Reject::NotReady,
        Reject::LowQuality,
        Reject::Saturated,
        Reject::Duplicate,
    ] {
        assert_eq!(c.rejected(r), 1, "{r}");
    }
}

#[test]
fn bad_configurations_are_refused() {
    let mut c = FilterConfig::default();
    c.imu.noise.gyro_density = -1.0;
    assert_eq!(EgoEkf::new(c).err(), Some(ego_ekf::ConfigError::BadNoise));
    let mut c = FilterConfig::default();
    c.robot.radius = 0.0;
    assert_eq!(
        EgoEkf::new(c).err(),
        Some(ego_ekf::ConfigError::BadGeometry)
    );
    let mut c = FilterConfig::default();
    c.imu.max_dt_ns = 0;
    assert_eq!(EgoEkf::new(c).err(), Some(ego_ekf::ConfigError::BadLimit));
}
