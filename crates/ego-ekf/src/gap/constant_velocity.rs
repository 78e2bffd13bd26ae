//! Bridging an IMU gap at constant velocity and constant yaw rate: the
//! fallback when the wheels did not dead-reckon it (see [`crate::gap`]).
//!
//! When the IMU stream breaks for longer than the configured step
//! (`ImuConfig::max_dt_ns`), the sample after the break is refused
//! ([`vslam_core::Reject::Gap`]) and the clock restarts at it, so the next
//! step integrates only the normal interval. The robot kept moving meanwhile,
//! unmeasured; left alone, the filter would keep its old position with its old
//! confidence and gate every wheel and flow update that tells it otherwise (a
//! lockout). So the gap of `T` seconds is bridged with the prediction of a
//! white-noise-acceleration (constant-velocity) model (Bar-Shalom, Li and
//! Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
//! 2001, sec. 6.2.2) for the position, and of a constant turn rate for the
//! heading (the coordinated-turn assumption of the same book, sec. 11.7.1,
//! applied to the attitude only), in the filter's error state:
//!
//! - nominal: `p <- p + v T`; `q <- q Exp(w_u T)`, `w_u = u u^T w` the last
//!   step's bias-corrected angular rate `w` about the vertical `u` (the
//!   estimated gravity's direction, in the body frame): the heading keeps
//!   turning as it last turned, the tilt is kept; velocity, biases and robot
//!   states kept;
//! - covariance: `P <- F P F^T + Q` with `F = I` except `dp/dv = I T`,
//!   `dtheta/dtheta = Exp(w_u T)^T`, `dtheta/db_g = -u u^T T` (and the gyro's
//!   z scale factor's column `u u^T (d w / d k) T` when it is estimated); per
//!   axis `Q_pp = q T^3 / 3`, `Q_pv = q T^2 / 2`, `Q_vv = q T` for the
//!   unmeasured acceleration density `q = GapConfig::accel_density^2`; the
//!   heading about `u` grows by `s^2`, `s` the turn the held rate may miss:
//!   a rate changing by at most `GapConfig::yaw_accel` per second misses at
//!   most `yaw_accel T^2 / 2`, and one that went anywhere within
//!   `GapConfig::max_yaw_rate` of either direction misses at most
//!   `(|w_u| + max_yaw_rate) T`; `s` is the smaller; and the IMU's own
//!   process noise over `T` (biases and robot states random walks, see
//!   [`crate::propagate::process_noise`]).
//!
//! `Q` is positive semi-definite and `F` is invertible (a rotation on the
//! attitude block, triangular elsewhere), so `P` stays symmetric positive
//! definite. Nothing is written unless every result is finite.

use nalgebra::Matrix3;

use crate::config::FilterConfig;
use crate::covariance::symmetrize;
use crate::propagate::{exp_so3, process_noise};
use crate::state::{BG, Covariance, KG, NominalState, P, TH, V, Vec3, rotate_local};

/// The vertical (up) in the body frame: the estimated gravity's opposite
/// turned into the body; `None` for a degenerate gravity.
fn body_up(x: &NominalState) -> Option<Vec3> {
    let g = x.gravity.norm();
    (g.is_finite() && g > 0.0).then(|| x.q_wb.inverse() * (-x.gravity / g))
}

/// The heading the held rate may miss over `t` seconds, rad (see the module
/// docs), for the held rate about the vertical `rate_up`, rad/s.
pub fn missed_turn(config: &FilterConfig, rate_up: f32, t: f32) -> f32 {
    let by_accel = 0.5 * config.gap.yaw_accel * t * t;
    let by_rate = (libm::fabsf(rate_up) + config.gap.max_yaw_rate) * t;
    by_accel.min(by_rate)
}

