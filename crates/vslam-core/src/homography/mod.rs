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
//! - [`mod@dlt`]: least squares from `N >= 4` correspondences (Givens-streamed QR,
//!   SVD of the 9x9 triangle, no `A^T A`).
//! - [`ransac`]: robust estimation with a caller-seeded PRNG and inlier mask.
//! - [`refine`]: Levenberg-Marquardt on the one-sided transfer error.
//! - [`normalize`]: the Hartley normalisation the solvers share.

//! # Example: track, estimate, decompose
//!
//! ```
//! use vslam_core::decompose::{decompose, NormalPrior, PinholeIntrinsics, SelectParams};
//! use vslam_core::geometry::{Vec2, Vec3};
//! use vslam_core::homography::{HomographyRansac, RansacParams};
//!
//! // Matches of a fronto-parallel ceiling, camera slid sideways by (5, -3) px.
//! let points1: [Vec2; 9] = core::array::from_fn(|i| {
//!     Vec2::new(60.0 + 250.0 * (i % 3) as f32, 50.0 + 180.0 * (i / 3) as f32)
//! });
//! let points2 = points1.map(|p| p + Vec2::new(5.0, -3.0));
//!
//! // The estimator owns its scratch for up to 128 matches.
//! let mut ransac = HomographyRansac::<128>::new(RansacParams { seed: 1, ..Default::default() })?;
//! let mut inliers = [false; 9];
//! let report = ransac.estimate(&points1, &points2, &mut inliers)?;
//! assert_eq!(report.inlier_count, 9);
//! let row_major: [f32; 9] = report.homography.to_row_major();
//! assert!((row_major[2] / row_major[8] - 5.0).abs() < 1e-3);
//!
//! // Motion and plane: the ceiling normal is +z of an upward camera.
//! let k = PinholeIntrinsics::new(400.0, 400.0, 320.0, 240.0)?;
//! let candidates = decompose(&report.homography, &k)?;
//! let prior = NormalPrior::new(&Vec3::z(), 0.3)?;
//! let params = SelectParams { prior: Some(prior), ..Default::default() };
//! let chosen = candidates.select(&points1, &inliers, &params)?;
//! let motion = candidates.selected(&chosen).ok_or("no candidate")?;
//! // X2 = R X1 + t: the camera moved by -t; t/d = (5/400, -3/400, 0).
//! assert!((motion.translation_over_distance - Vec3::new(0.0125, -0.0075, 0.0)).norm() < 1e-4);
//! # Ok::<(), Box<dyn core::error::Error>>(())
//! ```

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
