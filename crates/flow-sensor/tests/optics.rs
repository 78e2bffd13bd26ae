//! Counts to radians and metres through vslam-core's `FlowOptics`.

use flow_sensor::Variant;
use flow_sensor::optics::{OpticsError, angular_flow, default_optics, floor_displacement};
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{FlowOptics, FlowSample};

#[test]
fn pmw3901_default_resolution_converts_counts() {
    let o = default_optics(Variant::Pmw3901, 0.1, Extrinsics::identity()).unwrap();
    let s = FlowSample {
        dx: 500,
        dy: -250,
        ..FlowSample::default()
    };
    let [ax, ay] = angular_flow(&s, &o);
    assert!((ax - 1.0).abs() < 1e-6 && (ay + 0.5).abs() < 1e-6);
    let [mx, my] = floor_displacement(&s, &o);
    assert!((mx - 0.1).abs() < 1e-6 && (my + 0.05).abs() < 1e-6);
}

#[test]
fn paa5100_needs_a_calibrated_resolution() {
    assert_eq!(
        default_optics(Variant::Paa5100je, 0.025, Extrinsics::identity()),
        Err(OpticsError::NoDefaultResolution)
    );
    let o = FlowOptics::new(2000.0, 0.025, Extrinsics::identity()).unwrap();
    let s = FlowSample {
        dx: 2000,
        ..FlowSample::default()
    };
    assert!((floor_displacement(&s, &o)[0] - 0.025).abs() < 1e-6);
    assert!(matches!(
        default_optics(Variant::Pmw3901, -1.0, Extrinsics::identity()),
        Err(OpticsError::Optics(_))
    ));
}
