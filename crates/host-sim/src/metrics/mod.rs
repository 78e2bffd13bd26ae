//! Trajectory errors against ground truth, as `evo_ape` measures them
//! (Grupp 2017; the README gives the commands): both trajectories are poses
//! of the body frame B, matched at the estimate's time stamps (the truth
//! interpolated between its poses, at most 20 ms beyond its ends).
//!
//! Per trajectory: the planar (x, y) absolute trajectory error, RMSE, after
//! first-pose alignment and after a best-fit SE(2) alignment
//! ([`align`]); and after first-pose alignment, the final planar error,
//! the largest height error (heights relative to the first pose's) and the
//! yaw RMSE.

pub mod align;

use crate::plot::track::{wrap, yaw_of};
use crate::tum::TumPose;
use align::{Se2, best_fit, first_pose};

/// The header line that says how [`TrajectoryError`]'s figures are aligned.
pub const ALIGNMENT: &str = "errors of the body frame's poses against the truth: planar ATE \
     (RMSE) after first-pose and after best-fit SE(2) alignment; final, height and yaw errors \
     after first-pose alignment";

/// Errors of one trajectory; see the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryError {
    /// RMSE of the planar position error after first-pose alignment, metres.
    pub ate_rmse: f64,
    /// RMSE of the planar position error after the best-fit SE(2)
    /// alignment, metres.
    pub ate_se2_rmse: f64,
    /// Planar position error at the last matched pose (first-pose
    /// alignment), metres.
    pub final_error: f64,
    /// Largest height error (first-pose alignment), metres.
    pub max_height_error: f64,
    /// RMSE of the yaw error (first-pose alignment), degrees.
    pub yaw_rmse_deg: f64,
    /// Yaw error at the last matched pose (first-pose alignment), degrees.
    pub final_yaw_error_deg: f64,
    /// Length of the true path over the matched span, metres.
    pub path_length: f64,
    /// Poses matched to the truth.
    pub matched: usize,
}

impl TrajectoryError {
    /// Final error as a fraction of the path length.
    pub fn final_relative(&self) -> f64 {
        if self.path_length > 0.0 {
            self.final_error / self.path_length
        } else {
            f64::NAN
        }
    }
}

/// What the errors need of a pose: position and yaw.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pose {
    p: [f64; 3],
    yaw: f64,
}

impl Pose {
    fn of(p: &TumPose) -> Pose {
        let [x, y, z, w] = p.q_xyzw;
        Pose {
            p: p.p,
            yaw: yaw_of(w, x, y, z),
        }
    }

    fn xy(&self) -> [f64; 2] {
        [self.p[0], self.p[1]]
    }

    fn planar(&self) -> [f64; 3] {
        [self.p[0], self.p[1], self.yaw]
    }
}

/// The truth (sorted by time) at `t`, interpolated linearly (yaw the short
/// way round); `None` outside its span by more than 20 ms.
fn truth_at(truth: &[TumPose], t: u64) -> Option<Pose> {
    let i = truth.partition_point(|g| g.t.0 < t);
    let after = truth.get(i)?;
    if after.t.0 == t || i == 0 {
        return (after.t.0.abs_diff(t) <= 20_000_000).then(|| Pose::of(after));
    }
    let (b, a) = (Pose::of(truth.get(i - 1)?), Pose::of(after));
    let t0 = truth.get(i - 1)?.t.0;
    let f = (t - t0) as f64 / (after.t.0 - t0) as f64;
    Some(Pose {
        p: [0, 1, 2].map(|k| b.p[k] + f * (a.p[k] - b.p[k])),
        yaw: b.yaw + f * wrap(a.yaw - b.yaw),
    })
}

fn planar_error(a: &Se2, e: &Pose, g: &Pose) -> f64 {
    let p = a.apply(e.xy());
    (p[0] - g.p[0]).hypot(p[1] - g.p[1])
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n as f64).sqrt()
}

