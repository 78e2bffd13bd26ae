//! The maths of the wheel-odometry measurement.
//!
//! Each wheel's ground-contact point `c` (in the body, i.e. IMU, frame) moves,
//! seen in the robot frame, with `R_rb (R_wb^T v + w x p_bc)`; rolling without
//! slip, that is `[radius * rate, 0, 0]`. From both wheels the filter forms
//! four rows, all with measurement zero:
//!
//! 0. forward: `e_x . R_rb u_mid - (r_l w_l + r_r w_r) / 2` (the robot's
//!    forward speed, gated by the grip);
//! 1. differential: `e_x . R_rb (w x (p_br - p_bl)) - (r_r w_r - r_l w_l)`
//!    (the yaw rate seen by the wheels against the gyro's; gated with row 0);
//! 2. lateral: `e_y . R_rb u_mid` (non-holonomic, always fused);
//! 3. vertical: `e_z . R_rb u_mid` (non-holonomic, always fused);
//!
//! with `u_mid = R_wb^T v + w x p_mid`, `p_mid = (p_bl + p_br) / 2` the robot
//! origin and `w` the bias-corrected gyro rate. Jacobians are taken w.r.t.
//! velocity, attitude, gyro bias, both contact points, the body-to-robot
//! rotation and both radii, so the robot states are estimated.
//!
//! The Jacobians w.r.t. the radii use the predicted wheel rates instead of
//! the measured ones (see the code): the measured ones make the radius an
//! errors-in-variables regression, biased low.
//!
//! With per-wheel forward noise `s_f`, rows 0 and 1 have variances
//! `s_f^2 / 2` and `2 s_f^2` and are uncorrelated; rows 2 and 3 use the
//! grip's lateral noise.

use nalgebra::{Matrix3, RowVector2, SMatrix, SVector};
use vslam_core::sensors::WheelRates;

use crate::covariance::skew;
use crate::grip::GripParams;
use crate::state::{BG, CL, CR, DIM, NominalState, RAD, RB, TH, V, Vec3};
use crate::update::Measurement;

/// Row of the forward component.
pub const FORWARD: usize = 0;
/// Row of the differential (yaw-rate) component.
pub const DIFFERENTIAL: usize = 1;
/// Row of the lateral constraint.
pub const LATERAL: usize = 2;
/// Row of the vertical constraint.
pub const VERTICAL: usize = 3;

/// Builds the four-row wheel measurement at the current state.
///
/// `gyro` is the latest bias-corrected angular rate of the body.
pub fn wheel_measurement(
    x: &NominalState,
    gyro: &Vec3,
    rates: &WheelRates,
    grip: &GripParams,
) -> Measurement<4> {
    let r_rb = x.q_rb.to_rotation_matrix().into_inner();
    let r_wb = x.q_wb.to_rotation_matrix().into_inner();
    let v_b = r_wb.transpose() * x.v_wb;
    let p_mid = x.p_b_robot();
    let lever = x.p_br - x.p_bl;
    let u_mid = v_b + gyro.cross(&p_mid);
    let u_diff = gyro.cross(&lever);
    let w_mid = r_rb * u_mid;
    let w_diff = r_rb * u_diff;
    let (wl, wr) = (rates.left, rates.right);
    let (rl, rr) = (x.radius_left, x.radius_right);

    let h_val = SVector::<f32, 4>::new(
        w_mid.x - 0.5 * (rl * wl + rr * wr),
        w_diff.x - (rr * wr - rl * wl),
        w_mid.y,
        w_mid.z,
    );

    // Jacobians of R_rb u_mid and R_rb u_diff (3 rows each).
    let d_v = r_rb * r_wb.transpose();
    let d_th = r_rb * skew(&v_b);
    let d_bg_mid = r_rb * skew(&p_mid);
    let d_bg_diff = r_rb * skew(&lever);
    let d_c = r_rb * skew(gyro);
    let d_rb_mid = -r_rb * skew(&u_mid);
    let d_rb_diff = -r_rb * skew(&u_diff);

    let mut h = SMatrix::<f32, 4, DIM>::zeros();
    // Rows 0, 2, 3 are rows x, y, z of the mid-point velocity.
    for (row, axis) in [(FORWARD, 0usize), (LATERAL, 1), (VERTICAL, 2)] {
        put(&mut h, row, V, &d_v, axis);
        put(&mut h, row, TH, &d_th, axis);
        put(&mut h, row, BG, &d_bg_mid, axis);
        put(&mut h, row, CL, &(d_c * 0.5), axis);
        put(&mut h, row, CR, &(d_c * 0.5), axis);
        put(&mut h, row, RB, &d_rb_mid, axis);
    }
    put(&mut h, DIFFERENTIAL, BG, &d_bg_diff, 0);
    put(&mut h, DIFFERENTIAL, CL, &(-d_c), 0);
    put(&mut h, DIFFERENTIAL, CR, &d_c, 0);
    put(&mut h, DIFFERENTIAL, RB, &d_rb_diff, 0);
    // Radius columns. With the mean radius and the radius difference,
    // `r_l w_l + r_r w_r = 2 r_mean w_mean + dr dw / 2` and
    // `r_r w_r - r_l w_l = r_mean dw + dr w_mean`. The regressors are
    // evaluated at the *predicted* wheel rates (`w_mid.x / r_mean`,
    // `w_diff.x / r_mean`), as an EKF whose measurement is the wheel rate
    // itself would: with the measured, noisy rates the radius becomes an
    // errors-in-variables regression biased low (by 2-5 % in the Monte
    // Carlo test at 5-20 mm/s wheel noise). Equal to the exact Jacobian
    // of the rows when the wheels agree with the prediction.
    let r_mean = 0.5 * (rl + rr);
    let (w_mean, dw) = if r_mean > 0.0 {
        (w_mid.x / r_mean, w_diff.x / r_mean)
    } else {
        (0.5 * (wl + wr), wr - wl)
    };
    h.fixed_view_mut::<1, 2>(FORWARD, RAD)
        .copy_from(&RowVector2::new(
            -0.5 * w_mean + 0.25 * dw,
            -0.5 * w_mean - 0.25 * dw,
        ));
    h.fixed_view_mut::<1, 2>(DIFFERENTIAL, RAD)
        .copy_from(&RowVector2::new(w_mean - 0.5 * dw, -w_mean - 0.5 * dw));

    let sf2 = grip.forward_std() * grip.forward_std();
    let sl2 = grip.lateral_std() * grip.lateral_std();
    let noise = SMatrix::<f32, 4, 4>::from_diagonal(&SVector::<f32, 4>::new(
        0.5 * sf2,
        2.0 * sf2,
        sl2,
        sl2,
    ));
    Measurement {
        residual: -h_val,
        h,
        noise,
    }
}

/// Writes row `axis` of the 3x3 block `d` into row `row`, columns `col..col+3`.
fn put(h: &mut SMatrix<f32, 4, DIM>, row: usize, col: usize, d: &Matrix3<f32>, axis: usize) {
    h.fixed_view_mut::<1, 3>(row, col).copy_from(&d.row(axis));
}
