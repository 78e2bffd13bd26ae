//! Decomposition of a plane-induced homography into the camera motion and
//! the plane: `{R, t/d, n}`.
//!
//! Implements the SVD-based decomposition of Y. Ma, S. Soatto, J. Kosecka,
//! S. Sastry, *An Invitation to 3-D Vision*, Springer 2004, sec. 5.3.3
//! (Theorem 5.19 and the construction before it), after O. Faugeras and F.
//! Lustman, "Motion and structure from motion in a piecewise planar
//! environment", IJPRAI 2(3), 1988.
//!
//! # Conventions
//! - Camera frames: `X2 = R X1 + t` maps a point from camera-1 to camera-2
//!   coordinates (so `R = R_21`, `t = t_21`).
//! - The plane: `n^T X1 = d` in camera-1 coordinates, `|n| = 1`, `d > 0`; so
//!   `n` points from camera 1 *towards* the plane (for an upward camera under
//!   a flat ceiling, `n ~ +z_camera`).
//! - Then `X2 = (R + t n^T / d) X1` for points on the plane, and the
//!   calibrated homography is `H = K^-1 H_px K = lambda (R + (t/d) n^T)`.
//!
//! # Normalisation
//! `lambda` is removed by dividing by the middle singular value of `H`
//! (`sigma_2(R + u v^T) = 1` for any rank-one update, Ma et al. Lemma 5.18).
//! Its sign is taken from `det H`: `det(R + (t/d) n^T) = 1 + n^T R^T t / d =
//! d2 / d`, the ratio of the plane's distances from the two cameras, which is
//! positive whenever both cameras see the plane from the same side. This is
//! exactly the sign for which `x2^T H x1 > 0` for the imaged points, without
//! needing the points. ([`crate::homography::Homography`] already stores
//! `det H > 0`.)
//!
//! # Solutions
//! With `H^T H = V diag(s1^2, 1, s3^2) V^T`:
//! `u1,2 = (sqrt(1 - s3^2) v1 +- sqrt(s1^2 - 1) v3) / sqrt(s1^2 - s3^2)`,
//! `U_i = [v2, u_i, v2 x u_i]`, `W_i = [H v2, H u_i, H v2 x H u_i]`, and
//!
//! | # | `R`          | `n`         | `t/d`            |
//! |---|--------------|-------------|------------------|
//! | 0 | `W1 U1^T`    | `v2 x u1`   | `(H - R0) n0`    |
//! | 1 | `W2 U2^T`    | `v2 x u2`   | `(H - R1) n1`    |
//! | 2 | `R0`         | `-n0`       | `-(t/d)0`        |
//! | 3 | `R1`         | `-n1`       | `-(t/d)1`        |
//!
//! Positive depth of the imaged points removes two of them in general; a
//! prior on the plane normal (the ceiling, from the camera extrinsics)
//! removes the last ambiguity ([`HomographyDecomposition::select`]).
//!
//! # Pure rotation
//! If `s1^2 - s3^2` is below the tolerance, `H` is a rotation (`t/d = 0`, or
//! the plane at infinity) and `n` is undefined: the decomposition has one
//! candidate with `t/d = 0`, `n = 0`, and
//! [`HomographyDecomposition::is_pure_rotation`] says so.

// `!(x > tol)` is deliberate: it is true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod error;
mod intrinsics;
mod select;

pub use error::{DecomposeError, SelectError};
pub use intrinsics::PinholeIntrinsics;
pub use select::{NormalPrior, SelectParams, Selection};

use crate::geometry::{Mat3, Rot3, Vec3};
use crate::homography::Homography;
use heapless::Vec as HVec;
use nalgebra::SymmetricEigen;

/// Default: below this `s1^2 - s3^2` (of the normalised `H`) the motion is a
/// pure rotation. A translation `|t/d|` gives `s1^2 - s3^2 ~ 2 |t/d|`, so this
/// corresponds to `|t/d|` of about `5e-5`.
pub const PURE_ROTATION_TOLERANCE: f32 = 1e-4;

/// Iteration cap for the 3x3 symmetric eigen-decomposition.
const EIGEN_MAX_ITERATIONS: usize = 100;

/// One motion-and-plane explanation of a homography.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneMotion {
    /// `R = R_21`: camera-1 coordinates to camera-2 coordinates. Always a
    /// proper rotation (re-orthonormalised, `det = +1`).
    pub rotation: Rot3,
    /// `t / d`: the translation `t_21` over the plane's distance from camera 1.
    /// Zero for a pure rotation.
    pub translation_over_distance: Vec3,
    /// Unit plane normal in camera 1, pointing from the camera towards the
    /// plane. Zero (undefined) for a pure rotation.
    pub normal: Vec3,
}

impl PlaneMotion {
    /// `R + (t/d) n^T`: the calibrated homography this candidate explains.
    pub fn homography(&self) -> Mat3 {
        self.rotation.matrix() + self.translation_over_distance * self.normal.transpose()
    }
}

