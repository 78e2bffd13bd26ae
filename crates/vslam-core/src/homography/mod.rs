//! Plane-induced homographies between two images: the exact four-point
//! solver, the normalised DLT, RANSAC and refinement on the inliers.
//!
//! Convention: a [`Homography`] maps image-1 pixels to image-2 pixels,
//! `x2 ~ H x1` (homogeneous, `x = [u v 1]^T`). It is stored scaled to unit
//! Frobenius norm, `||H||_F = 1`, with the sign chosen so that `det H > 0`.
//! For a plane seen from the front by both cameras this is the sign for which
//! `x2^T H x1 > 0` (in calibrated coordinates), the sign the decomposition
//! ([`crate::decompose`]) expects. `H[2][2]` is *not* forced to 1; divide by it
//! yourself if you need that form.
//!
//! The estimators follow Hartley & Zisserman, *Multiple View Geometry*, 2nd
//! ed.: Algorithm 4.2 (normalised DLT, with the Hartley normalisation of
//! sec. 4.4.4), Algorithm 4.6 (adaptive RANSAC, eq. 4.18 for the number of
//! samples) and sec. 4.5 / A6 (Levenberg-Marquardt on the transfer error).
//!
//! - [`four_point`]: exact solver from four correspondences (projective basis).
//! - [`dlt`]: least squares from `N >= 4` correspondences (Givens-streamed QR,
//!   SVD of the 9x9 triangle, no `A^T A`).
//! - [`ransac`]: robust estimation with a caller-seeded PRNG and inlier mask.
//! - [`refine`]: Levenberg-Marquardt on the one-sided transfer error.
//! - [`normalize`]: the Hartley normalisation the solvers share.

// `!(x > tol)` is deliberate throughout: it is true for NaN, so a NaN can
// never pass a check that a plain `x <= tol` would let through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod dlt;
pub mod four_point;
pub mod normalize;
pub mod ransac;
pub mod refine;

mod error;
mod matrix;

pub use dlt::{dlt, dlt_masked};
pub use error::HomographyError;
pub use four_point::from_four_points;
pub use matrix::Homography;
pub use ransac::{HomographyRansac, RansacParams, RansacReport};
pub use refine::{RefineParams, RefineReport, refine_homography};
