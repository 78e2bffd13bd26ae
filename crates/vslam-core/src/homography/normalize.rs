//! Hartley normalisation: translate the points so their centroid is the
//! origin, and scale them so their mean distance from it is `sqrt(2)`.
//!
//! R. Hartley, "In defense of the eight-point algorithm", IEEE TPAMI 19(6),
//! 1997; Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., sec. 4.4.4.
//! Without it the DLT's design matrix mixes entries of order 1 and of order
//! `u^2 ~ 10^5` px^2 and loses most of `f32`'s digits.

use super::HomographyError;
use crate::geometry::{Mat3, Vec2};

/// A similarity `T`: `x_n = T x = s (x - c)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalization {
    centroid: Vec2,
    scale: f32,
}

impl Normalization {
    /// The identity (no change).
    pub fn identity() -> Self {
        Normalization {
            centroid: Vec2::zeros(),
            scale: 1.0,
        }
    }

    /// The normalisation of a set of points.
    ///
    /// # Errors
    /// [`HomographyError::TooFewPoints`] for an empty set,
    /// [`HomographyError::NonFinite`] for a NaN or infinite point (or sums
    /// that overflow), [`HomographyError::Degenerate`] if all points coincide.
    pub fn from_points<'a, I>(points: I) -> Result<Self, HomographyError>
    where
        I: IntoIterator<Item = &'a Vec2>,
        I::IntoIter: Clone,
    {
        let iter = points.into_iter();
        let mut count = 0usize;
        let mut sum = Vec2::zeros();
        for (index, p) in iter.clone().enumerate() {
            if !(p.x.is_finite() && p.y.is_finite()) {
                return Err(HomographyError::NonFinite { index });
            }
            sum += p;
            count += 1;
        }
        if count == 0 {
            return Err(HomographyError::TooFewPoints { got: 0 });
        }
        let n = count as f32;
        let centroid = sum / n;
        let mut dist = 0.0f32;
        for p in iter {
            dist += (p - centroid).norm();
        }
        let mean = dist / n;
        if !centroid.x.is_finite() || !centroid.y.is_finite() || !mean.is_finite() {
            return Err(HomographyError::NonFinite { index: 0 });
        }
        // All points on top of each other (to f32 precision of their size).
        let size = centroid.norm().max(mean);
        if !(mean > 1e-6 * size) || !(mean > 0.0) {
            return Err(HomographyError::Degenerate);
        }
        let scale = core::f32::consts::SQRT_2 / mean;
        if !scale.is_finite() {
            return Err(HomographyError::Degenerate);
        }
        Ok(Normalization { centroid, scale })
    }

    /// The centroid `c` that moves to the origin.
    pub fn centroid(&self) -> Vec2 {
        self.centroid
    }

    /// The scale `s` (normalised units per pixel).
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// `s (x - c)`.
    #[inline]
    pub fn apply(&self, p: &Vec2) -> Vec2 {
        (p - self.centroid) * self.scale
    }

    /// The 3x3 matrix `T`.
    pub fn matrix(&self) -> Mat3 {
        let s = self.scale;
        Mat3::new(
            s,
            0.0,
            -s * self.centroid.x,
            0.0,
            s,
            -s * self.centroid.y,
            0.0,
            0.0,
            1.0,
        )
    }

    /// The 3x3 matrix `T^-1`.
    pub fn inverse_matrix(&self) -> Mat3 {
        let inv = 1.0 / self.scale;
        Mat3::new(
            inv,
            0.0,
            self.centroid.x,
            0.0,
            inv,
            self.centroid.y,
            0.0,
            0.0,
            1.0,
        )
    }

    /// A homography estimated between normalised points, `H_n`, back in
    /// pixels: `H = T2^-1 H_n T1`, as a checked [`super::Homography`].
    ///
    /// # Errors
    /// As [`super::Homography::from_matrix`].
    pub fn denormalize(
        t1: &Normalization,
        t2: &Normalization,
        hn: &Mat3,
    ) -> Result<super::Homography, HomographyError> {
        super::Homography::from_matrix(&(t2.inverse_matrix() * hn * t1.matrix()))
    }
}
