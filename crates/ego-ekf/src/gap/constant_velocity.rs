//! Bridging an IMU gap at constant velocity: the fallback when the wheels did
//! not dead-reckon it (see [`crate::gap`]).
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
//! 2001, sec. 6.2.2), in the filter's error state:
//!
//! - nominal: `p <- p + v T`; velocity, attitude, biases and robot states kept;
//! - covariance: `P <- F P F^T + Q` with `F = I` except `dp/dv = I T`, and per
//!   axis `Q_pp = q T^3 / 3`, `Q_pv = q T^2 / 2`, `Q_vv = q T` for the
//!   unmeasured acceleration density `q = GapConfig::accel_density^2`; the
//!   yaw grows by `GapConfig::gyro_density^2 T` (the robot may have turned);
//!   and the IMU's own process noise over `T` (biases and robot states random
//!   walks, see [`crate::propagate::process_noise`]).
//!
//! `Q` is positive semi-definite and `F P F^T` keeps `P` positive definite, so
//! `P` stays symmetric positive definite. Nothing is written unless every
//! result is finite.

use crate::config::FilterConfig;
use crate::covariance::symmetrize;
use crate::propagate::process_noise;
use crate::state::{Covariance, NominalState, P, TH, V};

/// Bridges a gap of `gap_s` seconds; returns `false` (and changes nothing)
/// for a non-finite or non-positive gap or a non-finite result.
pub fn bridge_gap(
    x: &mut NominalState,
    p: &mut Covariance,
    config: &FilterConfig,
    gap_s: f32,
) -> bool {
    if !(gap_s.is_finite() && gap_s > 0.0) {
        return false;
    }
    let t = gap_s;
    let mut next = *p;
    // F P F^T for dp/dv = I t: row operation, then column operation.
    let v_rows = next.fixed_rows::<3>(V).into_owned();
    next.fixed_rows_mut::<3>(P)
        .zip_apply(&v_rows, |a, b| *a += t * b);
    let v_cols = next.fixed_columns::<3>(V).into_owned();
    next.fixed_columns_mut::<3>(P)
        .zip_apply(&v_cols, |a, b| *a += t * b);
    let q = config.gap.accel_density * config.gap.accel_density;
    let q_yaw = config.gap.gyro_density * config.gap.gyro_density;
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
    if let Some(e) = next.get_mut((TH + 2, TH + 2)) {
        *e += q_yaw * t;
    }
    symmetrize(&mut next);
    let p_wb = x.p_wb + x.v_wb * t;
    if !(next.iter().all(|v| v.is_finite()) && p_wb.iter().all(|v| v.is_finite())) {
        return false;
    }
    *p = next;
    x.p_wb = p_wb;
    true
}