/// Bridges a gap of `gap_s` seconds, the angular rate `gyro` (body frame,
/// bias-corrected, rad/s) held about the vertical; returns `false` (and
/// changes nothing) for a non-finite or non-positive gap, a non-finite rate
/// or a non-finite result.
pub fn bridge_gap(
    x: &mut NominalState,
    p: &mut Covariance,
    config: &FilterConfig,
    gyro: &Vec3,
    gap_s: f32,
) -> bool {
    if !(gap_s.is_finite() && gap_s > 0.0 && gyro.iter().all(|w| w.is_finite())) {
        return false;
    }
    let Some(up) = body_up(x) else {
        return false;
    };
    let t = gap_s;
    let vertical: Matrix3<f32> = up * up.transpose();
    let rate_up = up.dot(gyro);
    let turn = exp_so3(&(up * (rate_up * t)));
    let mut next = *p;
    // F P F^T: row operations, then the same on columns. The new position
    // rows read the velocity rows and the new attitude rows the attitude,
    // bias and scale rows; none of those is changed by the other.
    let th_rows = next.fixed_rows::<3>(TH).into_owned();
    let bg_rows = next.fixed_rows::<3>(BG).into_owned();
    let k_row = next.row(KG).into_owned();
    let v_rows = next.fixed_rows::<3>(V).into_owned();
    let f_thk = if config.imu.estimate_gyro_scale {
        vertical * x.gyro_scale_jacobian(gyro) * t
    } else {
        Vec3::zeros()
    };
    let f_thbg = -vertical * t;
    next.fixed_rows_mut::<3>(P)
        .zip_apply(&v_rows, |a, b| *a += t * b);
    let th_new = turn.transpose() * th_rows + f_thbg * bg_rows + f_thk * k_row;
    next.fixed_rows_mut::<3>(TH).copy_from(&th_new);
    let th_cols = next.fixed_columns::<3>(TH).into_owned();
    let bg_cols = next.fixed_columns::<3>(BG).into_owned();
    let k_col = next.column(KG).into_owned();
    let v_cols = next.fixed_columns::<3>(V).into_owned();
    next.fixed_columns_mut::<3>(P)
        .zip_apply(&v_cols, |a, b| *a += t * b);
    let th_new = th_cols * turn + bg_cols * f_thbg.transpose() + k_col * f_thk.transpose();
    next.fixed_columns_mut::<3>(TH).copy_from(&th_new);
    let q = config.gap.accel_density * config.gap.accel_density;
    let imu = process_noise(&config.imu, &config.robot, t);
    for (i, q_imu) in imu.iter().enumerate() {
        if let Some(d) = next.get_mut((i, i)) {
            *d += q_imu;
        }
    }
    for axis in 0..3 {
        let (pi, vi) = (P + axis, V + axis);
        let add = [
            ((pi, pi), q * t * t * t / 3.0),
            ((pi, vi), q * t * t / 2.0),
            ((vi, pi), q * t * t / 2.0),
            ((vi, vi), q * t),
        ];
        for (ij, a) in add {
            if let Some(e) = next.get_mut(ij) {
                *e += a;
            }
        }
    }
    let missed = missed_turn(config, rate_up, t);
    let q_yaw = vertical * (missed * missed);
    next.fixed_view_mut::<3, 3>(TH, TH)
        .zip_apply(&q_yaw, |a, b| *a += b);
    symmetrize(&mut next);
    let p_wb = x.p_wb + x.v_wb * t;
    let q_wb = rotate_local(&x.q_wb, &(up * (rate_up * t)));
    let finite = next.iter().all(|v| v.is_finite())
        && p_wb.iter().all(|v| v.is_finite())
        && q_wb.coords.iter().all(|v| v.is_finite());
    if !finite {
        return false;
    }
    *p = next;
    x.p_wb = p_wb;
    x.q_wb = q_wb;
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RobotPrior;
    use crate::gap::test_support::{positive_definite, random_covariance};
    use crate::state::{DIM, Quat};

    fn state() -> NominalState {
        let r = RobotPrior::default();
        NominalState {
            p_wb: Vec3::new(1.0, -2.0, 0.06),
            v_wb: Vec3::new(0.2, 0.1, 0.0),
            q_wb: Quat::from_euler_angles(0.02, -0.03, 0.7),
            accel_bias: Vec3::zeros(),
            gyro_bias: Vec3::new(1e-3, -2e-3, 3e-3),
            gravity: Vec3::new(0.0, 0.0, -9.8),
            gyro_scale: 0.0,
            clone_p_wb: Vec3::zeros(),
            clone_q_wb: Quat::identity(),
            p_bl: r.p_bl,
            p_br: r.p_br,
            q_rb: Quat::identity(),
            radius_left: 0.035,
            radius_right: 0.035,
        }
    }

    fn covariance() -> Covariance {
        random_covariance(5)
    }

    fn heading(q: &Quat) -> f32 {
        q.euler_angles().2
    }

    #[test]
    fn the_heading_keeps_turning_at_the_held_rate_and_the_tilt_stays() {
        let c = FilterConfig::default();
        let mut x = state();
        let mut p = covariance();
        let x0 = x;
        // Turning at 0.8 rad/s with some roll rate (a bump): only the turn
        // about the vertical is held.
        let gyro = x.q_wb.inverse() * Vec3::new(0.3, 0.0, 0.8);
        assert!(bridge_gap(&mut x, &mut p, &c, &gyro, 0.024));
        let turned = heading(&x.q_wb) - heading(&x0.q_wb);
        assert!((turned - 0.8 * 0.024).abs() < 1e-4, "{turned}");
        let up = |q: &Quat| q.inverse() * Vec3::z();
        assert!((up(&x.q_wb) - up(&x0.q_wb)).amax() < 1e-5);
        assert!((x.p_wb - (x0.p_wb + x0.v_wb * 0.024)).amax() < 1e-6);
        assert_eq!(x.v_wb, x0.v_wb);
        assert!(positive_definite(&p));
    }

    #[test]
    fn the_heading_variance_grows_by_the_turn_the_held_rate_may_miss() {
        let c = FilterConfig::default();
        // Short: bounded by the rate's change; long: by the rates.
        assert!((missed_turn(&c, 0.8, 0.024) - 0.5 * 20.0 * 0.024 * 0.024).abs() < 1e-6);
        assert!((missed_turn(&c, 0.8, 1.0) - 2.8).abs() < 1e-5);
        for (gap, rate) in [(0.024f32, 0.8f32), (1.0, -0.8), (0.1, 0.0)] {
            let mut x = state();
            let mut p = Covariance::identity() * 1e-6;
            let gyro = x.q_wb.inverse() * Vec3::new(0.0, 0.0, rate);
            let up = x.q_wb.inverse() * Vec3::z();
            let yaw_var = |p: &Covariance| (up.transpose() * p.fixed_view::<3, 3>(TH, TH) * up).x;
            let before = yaw_var(&p);
            assert!(bridge_gap(&mut x, &mut p, &c, &gyro, gap));
            let missed = missed_turn(&c, rate, gap);
            let grown = yaw_var(&p) - before;
            // The missed turn, plus the gyro bias's uncertainty over the gap.
            let bias = 1e-6 * gap * gap;
            let expected = missed * missed + bias;
            assert!(
                (grown - expected).abs() < 1e-3 * expected + 1e-7,
                "gap {gap}: grew {grown}, expected {expected}"
            );
            assert!(positive_definite(&p));
        }
    }

    #[test]
    fn the_attitude_rows_follow_the_transition() {
        // A bias error turns the heading by -u u^T db T; the attitude
        // error rotates with the turn.
        let c = FilterConfig::default();
        let x = state();
        let mut p = Covariance::zeros();
        let (gap, rate) = (0.05f32, 0.8f32);
        p[(BG + 2, BG + 2)] = 1e-4;
        let gyro = x.q_wb.inverse() * Vec3::new(0.0, 0.0, rate);
        let mut xb = x;
        assert!(bridge_gap(&mut xb, &mut p, &c, &gyro, gap));
        let up = x.q_wb.inverse() * Vec3::z();
        let f_thbg = -(up * up.transpose()) * gap;
        let expected = f_thbg.column(2) * 1e-4;
        let got = p.fixed_view::<3, 1>(TH, BG + 2);
        assert!((got - expected).amax() < 1e-9, "{got:?} vs {expected:?}");
        assert_eq!(p.nrows(), DIM);
    }

    #[test]
    fn bad_input_changes_nothing() {
        let c = FilterConfig::default();
        let x0 = state();
        let p0 = covariance();
        let (mut x, mut p) = (x0, p0);
        let gyro = Vec3::new(0.0, 0.0, 0.5);
        for gap in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(!bridge_gap(&mut x, &mut p, &c, &gyro, gap));
        }
        let nan = Vec3::new(0.0, f32::NAN, 0.5);
        assert!(!bridge_gap(&mut x, &mut p, &c, &nan, 0.1));
        let mut no_gravity = x0;
        no_gravity.gravity = Vec3::zeros();
        assert!(!bridge_gap(&mut no_gravity, &mut p, &c, &gyro, 0.1));
        assert_eq!((x, p), (x0, p0));
    }
}
