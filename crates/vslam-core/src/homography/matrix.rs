//! The [`Homography`] type: a checked, scale- and sign-normalised 3x3 matrix.

use super::HomographyError;
use crate::geometry::{Mat3, Vec2, Vec3};

/// Below this `|det H|` (with `||H||_F = 1`) a matrix is treated as singular.
///
/// The estimators check conditioning much more tightly, in normalised
/// coordinates; this guard only keeps numerically singular matrices out.
const MIN_UNIT_DET: f32 = 1e-15;

/// A homography `x2 ~ H x1` from image-1 pixels to image-2 pixels.
///
/// Invariants (checked on construction): every entry finite, `||H||_F = 1`,
/// `det H > 0`. See the [module docs](super) for the sign convention.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homography {
    h: Mat3,
}

impl Homography {
    /// The identity map.
    pub fn identity() -> Self {
        Homography {
            h: Mat3::identity() / libm::sqrtf(3.0),
        }
    }

    /// From any non-zero multiple of a homography: rescales to unit Frobenius
    /// norm and flips the sign so that `det H > 0`.
    ///
    /// # Errors
    /// [`HomographyError::NonFinite`] (index 0) for a NaN or infinite entry,
    /// [`HomographyError::NearSingular`] for a numerically singular matrix.
    pub fn from_matrix(m: &Mat3) -> Result<Self, HomographyError> {
        if !m.iter().all(|v| v.is_finite()) {
            return Err(HomographyError::NonFinite { index: 0 });
        }
        // Pre-scale by the largest entry so the norm cannot overflow.
        let max = m.amax();
        if !(max > 0.0) || !max.is_finite() {
            return Err(HomographyError::NearSingular);
        }
        let scaled = m / max;
        let norm = scaled.norm();
        if !(norm > 0.0) || !norm.is_finite() {
            return Err(HomographyError::NearSingular);
        }
        let unit = scaled / norm;
        let det = unit.determinant();
        if !(libm::fabsf(det) >= MIN_UNIT_DET) {
            return Err(HomographyError::NearSingular);
        }
        let h = if det < 0.0 { -unit } else { unit };
        if !h.iter().all(|v| v.is_finite()) {
            return Err(HomographyError::NonFinite { index: 0 });
        }
        Ok(Homography { h })
    }

    /// From nine entries in row-major order (`h00 h01 h02 h10 ... h22`).
    ///
    /// # Errors
    /// As [`Homography::from_matrix`].
    pub fn from_row_major(data: &[f32; 9]) -> Result<Self, HomographyError> {
        let [a, b, c, d, e, f, g, h, i] = *data;
        Homography::from_matrix(&Mat3::new(a, b, c, d, e, f, g, h, i))
    }

    /// The normalised matrix (`||H||_F = 1`, `det H > 0`).
    pub fn matrix(&self) -> &Mat3 {
        &self.h
    }

    /// The nine entries in row-major order.
    pub fn to_row_major(&self) -> [f32; 9] {
        let m = &self.h;
        [
            m.m11, m.m12, m.m13, m.m21, m.m22, m.m23, m.m31, m.m32, m.m33,
        ]
    }

    /// The inverse map (image 2 to image 1), normalised the same way.
    pub fn inverse(&self) -> Option<Homography> {
        let inv = self.h.try_inverse()?;
        Homography::from_matrix(&inv).ok()
    }

    /// Maps an image-1 pixel to image 2; `None` if it maps to the line at
    /// infinity (or beyond `f32`'s range), or the coordinates are not finite.
    pub fn transfer(&self, p1: &Vec2) -> Option<Vec2> {
        transfer(&self.h, p1)
    }

    /// Squared one-sided transfer error `||x2 - H x1||^2` in image-2 pixels;
    /// `f32::INFINITY` if `x1` maps to infinity.
    pub fn transfer_error_sq(&self, p1: &Vec2, p2: &Vec2) -> f32 {
        match self.transfer(p1) {
            Some(q) => (q - p2).norm_squared(),
            None => f32::INFINITY,
        }
    }
}

/// `H x1` in inhomogeneous coordinates, `None` at infinity (`w = 0`, or a
/// result too large for `f32`).
pub(crate) fn transfer(h: &Mat3, p1: &Vec2) -> Option<Vec2> {
    let y = h * Vec3::new(p1.x, p1.y, 1.0);
    if y.z == 0.0 {
        return None;
    }
    let q = Vec2::new(y.x / y.z, y.y / y.z);
    if q.x.is_finite() && q.y.is_finite() {
        Some(q)
    } else {
        None
    }
}
