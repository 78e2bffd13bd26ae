//! The error measure that judges recovery after a fault.
//!
//! **Recovery error** `e(T)`: the planar (x, y) distance between the EKF's
//! position and the true position at time `T`: the last EKF pose at or
//! before `T`, against the truth linearly interpolated at that pose's time
//! stamp. No alignment: the estimate starts from the true initial pose.
//!
//! **Criterion** (issue 8): with `T` = the end of the fault window plus
//! [`RECOVERY_S`] seconds, a run with the fault recovered when
//! `e_fault(T) <= RATIO * max(e_free(T), FLOOR_M)`, where `e_free` is the
//! fault-free run of the same scenario and seed. The floor keeps the
//! comparison away from millimetres: two runs both within 2 cm of the truth
//! are not told apart.

use crate::asl::GroundTruth;
use crate::tum::TumPose;

/// Seconds after the fault window at which recovery is judged.
pub const RECOVERY_S: f64 = 2.0;
/// Allowed ratio to the fault-free error.
pub const RATIO: f64 = 1.2;
/// Absolute floor of the compared error, metres.
pub const FLOOR_M: f64 = 0.02;

fn truth_at(truth: &[GroundTruth], t: u64) -> Option<[f64; 2]> {
    let i = truth.partition_point(|g| g.t.0 < t);
    let after = truth.get(i)?;
    if after.t.0 == t || i == 0 {
        return Some([after.p[0], after.p[1]]);
    }
    let before = truth.get(i - 1)?;
    let f = (t - before.t.0) as f64 / (after.t.0 - before.t.0) as f64;
    Some([0, 1].map(|k| before.p[k] + f * (after.p[k] - before.p[k])))
}

/// The recovery error `e(T)` of `est` at `t_ns` (module docs); `None`
/// without a pose at or before `t_ns` or without truth there.
pub fn error_at(est: &[TumPose], truth: &[GroundTruth], t_ns: u64) -> Option<f64> {
    let i = est.partition_point(|p| p.t.0 <= t_ns);
    let p = est.get(i.checked_sub(1)?)?;
    let g = truth_at(truth, p.t.0)?;
    Some(((p.p[0] - g[0]).powi(2) + (p.p[1] - g[1]).powi(2)).sqrt())
}

/// The judgement of one faulted run against the fault-free one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Recovery {
    /// When it is judged, ns (window end + [`RECOVERY_S`]).
    pub at_ns: u64,
    /// `e_fault(T)`, metres.
    pub faulted: f64,
    /// `e_free(T)`, metres.
    pub free: f64,
}

impl Recovery {
    /// Compares two EKF trajectories at `window_end_ns + RECOVERY_S`, each
    /// against its own truth (a motion fault changes the drive).
    pub fn judge(
        (faulted, faulted_truth): (&[TumPose], &[GroundTruth]),
        (free, free_truth): (&[TumPose], &[GroundTruth]),
        window_end_ns: u64,
    ) -> Option<Recovery> {
        let at_ns = window_end_ns + (RECOVERY_S * 1e9) as u64;
        Some(Recovery {
            at_ns,
            faulted: error_at(faulted, faulted_truth, at_ns)?,
            free: error_at(free, free_truth, at_ns)?,
        })
    }

    /// The bound `RATIO * max(e_free, FLOOR_M)`.
    pub fn bound(&self) -> f64 {
        RATIO * self.free.max(FLOOR_M)
    }

    /// Whether the faulted run recovered.
    pub fn recovered(&self) -> bool {
        self.faulted <= self.bound()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use traction::vslam_core::Timestamp;

    #[test]
    fn error_interpolates_the_truth_and_takes_the_last_pose() {
        let truth: Vec<GroundTruth> = (0..=10)
            .map(|i| GroundTruth {
                t: Timestamp(i * 100),
                p: [i as f64, 0.0, 0.0],
                q_wxyz: [1.0, 0.0, 0.0, 0.0],
                v: [0.0; 3],
                bias_gyro: [0.0; 3],
                bias_accel: [0.0; 3],
            })
            .collect();
        let pose = |t: u64, x: f64, y: f64| TumPose {
            t: Timestamp(t),
            p: [x, y, 0.0],
            q_xyzw: [0.0, 0.0, 0.0, 1.0],
        };
        let est = vec![pose(150, 1.5, 0.3), pose(250, 2.5, 0.4)];
        assert_eq!(error_at(&est, &truth, 200), Some(0.3));
        assert_eq!(error_at(&est, &truth, 100), None);
        let r = Recovery {
            at_ns: 0,
            faulted: 0.023,
            free: 0.005,
        };
        assert!(r.recovered(), "both under the floor");
        let r = Recovery {
            at_ns: 0,
            faulted: 0.13,
            free: 0.1,
        };
        assert!(!r.recovered());
    }
}
