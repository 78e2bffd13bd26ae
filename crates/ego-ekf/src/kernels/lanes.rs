//! Fixed-width lanes of `f32`, so that one formula serves a scalar and a
//! block of rows.
//!
//! The covariance loops apply the same expression to every row of a few
//! columns of `P`. Written once over a [`Lane`] type, the expression runs
//! on `f32` (one row at a time: Cortex-M, which has no vector unit) or on
//! [`Lanes<N>`] (`N` consecutive rows of a column at a time: the loops
//! vectorise on hosts). Every lane does the same operations in the same
//! order as the scalar form, so both give the same bits.

use core::ops::{Add, Mul, Sub};

#[cfg(not(target_arch = "arm"))]
use crate::state::DIM;

/// A value the row formulas compute with: `f32` or [`Lanes`], with
/// constants made by `From<f32>` (every lane the same).
pub(crate) trait Lane:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + From<f32>
{
}

impl Lane for f32 {}

/// `N` entries of a column (consecutive rows), computed lane by lane
/// (hosts only: Cortex-M has no vector unit).
#[cfg(not(target_arch = "arm"))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lanes<const N: usize>(pub [f32; N]);

#[cfg(not(target_arch = "arm"))]
impl<const N: usize> Lane for Lanes<N> {}

#[cfg(not(target_arch = "arm"))]
impl<const N: usize> From<f32> for Lanes<N> {
    #[inline(always)]
    fn from(v: f32) -> Self {
        Lanes([v; N])
    }
}

#[cfg(not(target_arch = "arm"))]
impl<const N: usize> Lanes<N> {
    /// Rows `at..at + N` of `col` (zeros if they do not fit: the callers'
    /// starts always fit, see [`starts`]).
    #[inline(always)]
    pub(crate) fn load(col: &[f32; DIM], at: usize) -> Self {
        Lanes(
            col.get(at..at + N)
                .and_then(|s| <[f32; N]>::try_from(s).ok())
                .unwrap_or([0.0; N]),
        )
    }

    /// Writes the lanes to rows `at..at + N` of `col` (nothing if they do
    /// not fit).
    #[inline(always)]
    pub(crate) fn store(self, col: &mut [f32; DIM], at: usize) {
        if let Some(dst) = col.get_mut(at..at + N) {
            dst.copy_from_slice(&self.0);
        }
    }
}

#[cfg(not(target_arch = "arm"))]
impl<const N: usize> Lanes<N> {
    /// The lane-wise minimum `if a < b { a } else { b }` (x86's `minps`;
    /// with a NaN in a lane, `b`'s value: callers that care about NaNs
    /// test for them apart).
    #[inline(always)]
    pub(crate) fn min(self, b: Self) -> Self {
        let mut out = self.0;
        for (o, r) in out.iter_mut().zip(b.0) {
            *o = if *o < r { *o } else { r };
        }
        Lanes(out)
    }
}

macro_rules! lane_op {
    ($trait:ident, $method:ident, $op:tt) => {
        #[cfg(not(target_arch = "arm"))]
        impl<const N: usize> $trait for Lanes<N> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: Self) -> Self {
                let mut out = self.0;
                for (o, r) in out.iter_mut().zip(rhs.0) {
                    *o $op r;
                }
                Lanes(out)
            }
        }
    };
}
lane_op!(Add, add, +=);
lane_op!(Sub, sub, -=);
lane_op!(Mul, mul, *=);

/// The starts of the row blocks of width `N` that cover the `DIM` rows of a
/// column: `0, N, 2N, ...` and, if `N` does not divide `DIM`, a last block
/// ending at the last row (overlapping the one before it: for outputs that
/// are written, not accumulated, the overlap computes the same values
/// twice). `K` must be `DIM.div_ceil(N)` (checked when it is evaluated, at
/// compile time: the callers use it in a constant context).
#[cfg(not(target_arch = "arm"))]
#[allow(clippy::indexing_slicing)] // k < K; a const fn panics at compile time
pub(crate) const fn starts<const N: usize, const K: usize>() -> [usize; K] {
    assert!(N <= DIM && K == DIM.div_ceil(N));
    let mut out = [0; K];
    let mut k = 0;
    while k < K {
        out[k] = if (k + 1) * N <= DIM { k * N } else { DIM - N };
        k += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(not(target_arch = "arm"))]
    #[test]
    fn block_starts_cover_every_row_once_or_with_overlap_at_the_end() {
        // DIM = 36.
        assert_eq!(starts::<8, 5>(), [0, 8, 16, 24, 28]);
        assert_eq!(starts::<4, 9>(), [0, 4, 8, 12, 16, 20, 24, 28, 32]);
        assert_eq!(starts::<5, 8>(), [0, 5, 10, 15, 20, 25, 30, 31]);
    }

    #[test]
    fn lanes_compute_what_the_scalars_do() {
        let a = Lanes([1.5f32, -2.0, 3.25, 1e-8]);
        let b = Lanes([0.1f32, 7.0, -0.3, 3.0]);
        let c = Lanes::<4>::from(0.7);
        let got = (a * b - c) + a;
        for l in 0..4 {
            assert_eq!(got.0[l], (a.0[l] * b.0[l] - 0.7) + a.0[l]);
        }
    }

    #[test]
    fn the_minimum_is_taken_lane_by_lane() {
        let a = Lanes([1.5f32, -2.0, 3.25, f32::INFINITY]);
        let b = Lanes([0.1f32, 7.0, 3.25, 2.0]);
        assert_eq!(a.min(b).0, [0.1, -2.0, 3.25, 2.0]);
        assert_eq!(b.min(a).0, [0.1, -2.0, 3.25, 2.0]);
    }

    #[test]
    fn load_and_store_keep_the_rows_and_refuse_what_does_not_fit() {
        let col: [f32; DIM] = core::array::from_fn(|i| i as f32);
        // DIM = 36.
        assert_eq!(Lanes::<4>::load(&col, 32).0, [32.0, 33.0, 34.0, 35.0]);
        assert_eq!(Lanes::<4>::load(&col, 33).0, [0.0; 4]);
        let mut out = [0.0f32; DIM];
        Lanes([1.0f32; 4]).store(&mut out, 34);
        assert_eq!(out, [0.0; DIM]);
        Lanes([1.0f32; 4]).store(&mut out, 2);
        assert_eq!(&out[..7], &[0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
    }
}
