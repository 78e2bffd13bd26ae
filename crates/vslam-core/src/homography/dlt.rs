//! The normalised Direct Linear Transform for `N >= 4` correspondences
//! (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., Algorithm 4.2).
//!
//! Each correspondence `x -> x'` gives two rows of `A h = 0` (from
//! `x' x (H x) = 0`, eq. 4.3); `h` is the right singular vector of `A` for the
//! smallest singular value. Forming `A^T A` would square the condition number
//! and cost `f32` half its digits, so the rows are instead streamed, one at a
//! time, into a 9x9 upper-triangular `R` with `A = Q R` by Givens rotations
//! (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 5.1.8 and 6.5.3
//! "updating the QR factorisation"; square-root free, after Gentleman 1973):
//! fixed memory for any `N`, no heap. `A`
//! and `R` have the same singular values and right singular vectors, so the
//! SVD of the small `R` finishes the job.

use super::four_point::check_conditioning;
use super::normalize::Normalization;
use super::{Homography, HomographyError};
use crate::geometry::{Mat3, Vec2};
use nalgebra::{SMatrix, SVD};

/// Below this ratio of the second-smallest to the largest singular value the
/// DLT system has a null space of two or more dimensions: the points do not
/// determine a homography.
pub const RANK_TOLERANCE: f32 = 1e-4;

/// Iteration cap for the SVD of the 9x9 triangle (it converges in far fewer).
const SVD_MAX_ITERATIONS: usize = 200;

/// The upper-triangular factor `R` of the DLT design matrix, accumulated one
/// row at a time by square-root-free Givens rotations (W. M. Gentleman,
/// "Least squares computations by Givens transformations without square
/// roots", IMA J. Appl. Math. 12, 1973; the row update of A. J. Miller,
/// Algorithm AS 274, Applied Statistics 41(2), 1992): `R = D^(1/2) R_bar` with
/// `R_bar` unit upper triangular, one division and no square root per
/// rotation.
#[derive(Clone, Debug)]
pub(crate) struct DltAccumulator {
    /// The diagonal `D` (squared row norms of `R`).
    d: [f32; 9],
    /// `R_bar` above its unit diagonal (entries on and below are unused).
    r_bar: [[f32; 9]; 9],
}

impl DltAccumulator {
    pub(crate) fn new() -> Self {
        DltAccumulator {
            d: [0.0; 9],
            r_bar: [[0.0; 9]; 9],
        }
    }

    /// Adds the two rows of the correspondence `a -> b` (normalised
    /// coordinates), with weight `weight` on the squared residuals.
    #[inline]
    pub(crate) fn add(&mut self, a: &Vec2, b: &Vec2, weight: f32) {
        let (x, y, u, v) = (a.x, a.y, b.x, b.y);
        self.add_row([0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v], weight);
        self.add_row([x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y, -u], weight);
    }

    /// Rotates one row of weight `w` into the triangle (AS 274 `include`).
    #[inline]
    fn add_row(&mut self, mut row: [f32; 9], mut w: f32) {
        for (i, (di, ri)) in self.d.iter_mut().zip(self.r_bar.iter_mut()).enumerate() {
            if !(w > 0.0) {
                break;
            }
            let xi = row.get(i).copied().unwrap_or(0.0);
            if xi == 0.0 {
                continue;
            }
            let dp = *di + w * xi * xi;
            if !(dp > 0.0) || !dp.is_finite() {
                continue;
            }
            let inv = 1.0 / dp;
            let c = *di * inv;
            let s = w * xi * inv;
            w *= c;
            *di = dp;
            for (xk, rk) in row.iter_mut().zip(ri.iter_mut()).skip(i + 1) {
                let v = *xk;
                *xk = v - xi * *rk;
                *rk = c * *rk + s * v;
            }
        }
    }

