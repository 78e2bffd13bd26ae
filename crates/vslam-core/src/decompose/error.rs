//! Why a homography could not be decomposed, or a candidate not selected.

use core::fmt;

/// Why a homography could not be decomposed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecomposeError {
    /// An entry of `H` is NaN or infinite.
    NonFinite,
    /// `H` is singular (rank below 3), or its determinant's sign says the two
    /// cameras are on opposite sides of the plane.
    Singular,
    /// The eigen-decomposition did not converge, or produced non-finite values.
    NoConvergence,
    /// The pure-rotation tolerance is negative or not finite.
    InvalidTolerance,
    /// Intrinsics not finite or focal length not positive.
    InvalidIntrinsics,
}

impl fmt::Display for DecomposeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DecomposeError::NonFinite => "homography has a non-finite entry",
            DecomposeError::Singular => "homography is singular",
            DecomposeError::NoConvergence => "eigen-decomposition did not converge",
            DecomposeError::InvalidTolerance => "pure-rotation tolerance out of range",
            DecomposeError::InvalidIntrinsics => {
                "intrinsics not finite or focal length not positive"
            }
        })
    }
}

impl core::error::Error for DecomposeError {}

/// Why no single candidate could be selected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SelectError {
    /// The inlier mask differs in length from the points.
    LengthMismatch,
    /// No candidate puts enough points in front of both cameras.
    NoneInFront,
    /// Several candidates pass the depth test and no prior decides.
    Ambiguous {
        /// How many candidates passed.
        passing: usize,
    },
    /// No passing candidate has its normal within the prior's angle.
    PriorMismatch {
        /// Angle of the closest passing candidate's normal to the prior, rad.
        best_angle_rad: f32,
    },
    /// Prior normal zero or not finite, angle not in `(0, pi]`, or fraction
    /// not in `(0.5, 1]`.
    InvalidParameter,
}

impl fmt::Display for SelectError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SelectError::LengthMismatch => f.write_str("inlier mask and points differ in length"),
            SelectError::NoneInFront => {
                f.write_str("no candidate puts the points in front of both cameras")
            }
            SelectError::Ambiguous { passing } => {
                write!(
                    f,
                    "{passing} candidates pass the depth test and no prior decides"
                )
            }
            SelectError::PriorMismatch { best_angle_rad } => write!(
                f,
                "closest candidate normal is {best_angle_rad} rad from the prior"
            ),
            SelectError::InvalidParameter => f.write_str("selection parameter out of range"),
        }
    }
}

impl core::error::Error for SelectError {}
