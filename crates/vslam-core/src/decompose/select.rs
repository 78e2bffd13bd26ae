//! Choosing the physical candidate: positive depth of the imaged points in
//! both cameras (Ma et al., *An Invitation to 3-D Vision*, sec. 5.3.3, "the
//! positive depth constraint"), then a prior on the plane normal.
//!
//! For a point with normalised ray `m` in camera 1 and candidate
//! `{R, t/d, n}`, the plane gives its depth `z1 = d / (n^T m)` and then
//! `X2 = R X1 + t`, so with `d = 1`: `z1 = 1 / (n^T m) > 0` and
//! `z2 = e3^T R m / (n^T m) + (t/d)_z > 0`. Both use only image-1 points.

use super::{HomographyDecomposition, PlaneMotion, SelectError};
use crate::geometry::{Extrinsics, Vec2, Vec3};

/// A prior on the plane normal in camera 1 (unit, pointing from the camera
/// towards the plane), with the largest angle a candidate may deviate by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalPrior {
    normal: Vec3,
    max_angle_rad: f32,
}

impl NormalPrior {
    /// Checked: `normal` finite and non-zero (it is normalised),
    /// `max_angle_rad` in `(0, pi]`.
    ///
    /// # Errors
    /// [`SelectError::InvalidParameter`].
    pub fn new(normal: &Vec3, max_angle_rad: f32) -> Result<Self, SelectError> {
        if !normal.iter().all(|v| v.is_finite())
            || !(max_angle_rad > 0.0)
            || !(max_angle_rad <= core::f32::consts::PI)
        {
            return Err(SelectError::InvalidParameter);
        }
        let normal = normal
            .try_normalize(f32::MIN_POSITIVE)
            .ok_or(SelectError::InvalidParameter)?;
        Ok(NormalPrior {
            normal,
            max_angle_rad,
        })
    }

    /// From a normal known in the body frame (e.g. the ceiling: `+z_B` for a
    /// robot on a level floor) and the camera mounting `T_BS`:
    /// `n_S = R_BS^T n_B`.
    ///
    /// # Errors
    /// [`SelectError::InvalidParameter`].
    pub fn from_body(
        extrinsics: &Extrinsics,
        normal_body: &Vec3,
        max_angle_rad: f32,
    ) -> Result<Self, SelectError> {
        NormalPrior::new(&extrinsics.vector_to_sensor(normal_body), max_angle_rad)
    }

    /// The unit normal, camera-1 frame.
    pub fn normal(&self) -> &Vec3 {
        &self.normal
    }

    /// The largest accepted angle, rad.
    pub fn max_angle_rad(&self) -> f32 {
        self.max_angle_rad
    }

    /// Angle between `n` and the prior, rad (`pi` for a zero `n`).
    pub fn angle_to(&self, n: &Vec3) -> f32 {
        let norm = n.norm();
        if !(norm > 0.0) {
            return core::f32::consts::PI;
        }
        let c = (self.normal.dot(n) / norm).clamp(-1.0, 1.0);
        libm::acosf(c)
    }
}

/// Settings of [`HomographyDecomposition::select`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectParams {
    /// A candidate passes the depth test if at least this fraction of the
    /// (finite, selected) points lies in front of both cameras; in `(0.5, 1]`.
    pub min_in_front_fraction: f32,
    /// The plane-normal prior, if known.
    pub prior: Option<NormalPrior>,
}

impl Default for SelectParams {
    /// 90 % of the points in front, no prior.
    fn default() -> Self {
        SelectParams {
            min_in_front_fraction: 0.9,
            prior: None,
        }
    }
}

/// The chosen candidate and the evidence for it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Selection {
    /// Index into [`HomographyDecomposition::candidates`].
    pub index: usize,
    /// Points in front of both cameras under the chosen candidate (for a
    /// pure rotation, where depth is undefined: all points).
    pub in_front: usize,
    /// Points considered (selected by the mask and finite).
    pub points: usize,
    /// Candidates that passed the depth test.
    pub passing: usize,
    /// Angle of the chosen normal to the prior, rad, if a prior was given.
    pub prior_angle_rad: Option<f32>,
}

/// Points (normalised rays `m`) in front of both cameras under `c`.
fn count_in_front<I: Iterator<Item = Vec3>>(c: &PlaneMotion, rays: I) -> usize {
    let r = c.rotation.matrix();
    let tz = c.translation_over_distance.z;
    rays.filter(|m| {
        let s = c.normal.dot(m);
        if !(s > 0.0) {
            return false;
        }
        let z2 = (r.row(2) * m).x / s + tz;
        z2 > 0.0
    })
    .count()
}

