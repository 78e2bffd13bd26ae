//! Trajectory error against ground truth: absolute trajectory error (RMSE of
//! the position difference at matching time stamps, no alignment: every
//! estimate starts from the true initial pose) and the final position error,
//! both also relative to the true path length.

use crate::tum::TumPose;

/// Errors of one trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryError {
    /// RMSE of the planar position error, metres.
    pub ate_rmse: f64,
    /// Planar position error at the last matched pose, metres.
    pub final_error: f64,
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

/// Truth as `(t_ns, [x, y, z])`, sorted by time.
pub type Truth = [(u64, [f64; 3])];

fn truth_at(truth: &Truth, t: u64) -> Option<[f64; 3]> {
    let i = truth.partition_point(|(tt, _)| *tt < t);
    let after = truth.get(i)?;
    if after.0 == t || i == 0 {
        return (after.0.abs_diff(t) <= 20_000_000).then_some(after.1);
    }
    let before = truth.get(i - 1)?;
    let f = (t - before.0) as f64 / (after.0 - before.0) as f64;
    Some([0, 1, 2].map(|k| before.1[k] + f * (after.1[k] - before.1[k])))
}

/// Compares `est` with `truth` at the estimate's time stamps.
pub fn trajectory_error(est: &[TumPose], truth: &Truth) -> Option<TrajectoryError> {
    let mut sq = 0.0;
    let mut n = 0usize;
    let mut last = None;
    let mut first_t = None;
    for p in est {
        let Some(g) = truth_at(truth, p.t.0) else {
            continue;
        };
        let e = ((p.p[0] - g[0]).powi(2) + (p.p[1] - g[1]).powi(2)).sqrt();
        sq += e * e;
        n += 1;
        last = Some((p.t.0, e));
        first_t.get_or_insert(p.t.0);
    }
    let (t_end, final_error) = last?;
    let t0 = first_t?;
    let path_length = truth
        .windows(2)
        .filter(|w| w[0].0 >= t0 && w[1].0 <= t_end)
        .map(|w| ((w[1].1[0] - w[0].1[0]).powi(2) + (w[1].1[1] - w[0].1[1]).powi(2)).sqrt())
        .sum();
    Some(TrajectoryError {
        ate_rmse: (sq / n as f64).sqrt(),
        final_error,
        path_length,
        matched: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use vslam_core::Timestamp;

    #[test]
    fn errors_of_a_shifted_trajectory() {
        let truth: Vec<(u64, [f64; 3])> = (0..=100)
            .map(|i| (i * 10_000_000, [i as f64 * 0.01, 0.0, 0.0]))
            .collect();
        let est: Vec<TumPose> = (0..=20)
            .map(|i| TumPose {
                t: Timestamp(i * 50_000_000 + 5_000_000),
                p: [i as f64 * 0.05 + 0.005, 0.03, 0.0],
                q_xyzw: [0.0, 0.0, 0.0, 1.0],
            })
            .collect();
        let e = trajectory_error(&est, &truth).unwrap();
        assert!((e.ate_rmse - 0.03).abs() < 1e-9, "{e:?}");
        assert!((e.final_error - 0.03).abs() < 1e-9);
        assert_eq!(e.matched, 20); // the last estimate is past the truth's end
        assert!((e.path_length - 0.95).abs() < 0.011, "{}", e.path_length);
    }
}