    /// The least-squares null vector as a 3x3 matrix (row-major `h`), in the
    /// coordinates the rows were given in.
    pub(crate) fn solve(&self) -> Result<Mat3, HomographyError> {
        let r = SMatrix::<f32, 9, 9>::from_fn(|i, j| {
            let scale = libm::sqrtf(self.d.get(i).copied().unwrap_or(0.0));
            match j.cmp(&i) {
                core::cmp::Ordering::Less => 0.0,
                core::cmp::Ordering::Equal => scale,
                core::cmp::Ordering::Greater => {
                    scale
                        * self
                            .r_bar
                            .get(i)
                            .and_then(|r| r.get(j))
                            .copied()
                            .unwrap_or(0.0)
                }
            }
        });
        if !r.iter().all(|v| v.is_finite()) {
            return Err(HomographyError::NonFinite { index: 0 });
        }
        let svd = SVD::try_new(r, false, true, f32::EPSILON, SVD_MAX_ITERATIONS)
            .ok_or(HomographyError::Degenerate)?;
        let s: [f32; 9] = svd.singular_values.into();
        let largest = s.iter().fold(0.0f32, |m, v| m.max(*v));
        if !(s[7] > RANK_TOLERANCE * largest) {
            return Err(HomographyError::Degenerate);
        }
        let v_t = svd.v_t.ok_or(HomographyError::Degenerate)?;
        let h = v_t.fixed_rows::<1>(8);
        let m = Mat3::from_row_iterator(h.iter().copied());
        if !m.iter().all(|v| v.is_finite()) {
            return Err(HomographyError::Degenerate);
        }
        check_conditioning(&m)?;
        Ok(m)
    }
}

/// The homography `x2 ~ H x1` that fits all correspondences
/// `points1[i] -> points2[i]` in the algebraic least-squares sense, after
/// Hartley normalisation.
///
/// # Errors
/// [`HomographyError::LengthMismatch`], [`HomographyError::TooFewPoints`],
/// [`HomographyError::NonFinite`], [`HomographyError::Degenerate`] (points
/// not in general position), [`HomographyError::NearSingular`].
pub fn dlt(points1: &[Vec2], points2: &[Vec2]) -> Result<Homography, HomographyError> {
    dlt_selected(points1, points2, |_| true)
}

/// As [`dlt`], using only the correspondences whose `mask` entry is `true`.
///
/// # Errors
/// As [`dlt`]; [`HomographyError::LengthMismatch`] also when `mask` differs in
/// length. Non-finite points are an error only where selected.
pub fn dlt_masked(
    points1: &[Vec2],
    points2: &[Vec2],
    mask: &[bool],
) -> Result<Homography, HomographyError> {
    if mask.len() != points1.len() {
        return Err(HomographyError::LengthMismatch);
    }
    dlt_selected(points1, points2, |i| mask.get(i).copied().unwrap_or(false))
}

fn dlt_selected(
    points1: &[Vec2],
    points2: &[Vec2],
    selected: impl Fn(usize) -> bool + Copy,
) -> Result<Homography, HomographyError> {
    if points1.len() != points2.len() {
        return Err(HomographyError::LengthMismatch);
    }
    let pairs = || {
        points1
            .iter()
            .zip(points2.iter())
            .enumerate()
            .filter(move |(i, _)| selected(*i))
    };
    let mut count = 0usize;
    for (index, (a, b)) in pairs() {
        if !(a.x.is_finite() && a.y.is_finite() && b.x.is_finite() && b.y.is_finite()) {
            return Err(HomographyError::NonFinite { index });
        }
        count += 1;
    }
    if count < 4 {
        return Err(HomographyError::TooFewPoints { got: count });
    }
    let t1 = Normalization::from_points(pairs().map(|(_, (a, _))| a))?;
    let t2 = Normalization::from_points(pairs().map(|(_, (_, b))| b))?;
    let mut acc = DltAccumulator::new();
    for (_, (a, b)) in pairs() {
        acc.add(&t1.apply(a), &t2.apply(b), 1.0);
    }
    let hn = acc.solve()?;
    Normalization::denormalize(&t1, &t2, &hn)
}
