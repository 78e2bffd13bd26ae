//! The per-aid status records (wheels, flow, zero-velocity update): one shape
//! for every aid, filled by every sample, agreeing with what the fusion call
//! returned and with the counters.

use ego_ekf::state::STANDARD_GRAVITY;
use ego_ekf::{AidOutcome, EgoEkf, ExplicitStart, FilterConfig, FlowConfig};
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, WheelRates};
use vslam_core::{Reject, Timestamp};

const DT: u64 = 4_000_000;

fn level_start(f: &mut EgoEkf) {
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
}

fn rest(t: u64) -> ImuSample {
    ImuSample::new(Timestamp(t), [0.0; 3], [0.0, 0.0, STANDARD_GRAVITY]).unwrap()
}

fn wheels(k: u64, rate: f32) -> WheelRates {
    WheelRates::new(Timestamp(k * DT), rate, rate).unwrap()
}

#[test]
fn wheel_status_follows_fused_gated_and_refused_samples() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    assert!(f.wheel_status().is_none());
    assert_eq!(f.fuse_wheel(&wheels(0, 0.0)), Err(Reject::NotReady));
    let s = f.wheel_status().unwrap();
    assert_eq!(s.outcome, AidOutcome::Rejected(Reject::NotReady));
    assert!(s.innovation[0].is_nan() && s.last_fused.is_none());

    level_start(&mut f);
    f.propagate(&rest(DT)).unwrap();
    let inn = f.fuse_wheel(&wheels(1, 0.0)).unwrap();
    let s = *f.wheel_status().unwrap();
    assert_eq!(s.outcome, AidOutcome::Fused);
    assert_eq!((s.t, s.last_fused), (Timestamp(DT), Some(Timestamp(DT))));
    assert_eq!(s.innovation[0], inn.forward);
    assert_eq!(s.innovation_var[0], inn.forward_var);
    assert_eq!(s.observation, [0.0, 0.0]);
    // The prior's uncertainty adds to the noise.
    assert!(s.innovation_var[0] > s.observation_var[0] && s.observation_var[0] > 0.0);
    assert!(s.test_ratio() < 1.0 && s.fused());

    // The robot stands, the wheels report 1 m/s, twice: gated in a row.
    let radius = f.wheel_radii()[0];
    for (k, run) in [(2u64, 1u16), (3, 2)] {
        f.propagate(&rest(k * DT)).unwrap();
        let inn = f.fuse_wheel(&wheels(k, 1.0 / radius)).unwrap();
        assert!(inn.gated);
        let s = *f.wheel_status().unwrap();
        assert_eq!(s.outcome, AidOutcome::Gated);
        assert_eq!(s.consecutive_gated, run);
        assert_eq!(s.last_fused, Some(Timestamp(DT)));
        assert!((s.observation[0] - 1.0).abs() < 1e-5, "{s:?}");
        assert!(s.test_ratio() > 1.0, "{s:?}");
        assert_eq!(s.innovation[0], inn.forward);
    }
    assert_eq!(f.fuse_wheel(&wheels(3, 0.0)), Err(Reject::Duplicate));
    let s = f.wheel_status().unwrap();
    assert_eq!(s.outcome, AidOutcome::Rejected(Reject::Duplicate));
    assert_eq!(s.consecutive_gated, 2);
    assert_eq!(s.last_fused, Some(Timestamp(DT)));
}

#[test]
fn flow_status_carries_the_test_ratio_of_fused_and_gated_reports() {
    let optics = FlowOptics::new(500.0, 0.03, Extrinsics::identity()).unwrap();
    let config = FilterConfig {
        flow: Some(FlowConfig::new(optics)),
        ..FilterConfig::default()
    };
    let sample = |k: u64, dx: i16, squal: u8| FlowSample {
        t: Timestamp(k * DT),
        dx,
        squal,
        // Below the datasheet's quality threshold, the long shutter of a
        // dark floor.
        shutter: if squal < 0x20 { 0x1F80 } else { 100 },
        motion: true,
        ..FlowSample::default()
    };
    let mut f = EgoEkf::new(config).unwrap();
    level_start(&mut f);
    f.propagate(&rest(DT)).unwrap();
    assert_eq!(f.fuse_flow(&sample(1, 0, 200)), Err(Reject::NotReady));
    let ok = f.fuse_flow(&sample(11, 0, 200)).unwrap();
    let s = *f.flow_status().unwrap();
    assert_eq!(s.outcome, AidOutcome::Fused);
    assert_eq!(s.nis, ok.nis);
    assert_eq!(s.observation_var, [ok.std * ok.std; 2]);
    assert!(s.innovation_var.iter().all(|&v| v > ok.std * ok.std));
    assert!(s.test_ratio() < 1.0);

    assert_eq!(f.fuse_flow(&sample(21, 0, 0x10)), Err(Reject::LowQuality));
    let s = *f.flow_status().unwrap();
    assert_eq!(s.outcome, AidOutcome::Rejected(Reject::LowQuality));
    assert!(s.nis.is_nan());

    // 1.5 m/s while the filter knows it stands: gated, its NIS kept.
    assert_eq!(f.fuse_flow(&sample(31, 1000, 200)), Err(Reject::Gated));
    let s = *f.flow_status().unwrap();
    assert_eq!(s.outcome, AidOutcome::Gated);
    assert_eq!(s.consecutive_gated, 1);
    assert_eq!(s.last_fused, Some(Timestamp(11 * DT)));
    assert!(s.observation[0] > 1.0, "{s:?}");
    // One component: the NIS is the innovation over its variance.
    let expect = s.innovation[0] * s.innovation[0] / s.innovation_var[0];
    assert!((s.nis - expect).abs() <= 1e-3 * expect, "{s:?}");
    assert!(s.test_ratio() > 1.0);

    // The run goes on until the flow's own reset: then the outcome is a
    // reset and the run is over.
    let mut propagated = 1;
    let mut reset = false;
    for n in 2..100u16 {
        let k = 31 + 10 * u64::from(n - 1);
        for i in propagated + 1..=k {
            f.propagate(&rest(i * DT)).unwrap();
        }
        propagated = k;
        let out = f.fuse_flow(&sample(k, 1000, 200));
        let s = *f.flow_status().unwrap();
        if out == Err(Reject::Gated) {
            assert_eq!((s.outcome, s.consecutive_gated), (AidOutcome::Gated, n));
            continue;
        }
        assert!(out.unwrap().reset, "{out:?}");
        assert_eq!((s.outcome, s.consecutive_gated), (AidOutcome::Reset, 0));
        assert!(s.fused() && s.test_ratio() > 1.0);
        assert_eq!(s.last_fused, Some(Timestamp(11 * DT)));
        reset = true;
        break;
    }
    assert!(reset);
    assert_eq!(f.flow_resets(), 1);
}

#[test]
fn zupt_status_after_each_update() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    level_start(&mut f);
    for k in 1..=200u64 {
        f.propagate(&rest(k * DT)).unwrap();
        if k % 5 == 0 {
            f.fuse_wheel(&wheels(k, 0.0)).unwrap();
        }
    }
    assert!(f.zupt_counts().fused() > 10);
    let s = *f.zupt_status().unwrap();
    assert_eq!(s.outcome, AidOutcome::Fused);
    assert_eq!(s.last_fused, Some(s.t));
    assert_eq!(s.observation, [0.0; 9]);
    assert!(s.nis.is_finite() && s.test_ratio() == 0.0);
    for (var, noise) in s.innovation_var.iter().zip(s.observation_var) {
        assert!(*var >= noise && noise > 0.0, "{s:?}");
    }
}
