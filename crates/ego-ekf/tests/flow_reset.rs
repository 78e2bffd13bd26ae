//! A filter whose velocity has run away gates every flow report; after a run
//! of gated reports of valid quality it resets its velocity to the flow's and
//! says so. With the reset switched off it stays locked out (the test of the
//! test).

use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, FlowConfig};
use nalgebra::Vector3;
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample};
use vslam_core::{Reject, Timestamp};

fn filter(reset_after_gated: u16) -> EgoEkf {
    let optics = FlowOptics::new(500.0, 0.03, Extrinsics::identity()).unwrap();
    let mut config = FilterConfig::default();
    let mut flow = FlowConfig::new(optics);
    flow.velocity_reset_after_gated = reset_after_gated;
    config.flow = Some(flow);
    let mut f = EgoEkf::new(config).unwrap();
    // The filter believes it drives 1 m/s forward; the robot stands still.
    f.start(&ExplicitStart {
        v_wb: Vector3::new(1.0, 0.0, 0.0),
        ..ExplicitStart::at_rest(Timestamp(0))
    })
    .unwrap();
    f
}

/// Two seconds standing still: IMU at 250 Hz, flow reports of zero motion at 100 Hz.
fn run(f: &mut EgoEkf) -> (u32, u32) {
    let (mut gated, mut reset_at) = (0u32, 0u32);
    for k in 1..=500u64 {
        let t = Timestamp(k * 4_000_000);
        let imu = ImuSample::new(t, [0.0; 3], [0.0, 0.0, 9.806_65]).unwrap();
        f.propagate(&imu).unwrap();
        if k % 5 == 0 {
            let s = FlowSample {
                t: Timestamp(k * 4_000_000 + 1),
                squal: 120,
                shutter: 0x0200,
                ..FlowSample::default()
            };
            match f.fuse_flow(&s) {
                Err(Reject::Gated) => gated += 1,
                Ok(fused) if fused.reset => reset_at = k as u32,
                _ => {}
            }
        }
    }
    (gated, reset_at)
}

#[test]
fn a_run_of_gated_flow_resets_the_velocity() {
    let mut f = filter(25);
    let (gated, reset_at) = run(&mut f);
    assert_eq!(f.flow_resets(), 1, "gated {gated}");
    assert!(reset_at > 0);
    assert!(
        f.velocity().norm() < 0.05,
        "velocity after reset {:?}",
        f.velocity()
    );
    assert_eq!(f.flow_counts().gated(), gated);
    // P stays symmetric positive definite.
    let p = f.covariance();
    assert!((p - p.transpose()).amax() < 1e-6);
    assert!(p.cholesky().is_some());
}

#[test]
fn without_the_reset_the_filter_stays_locked_out() {
    let mut f = filter(0);
    let (gated, _) = run(&mut f);
    assert_eq!(f.flow_resets(), 0);
    assert!(gated > 90, "gated {gated} of 99 reports");
    assert!(f.velocity().norm() > 0.5, "velocity {:?}", f.velocity());
}
