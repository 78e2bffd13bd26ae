//! Bridging an IMU gap with the wheels' dead reckoning: the planar motion
//! `(x, y, psi)` integrated over the gap in the robot frame at its start
//! ([`crate::gap::dead_reckoning`]) moves the filter's pose, and its noise
//! and its dependence on the estimated radii and track go into `P`.
//!
//! Nominal state (`R_0`, `R_rb` the attitude before the gap and the
//! body-to-robot rotation, `a = R_rb^T e_z` the robot's up axis in the body,
//! `l` the robot origin in the body, `d = (x, y, 0)`):
//!
//! - attitude: `q_1 = q_0 Exp(a psi)` (a turn about the robot's up axis);
//! - position of the robot origin moves by `D = R_0 R_rb^T d`:
//!   `p_1 = p_0 + R_0 l + D - R_1 l`;
//! - velocity: kept in the body frame, `v_1 = R_1 R_0^T v_0` (it turned with
//!   the robot); its covariance grows as in the constant-velocity bridge
//!   (`GapConfig::accel_density^2 T`), the wheel updates after the gap
//!   measure it again;
//! - biases, gravity and robot states kept.
//!
//! Error state (local attitude errors, as in [`crate::propagate`]; `R_D =
//! Exp(a psi)`, `u = R_0^T v_0`): the rows of `F` for position, velocity and
//! attitude are
//!
//! - `dp_1 = dp_0 + (-[D]x R_0 - R_0 [l]x + R_1 [l]x R_D^T) dth_0 + G_p (J dk + n)`
//!   (plus `(R_0 - R_1) / 2` on each contact point, through `l`);
//! - `dth_1 = R_D^T dth_0 + G_th (J dk + n)`, `G_th = a e_3^T`;
//! - `dv_1 = R_1 R_0^T dv_0 + R_1 [u]x (I - R_D^T) dth_0 + G_v (J dk + n)`,
//!   `G_v = -R_1 [u]x a e_3^T`;
//!
//! with `G_p = R_0 R_rb^T diag(1, 1, 0) + R_1 [l]x a e_3^T`, `J` the
//! dead-reckoning Jacobian w.r.t. `k = (r_l, r_r, L)` (the track `L =
//! -e_y^T R_rb (p_br - p_bl)` depends on both contact points), and `n` its
//! noise with covariance `S`. So `P <- F P F^T + G S G^T + Q`, `Q` the
//! velocity's growth and the IMU's own process noise over the gap (biases
//! and robot states). `F P F^T` touches only the first nine rows and
//! columns; the result is symmetrised and written only if finite.

use nalgebra::{Matrix3, RowVector3, SMatrix};

use crate::config::FilterConfig;
use crate::covariance::{skew, symmetrize};
use crate::gap::dead_reckoning::{DeadReckoning, WheelGeometry};
use crate::grip::GripParams;
use crate::propagate::process_noise;
use crate::state::{CL, CR, Covariance, DIM, NominalState, P, Quat, RAD_L, RAD_R, TH, V, Vec3};

/// Position, velocity and attitude: the first nine error-state rows.
const POSE_VEL: usize = 9;
const _: () = assert!(P == 0 && V == 3 && TH == 6);

/// The wheel geometry the filter currently believes (radii, the track
/// between its contact points as the robot frame sees them) with the
/// current floor's noise.
pub fn wheel_geometry(x: &NominalState, grip: &GripParams) -> WheelGeometry {
    let lever = x.q_rb * (x.p_br - x.p_bl);
    WheelGeometry {
        radius_left: x.radius_left,
        radius_right: x.radius_right,
        track: -lever.y,
        forward_std: grip.forward_std(),
        lateral_std: grip.lateral_std(),
    }
}