/// All candidate decompositions of one homography.
#[derive(Clone, Debug, PartialEq)]
pub struct HomographyDecomposition {
    candidates: HVec<PlaneMotion, 4>,
    pure_rotation: bool,
    singular_values: [f32; 3],
    intrinsics: PinholeIntrinsics,
}

impl HomographyDecomposition {
    /// The candidates: four in general, one for a pure rotation.
    pub fn candidates(&self) -> &[PlaneMotion] {
        &self.candidates
    }

    /// Whether the motion is (numerically) a pure rotation: one candidate,
    /// `t/d = 0`, normal undefined (zero). No scale can be read from it.
    pub fn is_pure_rotation(&self) -> bool {
        self.pure_rotation
    }

    /// Singular values of the normalised calibrated `H`, descending
    /// (`[s1, 1, s3]`). `s1 - s3` measures how much translation is visible.
    pub fn singular_values(&self) -> [f32; 3] {
        self.singular_values
    }

    /// The intrinsics the pixel points of [`Self::select`] are read with.
    pub fn intrinsics(&self) -> &PinholeIntrinsics {
        &self.intrinsics
    }
}

/// Decomposes a pixel homography `x2 ~ H x1` of a camera with intrinsics `K`
/// (the same camera for both images).
///
/// # Errors
/// See [`decompose_calibrated`].
pub fn decompose(
    h: &Homography,
    intrinsics: &PinholeIntrinsics,
) -> Result<HomographyDecomposition, DecomposeError> {
    decompose_with_tolerance(h, intrinsics, PURE_ROTATION_TOLERANCE)
}

/// As [`decompose`], with the pure-rotation tolerance on `s1^2 - s3^2` given
/// (see [`PURE_ROTATION_TOLERANCE`]).
///
/// # Errors
/// See [`decompose_calibrated`].
pub fn decompose_with_tolerance(
    h: &Homography,
    intrinsics: &PinholeIntrinsics,
    pure_rotation_tolerance: f32,
) -> Result<HomographyDecomposition, DecomposeError> {
    let calibrated = intrinsics.inverse_matrix() * h.matrix() * intrinsics.matrix();
    let mut out = decompose_calibrated(&calibrated, pure_rotation_tolerance)?;
    out.intrinsics = *intrinsics;
    Ok(out)
}

/// Decomposes a calibrated homography `H ~ K^-1 H_px K` given at any scale
/// and sign. Points for [`HomographyDecomposition::select`] are then
/// normalised coordinates (`K` = identity).
///
/// # Errors
/// [`DecomposeError::NonFinite`], [`DecomposeError::InvalidTolerance`],
/// [`DecomposeError::Singular`] (rank below 3, or the cameras on opposite
/// sides of the plane so no sign makes it physical),
/// [`DecomposeError::NoConvergence`].
pub fn decompose_calibrated(
    h: &Mat3,
    pure_rotation_tolerance: f32,
) -> Result<HomographyDecomposition, DecomposeError> {
    if !h.iter().all(|v| v.is_finite()) {
        return Err(DecomposeError::NonFinite);
    }
    if !(pure_rotation_tolerance >= 0.0) || !pure_rotation_tolerance.is_finite() {
        return Err(DecomposeError::InvalidTolerance);
    }
    // Scale to unit largest entry first so nothing below can overflow.
    let max = h.amax();
    if !(max > 0.0) {
        return Err(DecomposeError::Singular);
    }
    let h = h / max;
    let det = h.determinant();
    if !(libm::fabsf(det) > 1e-9 * libm::powf(h.norm(), 3.0)) {
        return Err(DecomposeError::Singular);
    }
    let h = if det < 0.0 { -h } else { h };

    let (s2, vecs) = sorted_eigen(&h.tr_mul(&h))?;
    let [l1, l2, l3] = s2;
    if !(l3 > 0.0) || !(l2 > 0.0) {
        return Err(DecomposeError::Singular);
    }
    // Divide by the middle singular value: H^T H scales by its square.
    let sigma2 = libm::sqrtf(l2);
    let h = h / sigma2;
    let (l1, l3) = (l1 / l2, l3 / l2);
    let singular_values = [libm::sqrtf(l1), 1.0, libm::sqrtf(l3)];
    let [v1, v2, v3] = vecs;

    let mut candidates = HVec::new();
    if l1 - l3 < pure_rotation_tolerance {
        let rotation = orthonormalize(&h)?;
        candidates
            .push(PlaneMotion {
                rotation,
                translation_over_distance: Vec3::zeros(),
                normal: Vec3::zeros(),
            })
            .map_err(|_| DecomposeError::NoConvergence)?;
        return Ok(HomographyDecomposition {
            candidates,
            pure_rotation: true,
            singular_values,
            intrinsics: PinholeIntrinsics::identity(),
        });
    }

    let a = libm::sqrtf((1.0 - l3).max(0.0));
    let b = libm::sqrtf((l1 - 1.0).max(0.0));
    let c = libm::sqrtf(l1 - l3);
    let u1 = (v1 * a + v3 * b) / c;
    let u2 = (v1 * a - v3 * b) / c;
    let first = solution(&h, &v2, &u1)?;
    let second = solution(&h, &v2, &u2)?;
    for s in [first, second] {
        candidates
            .push(s)
            .map_err(|_| DecomposeError::NoConvergence)?;
    }
    for s in [first, second] {
        candidates
            .push(PlaneMotion {
                rotation: s.rotation,
                translation_over_distance: -s.translation_over_distance,
                normal: -s.normal,
            })
            .map_err(|_| DecomposeError::NoConvergence)?;
    }
    Ok(HomographyDecomposition {
        candidates,
        pure_rotation: false,
        singular_values,
        intrinsics: PinholeIntrinsics::identity(),
    })
}

