//! The trajectories a plot draws, as time-stamped planar poses, and their
//! errors against the truth at the estimate's time stamps (the truth
//! interpolated linearly, no alignment: every estimate starts from the true
//! initial pose, as in [`crate::metrics`]).

use crate::asl::GroundTruth;
use crate::tum::TumPose;
use traction::vslam_core::Timestamp;

/// A planar pose: time (seconds), position (metres), yaw (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Planar {
    /// Seconds from the log's zero.
    pub t: f64,
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading about z, radians.
    pub yaw: f64,
}

impl Planar {
    fn finite(&self) -> bool {
        self.t.is_finite() && self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite()
    }
}

/// Yaw of a Hamilton quaternion `w, x, y, z`.
pub fn yaw_of(w: f64, x: f64, y: f64, z: f64) -> f64 {
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// The planar pose at `t` of position `p` and attitude `w, x, y, z`.
fn planar(t: Timestamp, p: &[f64; 3], [w, x, y, z]: [f64; 4]) -> Planar {
    Planar {
        t: t.0 as f64 * 1e-9,
        x: p[0],
        y: p[1],
        yaw: yaw_of(w, x, y, z),
    }
}

/// An estimate's poses (finite ones only).
pub fn from_tum(v: &[TumPose]) -> Vec<Planar> {
    v.iter()
        .map(|e| {
            let [x, y, z, w] = e.q_xyzw;
            planar(e.t, &e.p, [w, x, y, z])
        })
        .filter(Planar::finite)
        .collect()
}

/// The truth's poses (finite ones only).
pub fn from_truth(v: &[GroundTruth]) -> Vec<Planar> {
    v.iter()
        .map(|g| planar(g.t, &g.p, g.q_wxyz))
        .filter(Planar::finite)
        .collect()
}

/// Wraps an angle to `(-pi, pi]`.
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(std::f64::consts::TAU);
    if w > std::f64::consts::PI {
        w - std::f64::consts::TAU
    } else {
        w
    }
}

/// The pose of `path` (sorted by time) at `t`, interpolated; `None` outside
/// its span (more than 20 ms from its ends).
pub fn at(path: &[Planar], t: f64) -> Option<Planar> {
    let i = path.partition_point(|p| p.t < t);
    let after = path.get(i);
    let before = i.checked_sub(1).and_then(|j| path.get(j));
    match (before, after) {
        (Some(b), Some(a)) if a.t > b.t => {
            let f = (t - b.t) / (a.t - b.t);
            Some(Planar {
                t,
                x: b.x + f * (a.x - b.x),
                y: b.y + f * (a.y - b.y),
                yaw: b.yaw + f * wrap(a.yaw - b.yaw),
            })
        }
        (_, Some(a)) if (a.t - t).abs() <= 0.02 => Some(*a),
        (Some(b), _) if (t - b.t).abs() <= 0.02 => Some(*b),
        _ => None,
    }
}

/// One error sample: time, planar position error (m), yaw error (deg).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSample {
    /// Seconds.
    pub t: f64,
    /// Planar position error, metres.
    pub position: f64,
    /// Signed yaw error (estimate minus truth), degrees, in `(-180, 180]`.
    pub yaw_deg: f64,
}

/// Errors of `est` against `truth` at the estimate's time stamps.
pub fn errors(est: &[Planar], truth: &[Planar]) -> Vec<ErrorSample> {
    est.iter()
        .filter_map(|p| {
            let g = at(truth, p.t)?;
            Some(ErrorSample {
                t: p.t,
                position: (p.x - g.x).hypot(p.y - g.y),
                yaw_deg: wrap(p.yaw - g.yaw).to_degrees(),
            })
        })
        .collect()
}

/// Largest planar error of `est` against `truth`, metres (`None` when no
/// pose matches).
pub fn max_error(est: &[Planar], truth: &[Planar]) -> Option<f64> {
    errors(est, truth)
        .iter()
        .map(|e| e.position)
        .fold(None, |m, e| Some(m.map_or(e, |m: f64| m.max(e))))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(t: f64, x: f64, yaw: f64) -> Planar {
        Planar { t, x, y: 0.0, yaw }
    }

    #[test]
    fn interpolates_across_the_yaw_wrap_and_refuses_outside_the_span() {
        let path = [p(0.0, 0.0, 3.1), p(1.0, 1.0, -3.1)];
        let m = at(&path, 0.5).unwrap();
        assert!((m.x - 0.5).abs() < 1e-12);
        assert!(
            (wrap(m.yaw) - std::f64::consts::PI).abs() < 0.01,
            "{}",
            m.yaw
        );
        assert!(at(&path, 1.01).is_some());
        assert!(at(&path, 1.5).is_none());
        assert!(at(&path, -0.5).is_none());
        assert!(at(&[], 0.0).is_none());
    }

    #[test]
    fn errors_are_planar_and_yaw_is_signed_in_degrees() {
        let truth = [p(0.0, 0.0, 0.0), p(2.0, 2.0, 0.0)];
        let est = [
            Planar {
                t: 1.0,
                x: 1.0,
                y: 0.3,
                yaw: -0.1,
            },
            p(5.0, 0.0, 0.0),
        ];
        let e = errors(&est, &truth);
        assert_eq!(e.len(), 1, "the pose past the truth's end is not compared");
        assert!((e[0].position - 0.3).abs() < 1e-12);
        assert!((e[0].yaw_deg + 0.1f64.to_degrees()).abs() < 1e-9);
        assert_eq!(max_error(&est, &truth), Some(e[0].position));
        assert_eq!(max_error(&[], &truth), None);
    }

    #[test]
    fn yaw_of_a_quarter_turn() {
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((yaw_of(h, 0.0, 0.0, h) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
