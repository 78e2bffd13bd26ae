//! The measurement Jacobians equal finite differences of the measurement
//! functions (perturbing the nominal state through the filter's own error
//! injection, so the local rotation conventions are checked too).

use ego_ekf::camera::model::{pose_measurement, predicted, rotation_measurement};
use ego_ekf::config::{CameraConfig, FloorConfig, FlowConfig, ZuptConfig};
use ego_ekf::floor::model::floor_measurement;
use ego_ekf::flow::model::flow_measurement;
use ego_ekf::grip::GripParams;
use ego_ekf::state::{DIM, ErrorState, NominalState, Quat, Vec3};
use ego_ekf::update::Measurement;
use ego_ekf::wheel::model::wheel_measurement;
use ego_ekf::zupt::model::zupt_measurement;
use nalgebra::{SVector, Vector2};
use vslam_core::Timestamp;
use vslam_core::sensors::WheelRates;

fn state() -> NominalState {
    let q_wb = Quat::from_euler_angles(0.05, -0.03, 1.2);
    NominalState {
        p_wb: Vec3::new(1.0, -2.0, 0.06),
        v_wb: Vec3::new(0.25, 0.12, -0.02),
        q_wb,
        accel_bias: Vec3::new(0.01, -0.02, 0.03),
        gyro_bias: Vec3::new(0.001, 0.002, -0.003),
        gravity: Vec3::new(0.0, 0.0, -9.81),
        gyro_scale: 0.004,
        clone_p_wb: Vec3::new(1.001, -2.002, 0.0605),
        clone_q_wb: q_wb * Quat::from_scaled_axis(Vec3::new(0.002, -0.001, 0.003)),
        p_bl: Vec3::new(0.01, 0.11, -0.06),
        p_br: Vec3::new(-0.005, -0.12, -0.055),
        q_rb: Quat::from_euler_angles(0.02, -0.01, 0.03),
        radius_left: 0.035,
        radius_right: 0.035,
    }
}

/// h(x) recovered from a measurement built at `x` (h = z - residual).
fn check<const M: usize>(build: impl Fn(&NominalState) -> Measurement<M>, z: SVector<f32, M>) {
    let x0 = state();
    let m0 = build(&x0);
    let h0 = z - m0.residual;
    let eps = 1e-3f32;
    for j in 0..DIM {
        let mut dx = ErrorState::zeros();
        dx[j] = eps;
        let mut xp = x0;
        xp.inject(&dx);
        let mut xm = x0;
        xm.inject(&(-dx));
        let hp = z - build(&xp).residual;
        let hm = z - build(&xm).residual;
        let numeric = (hp - hm) / (2.0 * eps);
        let analytic = m0.h.column(j);
        for i in 0..M {
            let tol = 2e-3 * (1.0 + analytic[i].abs());
            assert!(
                (numeric[i] - analytic[i]).abs() < tol,
                "row {i} column {j}: numeric {} analytic {} (h0 {})",
                numeric[i],
                analytic[i],
                h0[i]
            );
        }
    }
}

#[test]
fn wheel_jacobian_matches_finite_differences() {
    // The filter passes the gyro corrected by the current bias and scale
    // factor estimates.
    let raw = Vec3::new(0.05, -0.04, 0.9);
    // Rates that agree with the state's prediction, where the radius
    // columns (evaluated at the predicted rates) equal the exact Jacobian.
    let x = state();
    let zero = WheelRates::new(Timestamp(1), 0.0, 0.0).unwrap();
    let m = wheel_measurement(&x, &x.corrected_gyro(&raw), &zero, &GripParams::default());
    let (mid, diff) = (-m.residual[0], -m.residual[1]);
    let rates = WheelRates::new(
        Timestamp(1),
        (mid - 0.5 * diff) / x.radius_left,
        (mid + 0.5 * diff) / x.radius_right,
    )
    .unwrap();
    let grip = GripParams::default();
    check(
        |x| wheel_measurement(x, &x.corrected_gyro(&raw), &rates, &grip),
        SVector::zeros(),
    );
}

#[test]
fn flow_jacobian_matches_finite_differences() {
    let raw = Vec3::new(0.05, -0.04, 0.9);
    let z = Vector2::new(0.3, -0.05);
    check(|x| flow_measurement(x, &(raw - x.gyro_bias), &z, 0.01), z);
}

#[test]
fn zupt_jacobian_matches_finite_differences() {
    let c = ZuptConfig::default();
    check(|x| zupt_measurement(x, &c), SVector::zeros());
}

#[test]
fn floor_jacobian_matches_finite_differences() {
    // A fast turn, so the lever-arm columns (gyro bias, contact points,
    // attitude through w x c) are far from zero.
    let raw = Vec3::new(0.3, -0.2, 1.5);
    let c = FloorConfig::default();
    let floor = 0.02;
    check(
        |x| floor_measurement(x, &(raw - x.gyro_bias), floor, &c),
        SVector::<f32, 2>::new(floor, 0.0),
    );
}

#[test]
fn flow_config_defaults_are_usable() {
    let optics = vslam_core::sensors::FlowOptics::new(
        500.0,
        0.03,
        vslam_core::geometry::Extrinsics::identity(),
    )
    .unwrap();
    let f = FlowConfig::new(optics);
    assert!(f.gate > 0.0 && f.base_std > 0.0);
}

#[test]
fn camera_jacobians_match_finite_differences() {
    // Measured = predicted at the linearisation point, so that h(x) =
    // -residual(x) is the predicted motion's local difference from it.
    let c = CameraConfig::default();
    let (rel, t_rel) = predicted(&state());
    let cov = nalgebra::Matrix3::identity() * 1e-6;
    check(|x| rotation_measurement(x, &rel, &c), SVector::zeros());
    check(
        |x| pose_measurement(x, &rel, &t_rel, &cov, &c),
        SVector::zeros(),
    );
}
