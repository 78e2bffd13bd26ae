//! Why a homography could not be estimated.

use core::fmt;

/// Why a homography could not be estimated. No estimator in this module ever
/// returns a matrix it could not vouch for: every degenerate case is one of
/// these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HomographyError {
    /// Fewer than four correspondences.
    TooFewPoints {
        /// How many were given.
        got: usize,
    },
    /// More correspondences than the estimator's capacity `N`.
    TooManyPoints {
        /// How many were given.
        got: usize,
        /// The capacity in the estimator's type.
        capacity: usize,
    },
    /// The two point lists (or the inlier mask) differ in length.
    LengthMismatch,
    /// A coordinate is NaN or infinite (index of the first such correspondence).
    NonFinite {
        /// Index of the offending correspondence.
        index: usize,
    },
    /// Two points of a minimal set coincide (in either image).
    DuplicatePoints,
    /// Three points of a minimal set are collinear (in either image).
    Collinear,
    /// The points do not fix a homography: fewer than four distinct points in
    /// general position (all on one line, or repeated), the null space of the
    /// DLT system is not one-dimensional.
    Degenerate,
    /// The estimate is (numerically) a singular matrix, not a homography.
    NearSingular,
    /// RANSAC found no model supported by enough inliers
    /// ([`super::RansacParams::min_inliers`]).
    NoConsensus,
    /// A parameter is out of its range (threshold, confidence, iterations).
    InvalidParameter,
}

impl fmt::Display for HomographyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HomographyError::TooFewPoints { got } => {
                write!(f, "need at least 4 correspondences, got {got}")
            }
            HomographyError::TooManyPoints { got, capacity } => {
                write!(f, "{got} correspondences exceed the capacity {capacity}")
            }
            HomographyError::LengthMismatch => {
                f.write_str("point lists and inlier mask differ in length")
            }
            HomographyError::NonFinite { index } => {
                write!(f, "correspondence {index} has a non-finite coordinate")
            }
            HomographyError::DuplicatePoints => f.write_str("two points of the sample coincide"),
            HomographyError::Collinear => f.write_str("three points of the sample are collinear"),
            HomographyError::Degenerate => {
                f.write_str("points are not in general position: homography not determined")
            }
            HomographyError::NearSingular => f.write_str("estimate is a near-singular matrix"),
            HomographyError::NoConsensus => {
                f.write_str("no homography is supported by enough inliers")
            }
            HomographyError::InvalidParameter => f.write_str("parameter out of range"),
        }
    }
}

impl core::error::Error for HomographyError {}