/// Bridges a gap of `gap_s` seconds over which the wheels dead-reckoned
/// `motion`; returns `false` (and changes nothing) for a non-finite or
/// non-positive gap or a non-finite result.
pub fn bridge_with_wheels(
    x: &mut NominalState,
    p: &mut Covariance,
    config: &FilterConfig,
    motion: &DeadReckoning,
    gap_s: f32,
) -> bool {
    if !(gap_s.is_finite() && gap_s > 0.0) {
        return false;
    }
    let r0 = x.q_wb.to_rotation_matrix().into_inner();
    let r_rb = x.q_rb.to_rotation_matrix().into_inner();
    let axis = r_rb.transpose() * Vec3::z();
    let r_wr0 = r0 * r_rb.transpose();
    let delta = r_wr0 * Vec3::new(motion.x, motion.y, 0.0);
    let q_turn = Quat::from_scaled_axis(axis * motion.psi);
    let r_turn = q_turn.to_rotation_matrix().into_inner();
    let r1 = r0 * r_turn;
    let lever = x.p_b_robot();
    let v_b0 = r0.transpose() * x.v_wb;
    let k_v = r1 * skew(&v_b0);
    let lever_turn = r1 * skew(&lever);

    // Noise Jacobian G: (x, y, psi) of the dead reckoning -> (p, v, th).
    let mut g = SMatrix::<f32, POSE_VEL, 3>::zeros();
    let mut g_p = Matrix3::zeros();
    g_p.fixed_columns_mut::<2>(0)
        .copy_from(&r_wr0.fixed_columns::<2>(0));
    g_p.set_column(2, &(lever_turn * axis));
    g.fixed_view_mut::<3, 3>(P, 0).copy_from(&g_p);
    g.fixed_view_mut::<3, 1>(V, 2).copy_from(&(-k_v * axis));
    g.fixed_view_mut::<3, 1>(TH, 2).copy_from(&axis);

    // F's first nine rows.
    let mut f = SMatrix::<f32, POSE_VEL, DIM>::zeros();
    f.fixed_view_mut::<POSE_VEL, POSE_VEL>(0, 0)
        .fill_with_identity();
    let f_pth = -skew(&delta) * r0 - r0 * skew(&lever) + lever_turn * r_turn.transpose();
    f.fixed_view_mut::<3, 3>(P, TH).copy_from(&f_pth);
    f.fixed_view_mut::<3, 3>(V, V)
        .copy_from(&(r1 * r0.transpose()));
    let f_vth = k_v * (Matrix3::identity() - r_turn.transpose());
    f.fixed_view_mut::<3, 3>(V, TH).copy_from(&f_vth);
    f.fixed_view_mut::<3, 3>(TH, TH)
        .copy_from(&r_turn.transpose());
    // Radii and track, through the dead reckoning.
    let g_k = g * motion.jacobian;
    let track_row: RowVector3<f32> = r_rb.row(1).into_owned();
    let d_track = g_k.column(2) * track_row;
    f.fixed_view_mut::<POSE_VEL, 1>(0, RAD_L)
        .copy_from(&g_k.column(0));
    f.fixed_view_mut::<POSE_VEL, 1>(0, RAD_R)
        .copy_from(&g_k.column(1));
    let half_lever = (r0 - r1) * 0.5;
    for (col, sign) in [(CL, 1.0f32), (CR, -1.0)] {
        let mut block = d_track * sign;
        block
            .fixed_view_mut::<3, 3>(P, 0)
            .zip_apply(&half_lever, |a, b| *a += b);
        f.fixed_view_mut::<POSE_VEL, 3>(0, col).copy_from(&block);
    }

    let mut next = *p;
    let rows = f * next;
    next.fixed_rows_mut::<POSE_VEL>(0).copy_from(&rows);
    let cols = next * f.transpose();
    next.fixed_columns_mut::<POSE_VEL>(0).copy_from(&cols);
    let q_dr = g * motion.noise * g.transpose();
    next.fixed_view_mut::<POSE_VEL, POSE_VEL>(0, 0)
        .zip_apply(&q_dr, |a, b| *a += b);
    let q_v = config.gap.accel_density * config.gap.accel_density * gap_s;
    let imu = process_noise(&config.imu_noise, &config.robot, gap_s);
    for (i, q_imu) in imu.iter().enumerate() {
        let extra = if (V..V + 3).contains(&i) { q_v } else { 0.0 };
        if let Some(d) = next.get_mut((i, i)) {
            *d += q_imu + extra;
        }
    }
    symmetrize(&mut next);

    let p1 = x.p_wb + r0 * lever + delta - r1 * lever;
    let v1 = r1 * v_b0;
    let q1 = Quat::new_normalize((x.q_wb * q_turn).into_inner());
    let finite = next.iter().all(|v| v.is_finite())
        && p1.iter().chain(v1.iter()).all(|v| v.is_finite())
        && q1.coords.iter().all(|v| v.is_finite());
    if !finite {
        return false;
    }
    *p = next;
    x.p_wb = p1;
    x.v_wb = v1;
    x.q_wb = q1;
    true
}
