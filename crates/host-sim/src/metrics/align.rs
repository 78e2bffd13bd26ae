//! Rigid planar alignments of an estimated trajectory onto the truth, the
//! two that `evo` (Grupp, "evo: Python package for the evaluation of
//! odometry and SLAM", 2017) offers in 3-D as `--align_origin` and
//! `--align`:
//!
//! - [`first_pose`]: the transform that puts the estimate's first pose on
//!   the truth's (what a robot that starts from a known pose sees);
//! - [`best_fit`]: the rotation and translation (no scale) that minimise
//!   the sum of squared planar position errors, in closed form: Umeyama,
//!   "Least-squares estimation of transformation parameters between two
//!   point patterns", IEEE PAMI 13(4), 1991, in two dimensions, where the
//!   SVD of the 2x2 cross-covariance reduces to one `atan2` (Horn, "Closed-
//!   form solution of absolute orientation using unit quaternions", JOSA A
//!   4(4), 1987, sec. 2, the planar case).

/// A rigid planar transform: `p -> R(theta) p + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se2 {
    /// Rotation angle, radians.
    pub theta: f64,
    /// Translation, metres.
    pub t: [f64; 2],
}

impl Se2 {
    /// The identity.
    pub const IDENTITY: Se2 = Se2 {
        theta: 0.0,
        t: [0.0, 0.0],
    };

    /// The transform applied to a point.
    pub fn apply(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.theta.sin_cos();
        [c * x - s * y + self.t[0], s * x + c * y + self.t[1]]
    }
}

/// The transform that takes the estimate's first pose (`est`: x, y, yaw)
/// onto the truth's (`truth`).
pub fn first_pose(est: [f64; 3], truth: [f64; 3]) -> Se2 {
    let theta = truth[2] - est[2];
    let (s, c) = theta.sin_cos();
    Se2 {
        theta,
        t: [
            truth[0] - (c * est[0] - s * est[1]),
            truth[1] - (s * est[0] + c * est[1]),
        ],
    }
}

/// The rigid transform (rotation and translation, no scale) that takes the
/// points `est` closest to the matching points `truth` in the least-squares
/// sense; `None` for no points or slices of different lengths. With the
/// centred points `e_i`, `g_i`, the rotation maximises
/// `sum g_i . R e_i`: `theta = atan2(sum e_i x g_i, sum e_i . g_i)`; then
/// `t = mean(g) - R mean(e)`. Points all at one place give `theta = 0`.
pub fn best_fit(est: &[[f64; 2]], truth: &[[f64; 2]]) -> Option<Se2> {
    if est.is_empty() || est.len() != truth.len() {
        return None;
    }
    let n = est.len() as f64;
    let mean = |v: &[[f64; 2]]| {
        let s = v.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]]);
        [s[0] / n, s[1] / n]
    };
    let (me, mg) = (mean(est), mean(truth));
    let (mut dot, mut cross) = (0.0, 0.0);
    for (e, g) in est.iter().zip(truth) {
        let (ex, ey) = (e[0] - me[0], e[1] - me[1]);
        let (gx, gy) = (g[0] - mg[0], g[1] - mg[1]);
        dot += ex * gx + ey * gy;
        cross += ex * gy - ey * gx;
    }
    let theta = cross.atan2(dot);
    let r = Se2 { theta, t: [0.0; 2] }.apply(me);
    Some(Se2 {
        theta,
        t: [mg[0] - r[0], mg[1] - r[1]],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rmse(a: &Se2, est: &[[f64; 2]], truth: &[[f64; 2]]) -> f64 {
        let s: f64 = est
            .iter()
            .zip(truth)
            .map(|(e, g)| {
                let p = a.apply(*e);
                (p[0] - g[0]).powi(2) + (p[1] - g[1]).powi(2)
            })
            .sum();
        (s / est.len() as f64).sqrt()
    }

    #[test]
    fn a_hand_computed_fit() {
        // Truth (-1, 0), (1, 0), (0, 0); the estimate's third point is 0.3 m
        // off in y. Centred: e = (-1, -0.1), (1, -0.1), (0, 0.2), g = the
        // truth; sum e x g = -0.1 + 0.1 + 0 = 0, so no rotation, and the
        // translation is the centroids' difference (0, -0.1). Residuals
        // (0, -0.1), (0, -0.1), (0, 0.2): RMSE sqrt(0.06 / 3).
        let truth = [[-1.0, 0.0], [1.0, 0.0], [0.0, 0.0]];
        let est = [[-1.0, 0.0], [1.0, 0.0], [0.0, 0.3]];
        let a = best_fit(&est, &truth).unwrap();
        assert!(a.theta.abs() < 1e-12, "{a:?}");
        assert!(
            a.t[0].abs() < 1e-12 && (a.t[1] + 0.1).abs() < 1e-12,
            "{a:?}"
        );
        assert!((rmse(&a, &est, &truth) - 0.02f64.sqrt()).abs() < 1e-12);
        // First-pose alignment leaves the estimate as it is: 0.3 m at one
        // of three points.
        let f = first_pose([-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]);
        assert!((rmse(&f, &est, &truth) - 0.03f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn a_rigidly_moved_trajectory_fits_exactly() {
        let truth: Vec<[f64; 2]> = (0..50)
            .map(|i| {
                let s = i as f64 * 0.1;
                [s, 0.5 * (0.7 * s).sin()]
            })
            .collect();
        let moved = Se2 {
            theta: 2.5,
            t: [3.0, -1.5],
        };
        let est: Vec<[f64; 2]> = truth.iter().map(|p| moved.apply(*p)).collect();
        let a = best_fit(&est, &truth).unwrap();
        assert!(rmse(&a, &est, &truth) < 1e-12, "{a:?}");
        assert!((a.theta + 2.5).abs() < 1e-12);
        // The first pose, with its heading moved alike, fits it as well.
        let f = first_pose([est[0][0], est[0][1], 2.5], [truth[0][0], truth[0][1], 0.0]);
        assert!(rmse(&f, &est, &truth) < 1e-12, "{f:?}");
    }

    #[test]
    fn no_nearby_transform_fits_better() {
        // A drifting estimate: the best fit is a minimum of the error.
        let truth: Vec<[f64; 2]> = (0..40)
            .map(|i| [i as f64 * 0.1, (i as f64 * 0.2).cos()])
            .collect();
        let est: Vec<[f64; 2]> = truth
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let d = i as f64 * 0.004;
                [p[0] + d, p[1] - 0.5 * d + 0.01 * (i as f64).sin()]
            })
            .collect();
        let a = best_fit(&est, &truth).unwrap();
        let best = rmse(&a, &est, &truth);
        for (dth, dx, dy) in [
            (1e-3, 0.0, 0.0),
            (-1e-3, 0.0, 0.0),
            (0.0, 1e-3, 0.0),
            (0.0, -1e-3, 0.0),
            (0.0, 0.0, 1e-3),
            (0.0, 0.0, -1e-3),
        ] {
            let b = Se2 {
                theta: a.theta + dth,
                t: [a.t[0] + dx, a.t[1] + dy],
            };
            assert!(rmse(&b, &est, &truth) > best, "{dth} {dx} {dy}");
        }
        assert!(best < rmse(&Se2::IDENTITY, &est, &truth));
    }

    #[test]
    fn refuses_what_cannot_be_fitted() {
        assert!(best_fit(&[], &[]).is_none());
        assert!(best_fit(&[[0.0, 0.0]], &[]).is_none());
    }
}
