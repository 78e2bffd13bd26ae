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
//! - velocity: what the wheels measure at the end, the speed `s` along the
//!   robot's forward axis and the yaw rate `w`:
//!   `u = R_rb^T (s, 0, 0) + [l]x a w` (the IMU's velocity in the body),
//!   `v_1 = R_1 u`. The velocity before the gap is forgotten: the robot may
//!   have braked, stopped or started meanwhile;
//! - biases, gravity and robot states kept.
//!
//! Error state (local attitude errors, as in [`crate::propagate`]; `R_D =
//! Exp(a psi)`): the rows of `F` for position, attitude and velocity are
//!
//! - `dp_1 = dp_0 + (-[D]x R_0 - R_0 [l]x + R_1 [l]x R_D^T) dth_0 + G_p (K dk + n)`
//!   (plus `(R_0 - R_1) / 2` on each contact point, through `l`);
//! - `dth_1 = R_D^T dth_0 + G_th (K dk + n)`;
//! - `dv_1 = -R_1 [u]x dth_1 + R_1 R_rb^T du + R_1 [l]x a dw`, i.e.
//!   `-R_1 [u]x R_D^T dth_0 + G_v (K dk + n)` (no dependence on `dv_0`;
//!   plus `-R_1 [a w]x / 2` on each contact point, through `l`);
//!
//! with the noise `n` = the dead reckoning's `(x, y, psi)` (covariance `S`),
//! the end speed's forward, sideways and vertical parts and its yaw rate
//! (the latest wheel sample's variances), mapped by `G = [G_p; G_th; G_v]`:
//! `G_p = [R_0 R_rb^T diag(1, 1, 0) + R_1 [l]x a e_3^T, 0, 0]`,
//! `G_th = [a e_3^T, 0, 0]`, `G_v = [-R_1 [u]x a e_3^T, R_1 R_rb^T, R_1 [l]x a]`;
//! `K` stacks the Jacobians of `(x, y, psi)`, of the end speed and of the
//! end yaw rate w.r.t. `k = (r_l, r_r, L)` (the track `L = -e_y^T R_rb
//! (p_br - p_bl)` depends on both contact points and on `R_rb`). The
//! body-to-robot rotation `R_rb Exp(drb)` also tilts the turn's axis
//! (`dth_1 += psi J_r(a psi) [a]x drb`, `J_r` the right Jacobian of SO(3)),
//! turns the path (`dp_1 += R_0 [R_rb^T d]x drb`) and the end velocity. So `P <- F P F^T + G Sigma G^T +
//! Q`, `Q` the IMU's own process noise over the gap (biases and robot
//! states). `F P F^T` touches only the first nine rows and columns (`F`'s
//! velocity columns there are zero); the velocity block gets the wheels'
//! noise, so `P` stays positive definite. The result is symmetrised and
//! written only if finite.

use nalgebra::{Matrix3, RowVector3, SMatrix};

use crate::config::FilterConfig;
use crate::covariance::{skew, symmetrize};
use crate::gap::dead_reckoning::{DeadReckoning, WheelGeometry};
use crate::grip::GripParams;
use crate::propagate::process_noise;
use crate::state::{CL, CR, Covariance, DIM, NominalState, P, Quat, RAD_L, RAD_R, RB, TH, V, Vec3};

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

/// The right Jacobian of SO(3) at `phi` (Solà 2017, eq. 183).
fn right_jacobian(phi: &Vec3) -> Matrix3<f32> {
    let theta = phi.norm();
    let k = skew(phi);
    if theta < 1e-4 {
        return Matrix3::identity() - k * 0.5;
    }
    let t2 = theta * theta;
    Matrix3::identity() - k * ((1.0 - libm::cosf(theta)) / t2)
        + k * k * ((theta - libm::sinf(theta)) / (t2 * theta))
}

/// Size of the noise `n`: dead reckoning `(x, y, psi)`, end speed
/// (forward, sideways, vertical), end yaw rate.
const NOISE: usize = 7;

/// The bridged pose and the linearisation of the bridge (see the module
/// docs).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Moved {
    p_wb: Vec3,
    v_wb: Vec3,
    q_wb: Quat,
    /// The first nine rows of `F`.
    f: SMatrix<f32, POSE_VEL, DIM>,
    /// `G`: the noise `n` into those rows.
    g: SMatrix<f32, POSE_VEL, NOISE>,
    /// The covariance of `n`.
    sigma: SMatrix<f32, NOISE, NOISE>,
}