/// Whether two candidates are the same motion (the doubled solutions of the
/// special cases `s1 = 1` or `s3 = 1`).
fn same_motion(a: &PlaneMotion, b: &PlaneMotion) -> bool {
    let dr = (a.rotation.matrix() - b.rotation.matrix()).norm();
    let dn = (a.normal - b.normal).norm();
    let scale = a
        .translation_over_distance
        .norm()
        .max(b.translation_over_distance.norm())
        .max(1e-6);
    let dt = (a.translation_over_distance - b.translation_over_distance).norm() / scale;
    dr < 1e-3 && dn < 1e-3 && dt < 1e-3
}

impl HomographyDecomposition {
    /// Selects the physical candidate.
    ///
    /// `points1` are image-1 pixels (normalised coordinates after
    /// [`super::decompose_calibrated`]); `inliers` selects among them (empty:
    /// all). Non-finite points are skipped. Candidates pass if at least
    /// `min_in_front_fraction` of the points lie in front of both cameras
    /// (with no points, all pass). With a prior, the passing candidate whose
    /// normal is closest to it wins if within its angle; without one, a single
    /// passing candidate (or several equal ones) wins.
    ///
    /// A pure rotation has one candidate, which is selected.
    ///
    /// # Errors
    /// [`SelectError::LengthMismatch`], [`SelectError::InvalidParameter`],
    /// [`SelectError::NoneInFront`], [`SelectError::Ambiguous`],
    /// [`SelectError::PriorMismatch`].
    pub fn select(
        &self,
        points1: &[Vec2],
        inliers: &[bool],
        params: &SelectParams,
    ) -> Result<Selection, SelectError> {
        if !(inliers.is_empty() || inliers.len() == points1.len()) {
            return Err(SelectError::LengthMismatch);
        }
        let f = params.min_in_front_fraction;
        if !(f > 0.5 && f <= 1.0) {
            return Err(SelectError::InvalidParameter);
        }
        let k = self.intrinsics;
        let rays = || {
            points1
                .iter()
                .enumerate()
                .filter(move |(i, _)| inliers.is_empty() || inliers.get(*i).copied() == Some(true))
                .map(move |(_, p)| k.ray(p))
                .filter(|m| m.iter().all(|v| v.is_finite()))
        };
        let points = rays().count();
        let needed = libm::ceilf(f * points as f32) as usize;

        if self.pure_rotation {
            return Ok(Selection {
                index: 0,
                in_front: points,
                points,
                passing: 1,
                prior_angle_rad: None,
            });
        }

        // (index, in front, prior angle) of the passing candidates.
        let mut passing: heapless::Vec<(usize, usize, f32), 4> = heapless::Vec::new();
        for (index, c) in self.candidates.iter().enumerate() {
            let in_front = count_in_front(c, rays());
            if in_front >= needed && (points == 0 || in_front > 0) {
                let angle = params.prior.map(|p| p.angle_to(&c.normal)).unwrap_or(0.0);
                // Capacity 4 = candidates: cannot overflow.
                let _ = passing.push((index, in_front, angle));
            }
        }
        let Some(&first) = passing.first() else {
            return Err(SelectError::NoneInFront);
        };
        let chosen = match params.prior {
            Some(prior) => {
                let best = passing
                    .iter()
                    .copied()
                    .fold(first, |b, c| if c.2 < b.2 { c } else { b });
                if !(best.2 <= prior.max_angle_rad()) {
                    return Err(SelectError::PriorMismatch {
                        best_angle_rad: best.2,
                    });
                }
                best
            }
            None => {
                let reference = self.candidates.get(first.0);
                let all_same =
                    passing
                        .iter()
                        .all(|c| match (reference, self.candidates.get(c.0)) {
                            (Some(a), Some(b)) => same_motion(a, b),
                            _ => false,
                        });
                if !all_same {
                    return Err(SelectError::Ambiguous {
                        passing: passing.len(),
                    });
                }
                first
            }
        };
        Ok(Selection {
            index: chosen.0,
            in_front: chosen.1,
            points,
            passing: passing.len(),
            prior_angle_rad: params.prior.map(|_| chosen.2),
        })
    }

    /// The candidate a [`Selection`] chose.
    pub fn selected(&self, selection: &Selection) -> Option<&PlaneMotion> {
        self.candidates.get(selection.index)
    }
}
