//! The hand-tuned kernels of the Kalman update ([`crate::update`]): the
//! arithmetic on the `DIM x DIM` covariance and the `DIM x M` block
//! `P H^T`, written over [`crate::state::DIM`] and the clone's rows
//! [`crate::state::CLONE`] (both derived from the state table), with a host
//! twin (four rows at a time, [`lanes::Lanes`]) and a Cortex-M twin
//! (scalar, four columns at a time) of the same operations in the same
//! order, so both give the same bits.
//!
//! - [`cholesky`](cholesky::cholesky): the factor `S = L L^T` of the
//!   innovation covariance (Cholesky-Banachiewicz);
//! - [`forward`]: forward substitution `L^-1 y` and the whitening
//!   `W = P H^T L^-T` with the correction `W z` and the variance check,
//!   one pass over the rows;
//! - [`downdate`]: `P <- P - W W^T` on the upper triangle or on both;
//! - [`mirror`]: the upper triangle copied onto the lower one in 4x4
//!   blocks;
//! - [`lanes`]: fixed-width lanes of `f32`, one formula for a row and for a
//!   block of rows.
//!
//! The kernels the update calls are `#[inline]`: they live in another
//! module (another codegen unit) than their caller, where the compiler
//! inlines them as it did in one file (out of line, the Cortex-M wheel
//! update took 1,040 more instructions, `firmware/report`).
//!
//! The maths they implement (the update `P <- P - K S K^T` as
//! `P - W W^T`, Solà 2017, sec. 6.1-6.3) is described in
//! [`crate::update`]; [`crate::reference`] holds the dense formulas the
//! tests compare against.

pub(crate) mod cholesky;
pub(crate) mod downdate;
pub(crate) mod forward;
pub(crate) mod lanes;
pub(crate) mod mirror;

use nalgebra::SMatrix;

use crate::state::DIM;

pub(crate) use cholesky::cholesky;
pub(crate) use downdate::{clone_rows_zero, downdate_symmetric_with, downdate_upper_with};
pub use downdate::{downdate, downdate_symmetric, downdate_upper};
pub(crate) use forward::{forward_substitute, whiten_rows};
pub use mirror::mirror_upper_to_lower;

/// Row `i` of `W`.
#[inline(always)]
pub(crate) fn row_of<const M: usize>(w: &SMatrix<f32, DIM, M>, i: usize) -> [f32; M] {
    core::array::from_fn(|r| {
        w.data
            .0
            .get(r)
            .and_then(|c| c.get(i))
            .copied()
            .unwrap_or(0.0)
    })
}

/// `p - W[i, 0] wj[0] - W[i, 1] wj[1] - ...`, in that order.
#[inline(always)]
pub(crate) fn entry_minus<const M: usize>(
    p: f32,
    w: &SMatrix<f32, DIM, M>,
    i: usize,
    wj: &[f32; M],
) -> f32 {
    let mut v = p;
    for (w_r, a) in w.data.0.iter().zip(wj) {
        v -= w_r.get(i).copied().unwrap_or(0.0) * a;
    }
    v
}