fn moved(x: &NominalState, motion: &DeadReckoning) -> Moved {
    let r0 = x.q_wb.to_rotation_matrix().into_inner();
    let r_rb = x.q_rb.to_rotation_matrix().into_inner();
    let axis = r_rb.transpose() * Vec3::z();
    let r_wr0 = r0 * r_rb.transpose();
    let delta = r_wr0 * Vec3::new(motion.x, motion.y, 0.0);
    let q_turn = Quat::from_scaled_axis(axis * motion.psi);
    let r_turn = q_turn.to_rotation_matrix().into_inner();
    let r1 = r0 * r_turn;
    let lever = x.p_b_robot();
    let lever_turn = r1 * skew(&lever);
    let lever_rate = skew(&lever) * axis;
    let u = r_rb.transpose() * Vec3::new(motion.speed, 0.0, 0.0) + lever_rate * motion.yaw_rate;
    let k_v = -(r1 * skew(&u));

    let mut g = SMatrix::<f32, POSE_VEL, NOISE>::zeros();
    g.fixed_view_mut::<3, 2>(P, 0)
        .copy_from(&r_wr0.fixed_columns::<2>(0));
    g.fixed_view_mut::<3, 1>(P, 2)
        .copy_from(&(lever_turn * axis));
    g.fixed_view_mut::<3, 1>(TH, 2).copy_from(&axis);
    g.fixed_view_mut::<3, 1>(V, 2).copy_from(&(k_v * axis));
    g.fixed_view_mut::<3, 3>(V, 3)
        .copy_from(&(r1 * r_rb.transpose()));
    g.fixed_view_mut::<3, 1>(V, 6).copy_from(&(r1 * lever_rate));
    let mut sigma = SMatrix::<f32, NOISE, NOISE>::zeros();
    sigma.fixed_view_mut::<3, 3>(0, 0).copy_from(&motion.noise);
    let rv = motion.rate_var;
    for (i, var) in [(3, rv.x), (4, rv.y), (5, rv.y), (6, rv.z)] {
        if let Some(e) = sigma.get_mut((i, i)) {
            *e = var;
        }
    }
    // K: n's dependence on k = (r_l, r_r, L).
    let mut k = SMatrix::<f32, NOISE, 3>::zeros();
    k.fixed_rows_mut::<3>(0).copy_from(&motion.jacobian);
    k.set_row(3, &motion.rate_jacobian.row(0));
    k.set_row(6, &motion.rate_jacobian.row(1));

    // F's first nine rows.
    let mut f = SMatrix::<f32, POSE_VEL, DIM>::zeros();
    f.fixed_view_mut::<3, 3>(P, P).fill_with_identity();
    let f_pth = -skew(&delta) * r0 - r0 * skew(&lever) + lever_turn * r_turn.transpose();
    f.fixed_view_mut::<3, 3>(P, TH).copy_from(&f_pth);
    f.fixed_view_mut::<3, 3>(TH, TH)
        .copy_from(&r_turn.transpose());
    f.fixed_view_mut::<3, 3>(V, TH)
        .copy_from(&(k_v * r_turn.transpose()));
    // The body-to-robot rotation: it sets the turn's axis, the path's
    // direction and the end velocity's direction.
    let th_rb = right_jacobian(&(axis * motion.psi)) * skew(&axis) * motion.psi;
    let forward_b = r_rb.transpose() * Vec3::new(motion.speed, 0.0, 0.0);
    let d_b = r_rb.transpose() * Vec3::new(motion.x, motion.y, 0.0);
    let p_rb = r0 * skew(&d_b) + lever_turn * th_rb;
    let v_rb = k_v * th_rb + r1 * (skew(&forward_b) + skew(&lever) * skew(&axis) * motion.yaw_rate);
    f.fixed_view_mut::<3, 3>(P, RB).copy_from(&p_rb);
    f.fixed_view_mut::<3, 3>(TH, RB).copy_from(&th_rb);
    f.fixed_view_mut::<3, 3>(V, RB).copy_from(&v_rb);
    // Radii and track.
    let g_k = g * k;
    let track_row: RowVector3<f32> = r_rb.row(1).into_owned();
    let d_track = g_k.column(2) * track_row;
    f.fixed_view_mut::<POSE_VEL, 1>(0, RAD_L)
        .copy_from(&g_k.column(0));
    f.fixed_view_mut::<POSE_VEL, 1>(0, RAD_R)
        .copy_from(&g_k.column(1));
    // The robot origin `l` is the contact points' mean: it moves the
    // position and, turning, the IMU's velocity.
    let track_rb = track_row * skew(&(x.p_br - x.p_bl));
    let mut rb_cols = f.fixed_view::<POSE_VEL, 3>(0, RB).into_owned();
    rb_cols += g_k.column(2) * track_rb;
    f.fixed_view_mut::<POSE_VEL, 3>(0, RB).copy_from(&rb_cols);
    let half_lever = (r0 - r1) * 0.5;
    let half_lever_v = -(r1 * skew(&(axis * motion.yaw_rate))) * 0.5;
    for (col, sign) in [(CL, 1.0f32), (CR, -1.0)] {
        let mut block = d_track * sign;
        block
            .fixed_view_mut::<3, 3>(P, 0)
            .zip_apply(&half_lever, |a, b| *a += b);
        block
            .fixed_view_mut::<3, 3>(V, 0)
            .zip_apply(&half_lever_v, |a, b| *a += b);
        f.fixed_view_mut::<POSE_VEL, 3>(0, col).copy_from(&block);
    }
    Moved {
        p_wb: x.p_wb + r0 * lever + delta - r1 * lever,
        v_wb: r1 * u,
        q_wb: Quat::new_normalize((x.q_wb * q_turn).into_inner()),
        f,
        g,
        sigma,
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
    let Moved {
        p_wb,
        v_wb,
        q_wb,
        f,
        g,
        sigma,
    } = moved(x, motion);
    let mut next = *p;
    let rows = f * next;
    next.fixed_rows_mut::<POSE_VEL>(0).copy_from(&rows);
    let cols = next * f.transpose();
    next.fixed_columns_mut::<POSE_VEL>(0).copy_from(&cols);
    let q_wheels = g * sigma * g.transpose();
    next.fixed_view_mut::<POSE_VEL, POSE_VEL>(0, 0)
        .zip_apply(&q_wheels, |a, b| *a += b);
    let imu = process_noise(&config.imu, &config.robot, gap_s);
    for (i, q_imu) in imu.iter().enumerate() {
        if let Some(d) = next.get_mut((i, i)) {
            *d += q_imu;
        }
    }
    symmetrize(&mut next);
    let finite = next.iter().all(|v| v.is_finite())
        && p_wb.iter().chain(v_wb.iter()).all(|v| v.is_finite())
        && q_wb.coords.iter().all(|v| v.is_finite());
    if !finite {
        return false;
    }
    *p = next;
    x.p_wb = p_wb;
    x.v_wb = v_wb;
    x.q_wb = q_wb;
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RobotPrior;
    use crate::gap::test_support::{positive_definite, random_covariance as covariance};
    use crate::state::{ErrorState, RAD};

    fn state() -> NominalState {
        let r = RobotPrior::default();
        NominalState {
            p_wb: Vec3::new(1.0, -2.0, 0.06),
            v_wb: Quat::from_euler_angles(0.0, 0.0, 0.7) * Vec3::new(0.28, 0.01, 0.0),
            q_wb: Quat::from_euler_angles(0.02, -0.03, 0.7),
            accel_bias: Vec3::zeros(),
            gyro_bias: Vec3::zeros(),
            gravity: Vec3::new(0.0, 0.0, -9.8),
            gyro_scale: 0.0,
            clone_p_wb: Vec3::zeros(),
            clone_q_wb: Quat::identity(),
            p_bl: r.p_bl + Vec3::new(0.003, 0.002, -0.001),
            p_br: r.p_br + Vec3::new(-0.002, 0.001, 0.002),
            q_rb: Quat::from_euler_angles(0.01, 0.02, -0.015),
            radius_left: 0.035,
            radius_right: 0.0352,
        }
    }

    /// A left turn that speeds up, dead-reckoned with the state's geometry.
    fn motion(x: &NominalState) -> DeadReckoning {
        let g = wheel_geometry(x, &GripParams::default());
        let mut d = DeadReckoning::default();
        for k in 0..25 {
            let l = 6.0 + 0.04 * k as f32;
            let r = 9.0 + 0.08 * k as f32;
            assert!(d.step(&g, l, r, 0.02));
        }
        d
    }

    #[test]
    fn the_transition_matches_finite_differences() {
        let x = state();
        let m0 = moved(&x, &motion(&x));
        let columns = (0..9)
            .chain(CL..CL + 6)
            .chain(RB..RB + 3)
            .chain(RAD..RAD + 2);
        for i in columns {
            let h = if i >= RAD { 1e-4 } else { 1e-3 };
            let mut dx = ErrorState::zeros();
            dx[i] = h;
            let mut xp = x;
            xp.inject(&dx);
            let m = moved(&xp, &motion(&xp));
            let dth = (m0.q_wb.inverse() * m.q_wb).scaled_axis();
            let got = [m.p_wb - m0.p_wb, m.v_wb - m0.v_wb, dth];
            for (block, d) in got.iter().enumerate() {
                let predicted = m0.f.fixed_view::<3, 1>(3 * block, i) * h;
                let err = (predicted - d).amax();
                assert!(
                    err <= 0.03 * d.amax() + 3e-6,
                    "column {i}, block {block}: F says {predicted:?}, moved {d:?}"
                );
            }
        }
    }

    #[test]
    fn the_covariance_stays_symmetric_positive_definite_and_grows() {
        let c = FilterConfig::default();
        for seed in 1..5 {
            let mut x = state();
            let mut p = covariance(seed);
            assert!(positive_definite(&p));
            let m = motion(&x);
            let yaw_axis = x.q_rb.inverse() * Vec3::z();
            let yaw_var =
                |p: &Covariance| (yaw_axis.transpose() * p.fixed_view::<3, 3>(TH, TH) * yaw_axis).x;
            let before = yaw_var(&p);
            assert!(bridge_with_wheels(&mut x, &mut p, &c, &m, 0.5));
            assert_eq!(p, p.transpose());
            assert!(positive_definite(&p), "seed {seed}");
            // At least the wheels' own yaw noise was added.
            assert!(yaw_var(&p) >= before + 0.9 * m.noise[(2, 2)]);
            assert!(x.is_finite());
        }
    }

    #[test]
    fn bad_input_changes_nothing() {
        let c = FilterConfig::default();
        let x0 = state();
        let p0 = covariance(9);
        let m = motion(&x0);
        let (mut x, mut p) = (x0, p0);
        for gap in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(!bridge_with_wheels(&mut x, &mut p, &c, &m, gap));
        }
        let mut nan = m;
        nan.x = f32::NAN;
        assert!(!bridge_with_wheels(&mut x, &mut p, &c, &nan, 0.5));
        let mut huge = m;
        huge.noise[(2, 2)] = f32::MAX;
        assert!(!bridge_with_wheels(&mut x, &mut p, &c, &huge, 0.5));
        assert_eq!((x, p), (x0, p0));
    }

    #[test]
    fn the_velocity_after_the_bridge_is_the_wheels_end_speed() {
        let c = FilterConfig::default();
        let mut x = state();
        // Uncertainties of a filter that has run a while.
        let r = c.robot;
        let mut d = crate::state::ErrorState::from_element(1e-8);
        for (start, len, std) in [
            (P, 3, 0.01),
            (V, 3, 0.01),
            (TH, 3, 1e-3),
            (CL, 6, r.contact_std),
            (RAD, 2, r.radius_std),
        ] {
            d.rows_mut(start, len).fill(std * std);
        }
        let mut p = Covariance::from_diagonal(&d);
        let m = motion(&x);
        assert!(bridge_with_wheels(&mut x, &mut p, &c, &m, 0.5));
        let fwd = x.q_wb * (x.q_rb.inverse() * Vec3::x());
        // (The IMU is not at the robot origin: a few mm/s of the turn.)
        assert!((x.v_wb.dot(&fwd) - m.speed).abs() < 5e-3);
        // Known to the wheels' noise and the radius uncertainty (1 mm of
        // 35 mm: 3 %), not to the constant-velocity bridge's 0.35 m/s.
        let v_var = (fwd.transpose() * p.fixed_view::<3, 3>(V, V) * fwd).x;
        let radius_part = (0.03 * m.speed).powi(2);
        assert!(v_var >= 0.9 * m.rate_var.x, "{v_var}");
        assert!(v_var < 2.0 * (m.rate_var.x + radius_part), "{v_var}");
        assert!(positive_definite(&p));
    }
}