/// Eigenvalues of a symmetric 3x3 matrix, descending, with their unit
/// eigenvectors.
fn sorted_eigen(m: &Mat3) -> Result<([f32; 3], [Vec3; 3]), DecomposeError> {
    let eig = SymmetricEigen::try_new(*m, f32::EPSILON, EIGEN_MAX_ITERATIONS)
        .ok_or(DecomposeError::NoConvergence)?;
    let vals: [f32; 3] = eig.eigenvalues.into();
    let vecs = [
        eig.eigenvectors.column(0).into_owned(),
        eig.eigenvectors.column(1).into_owned(),
        eig.eigenvectors.column(2).into_owned(),
    ];
    let mut order = [0usize, 1, 2];
    let val = |i: usize| vals.get(i).copied().unwrap_or(f32::NAN);
    order.sort_unstable_by(|&i, &j| val(j).total_cmp(&val(i)));
    let vec = |i: usize| vecs.get(i).copied().unwrap_or_else(Vec3::zeros);
    let [i, j, k] = order;
    let out_vals = [val(i), val(j), val(k)];
    let out_vecs = [vec(i), vec(j), vec(k)];
    if !out_vals.iter().all(|v| v.is_finite())
        || !out_vecs.iter().all(|v| v.iter().all(|x| x.is_finite()))
    {
        return Err(DecomposeError::NoConvergence);
    }
    Ok((out_vals, out_vecs))
}

/// One of Ma et al.'s two primary solutions from `v2` and `u`.
fn solution(h: &Mat3, v2: &Vec3, u: &Vec3) -> Result<PlaneMotion, DecomposeError> {
    let (e1, e2, e3) = orthonormal_frame(v2, u)?;
    let (f1, f2, f3) = orthonormal_frame(&(h * v2), &(h * u))?;
    let uu = Mat3::from_columns(&[e1, e2, e3]);
    let ww = Mat3::from_columns(&[f1, f2, f3]);
    let r = ww * uu.transpose();
    let rotation = Rot3::from_matrix_unchecked(r);
    let normal = e3;
    let translation_over_distance = (h - r) * normal;
    if !translation_over_distance.iter().all(|v| v.is_finite()) {
        return Err(DecomposeError::NoConvergence);
    }
    Ok(PlaneMotion {
        rotation,
        translation_over_distance,
        normal,
    })
}

/// Gram-Schmidt: `a`, the part of `b` orthogonal to it, and their cross
/// product, all unit; a right-handed orthonormal frame.
fn orthonormal_frame(a: &Vec3, b: &Vec3) -> Result<(Vec3, Vec3, Vec3), DecomposeError> {
    let e1 = a
        .try_normalize(f32::MIN_POSITIVE)
        .ok_or(DecomposeError::Singular)?;
    let e2 = (b - e1 * e1.dot(b))
        .try_normalize(f32::MIN_POSITIVE)
        .ok_or(DecomposeError::Singular)?;
    let e3 = e1.cross(&e2);
    Ok((e1, e2, e3))
}

/// The rotation nearest to `m` (which is near one): Gram-Schmidt on its
/// first two columns as the start, polished by nalgebra's iterative
/// projection onto SO(3) (Mueller et al., "A robust method to extract the
/// rotational part of deformations", MIG 2016).
fn orthonormalize(m: &Mat3) -> Result<Rot3, DecomposeError> {
    let c0 = m.column(0).into_owned();
    let c1 = m.column(1).into_owned();
    let (e1, e2, e3) = orthonormal_frame(&c0, &c1)?;
    let guess = Rot3::from_matrix_unchecked(Mat3::from_columns(&[e1, e2, e3]));
    let r = Rot3::from_matrix_eps(m, 1e-7, 16, guess);
    if r.matrix().iter().all(|v| v.is_finite()) {
        Ok(r)
    } else {
        Ok(guess)
    }
}