/// Compares `est` with `truth` (both sorted by time) at the estimate's time
/// stamps; `None` when no pose matches.
pub fn trajectory_error(est: &[TumPose], truth: &[TumPose]) -> Option<TrajectoryError> {
    let pairs: Vec<(u64, Pose, Pose)> = est
        .iter()
        .filter_map(|e| Some((e.t.0, Pose::of(e), truth_at(truth, e.t.0)?)))
        .collect();
    let (t0, e0, g0) = *pairs.first()?;
    let (t_end, e_end, g_end) = *pairs.last()?;
    let first = first_pose(e0.planar(), g0.planar());
    let xy = |k: fn(&(u64, Pose, Pose)) -> &Pose| pairs.iter().map(k).map(Pose::xy).collect();
    let (est_xy, truth_xy): (Vec<[f64; 2]>, Vec<[f64; 2]>) = (xy(|p| &p.1), xy(|p| &p.2));
    let fit = best_fit(&est_xy, &truth_xy)?;
    let dz = |e: &Pose, g: &Pose| (e.p[2] - e0.p[2]) - (g.p[2] - g0.p[2]);
    let path_length = truth
        .windows(2)
        .filter(|w| w[0].t.0 >= t0 && w[1].t.0 <= t_end)
        .map(|w| (w[1].p[0] - w[0].p[0]).hypot(w[1].p[1] - w[0].p[1]))
        .sum();
    Some(TrajectoryError {
        ate_rmse: rms(pairs.iter().map(|(_, e, g)| planar_error(&first, e, g))),
        ate_se2_rmse: rms(pairs.iter().map(|(_, e, g)| planar_error(&fit, e, g))),
        final_error: planar_error(&first, &e_end, &g_end),
        max_height_error: pairs
            .iter()
            .map(|(_, e, g)| dz(e, g).abs())
            .fold(0.0, f64::max),
        yaw_rmse_deg: rms(pairs
            .iter()
            .map(|(_, e, g)| wrap(e.yaw + first.theta - g.yaw).to_degrees())),
        final_yaw_error_deg: wrap(e_end.yaw + first.theta - g_end.yaw).to_degrees(),
        path_length,
        matched: pairs.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use vslam_core::Timestamp;

    fn pose(t_ns: u64, p: [f64; 3], yaw: f64) -> TumPose {
        let (s, c) = (0.5 * yaw).sin_cos();
        TumPose {
            t: Timestamp(t_ns),
            p,
            q_xyzw: [0.0, 0.0, s, c],
        }
    }

    #[test]
    fn errors_of_a_shifted_trajectory() {
        // Truth along x at 1 m/s, 10 ms apart; the estimate, 5 ms off the
        // truth's time stamps, is 3 cm to the left but at its first and last
        // matched poses.
        let truth: Vec<TumPose> = (0..=100)
            .map(|i| pose(i * 10_000_000, [i as f64 * 0.01, 0.0, 0.0], 0.0))
            .collect();
        let est: Vec<TumPose> = (0..=20)
            .map(|i| {
                let y = if i == 0 || i == 19 { 0.0 } else { 0.03 };
                pose(
                    i * 50_000_000 + 5_000_000,
                    [i as f64 * 0.05 + 0.005, y, 0.0],
                    0.0,
                )
            })
            .collect();
        let e = trajectory_error(&est, &truth).unwrap();
        assert_eq!(e.matched, 20); // the last estimate is past the truth's end
        // 18 of 20 matched poses 3 cm off after first-pose alignment.
        assert!(
            (e.ate_rmse - 0.03 * (18.0f64 / 20.0).sqrt()).abs() < 1e-9,
            "{e:?}"
        );
        assert!(e.final_error.abs() < 1e-9);
        // The offsets are symmetric along the path, so the best fit does not
        // turn: it shifts by their mean, 0.027 m, leaving 0.027 m twice and
        // 0.003 m eighteen times.
        let se2 = ((2.0 * 0.027f64.powi(2) + 18.0 * 0.003f64.powi(2)) / 20.0).sqrt();
        assert!((e.ate_se2_rmse - se2).abs() < 1e-9, "{e:?} {se2}");
        assert!((e.path_length - 0.95).abs() < 0.011, "{}", e.path_length);
        assert_eq!(e.max_height_error, 0.0);
        assert_eq!(e.yaw_rmse_deg, 0.0);
    }

    #[test]
    fn a_rigidly_moved_estimate_has_no_error_after_either_alignment() {
        // The estimate runs in a world turned by 1 rad, shifted and lifted:
        // both alignments remove that, the height is relative to the first pose.
        let truth: Vec<TumPose> = (0..200)
            .map(|i| {
                let s = i as f64 * 0.02;
                pose(
                    i * 4_000_000,
                    [s, (0.8 * s).sin(), 0.0],
                    0.8 * (0.8 * s).cos(),
                )
            })
            .collect();
        let (s, c) = 1.0f64.sin_cos();
        let est: Vec<TumPose> = truth
            .iter()
            .map(|g| {
                let [x, y, _] = g.p;
                let [_, _, qz, qw] = g.q_xyzw;
                let yaw = 2.0 * qz.atan2(qw);
                pose(
                    g.t.0,
                    [c * x - s * y + 2.0, s * x + c * y - 1.0, 0.3],
                    yaw + 1.0,
                )
            })
            .collect();
        let e = trajectory_error(&est, &truth).unwrap();
        assert!(e.ate_rmse < 1e-9, "{e:?}");
        assert!(e.ate_se2_rmse < 1e-9, "{e:?}");
        assert!(e.final_error < 1e-9 && e.max_height_error < 1e-9, "{e:?}");
        assert!(e.yaw_rmse_deg < 1e-6, "{e:?}");
    }

    #[test]
    fn height_and_yaw_errors() {
        // The estimate climbs 2 cm by its end, turns 1 degree the wrong way
        // over half its poses and ends 4 cm ahead.
        let truth: Vec<TumPose> = (0..10)
            .map(|i| pose(i * 10_000_000, [i as f64 * 0.1, 0.0, 0.0], 0.0))
            .collect();
        let est: Vec<TumPose> = (0..10)
            .map(|i| {
                let yaw = if i >= 5 { 1f64.to_radians() } else { 0.0 };
                let ahead = if i == 9 { 0.04 } else { 0.0 };
                pose(
                    i * 10_000_000,
                    [i as f64 * 0.1 + ahead, 0.0, 0.5 + i as f64 * 0.02 / 9.0],
                    yaw,
                )
            })
            .collect();
        let e = trajectory_error(&est, &truth).unwrap();
        assert!((e.max_height_error - 0.02).abs() < 1e-12, "{e:?}");
        assert!((e.yaw_rmse_deg - 0.5f64.sqrt()).abs() < 1e-9, "{e:?}");
        assert!((e.final_error - 0.04).abs() < 1e-12, "{e:?}");
        assert!((e.ate_rmse - 0.04 / 10f64.sqrt()).abs() < 1e-12, "{e:?}");
    }

    #[test]
    fn nothing_matched_is_no_error() {
        let truth = [pose(0, [0.0; 3], 0.0)];
        assert!(trajectory_error(&[pose(1_000_000_000, [0.0; 3], 0.0)], &truth).is_none());
        assert!(trajectory_error(&[], &truth).is_none());
    }
}
