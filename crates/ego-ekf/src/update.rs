//! The shared gated Kalman update of the error-state filter.
//!
//! For a linearised measurement `y = z - h(x_hat) = H dx + n`, `n ~ N(0, R)`
//! (Solà 2017, sec. 6.1-6.3): innovation covariance `S = H P H^T + R`,
//! normalised innovation squared `y^T S^-1 y` tested against a chi-square
//! gate, gain `K = P H^T S^-1`, error estimate `dx = K y` injected into the
//! nominal state, covariance in the symmetric form
//! `P <- P - K S K^T` (equal to the Joseph form for the optimal gain), then
//! the error reset `P <- G P G^T`. An update that would leave a
//! non-positive variance is refused and the state left untouched.
//!
//! The arithmetic follows the structure, as PX4 EKF2's generated code does:
//! - `P H^T` only over the columns where `H` is nonzero ([`Support`]; the
//!   wheel rows touch 20 of 35, the flow rows 18, the ZUPT rows 15; the
//!   wheel computes it from its factored rows, see
//!   [`crate::wheel::model::WheelRows::p_ht`]);
//! - with the Cholesky factor `S = L L^T`, `W = P H^T L^-T` gives
//!   `K S K^T = W W^T`, `dx = W (L^-1 y)` and the NIS `|L^-1 y|^2`: the
//!   sequence of scalar updates row by row, with all their rank-one
//!   downdates in one pass over `P` ([`fuse_prepared`]);
//! - `P <- P - W W^T` in place, no 35x35 temporary, on the upper triangle
//!   ([`downdate_upper`], half the products) and mirrored
//!   ([`mirror_upper_to_lower`]), or on Cortex-M with both triangles written
//!   in the same pass ([`downdate_symmetric`]): exactly symmetric, the same
//!   bits on every target;
//! - the reset on the upper triangle, only the rotation rows and columns
//!   ([`crate::covariance::reset_upper`]), and only for corrections above
//!   [`crate::covariance::RESET_MIN_ANGLE`] (`G = I` below).
//!
//! [`crate::reference::gated_update_dense`] is the straightforward dense
//! formula (Joseph form) the tests compare against.

use nalgebra::{SMatrix, SVector};
use vslam_core::Reject;

use crate::covariance::{reset_needed, reset_upper};
use crate::lanes::Lane;
#[cfg(not(target_arch = "arm"))]
use crate::lanes::Lanes;
use crate::state::{CP, CTH, Covariance, DIM, ErrorState, NominalState};

/// The columns where a measurement Jacobian `H` (`M` rows) is nonzero: a
/// bit mask over the error state, with `H` borrowed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Support<'a, const M: usize> {
    h: &'a SMatrix<f32, M, DIM>,
    mask: u64,
}

// The mask holds one bit per error-state column.
const _: () = assert!(DIM <= 64);

impl<'a, const M: usize> Support<'a, M> {
    /// The nonzero columns of `h`.
    pub fn of(h: &'a SMatrix<f32, M, DIM>) -> Self {
        let mut mask = 0u64;
        for (j, col) in h.data.0.iter().enumerate() {
            let nonzero = col.iter().fold(false, |any, v| any | (*v != 0.0));
            mask |= u64::from(nonzero) << j;
        }
        Support { h, mask }
    }

    /// Number of nonzero columns.
    pub fn len(&self) -> usize {
        self.mask.count_ones() as usize
    }

    /// Whether `H` is zero.
    pub fn is_empty(&self) -> bool {
        self.mask == 0
    }

    /// `(j, H[.., j])` for every nonzero column `j`, in increasing `j`.
    pub fn iter(&self) -> impl Iterator<Item = (usize, &'a [f32; M])> + use<'a, M> {
        let h = self.h;
        let mut bits = self.mask;
        core::iter::from_fn(move || {
            while bits != 0 {
                let j = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if let Some(col) = h.data.0.get(j) {
                    return Some((j, col));
                }
            }
            None
        })
    }

    /// `P H^T`: column `r` is the sum over the nonzero `H[r, j]` of
    /// `H[r, j]` times column `j` of `P` (contiguous in nalgebra's storage).
    pub fn p_ht(&self, p: &Covariance) -> SMatrix<f32, DIM, M> {
        let mut pht = SMatrix::<f32, DIM, M>::zeros();
        for (j, h) in self.iter() {
            let Some(pj) = p.data.0.get(j) else {
                continue;
            };
            for (out, &hv) in pht.data.0.iter_mut().zip(h) {
                if hv != 0.0 {
                    axpy(out, hv, pj);
                }
            }
        }
        pht
    }
}

/// `y <- y + a x` over a whole column.
#[inline(always)]
fn axpy(y: &mut [f32; DIM], a: f32, x: &[f32; DIM]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

/// Whether every entry is finite (branch-free, so it vectorises).
fn all_finite(values: &[f32]) -> bool {
    values.iter().fold(true, |ok, v| ok & v.is_finite())
}

/// A linearised measurement of dimension `M`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement<const M: usize> {
    /// Residual `z - h(x_hat)`.
    pub residual: SVector<f32, M>,
    /// Jacobian `dh / d(dx)`.
    pub h: SMatrix<f32, M, DIM>,
    /// Measurement noise covariance `R`.
    pub noise: SMatrix<f32, M, M>,
}

impl<const M: usize> Measurement<M> {
    /// Whether residual, Jacobian and noise are all finite.
    pub fn is_finite(&self) -> bool {
        all_finite(self.residual.as_slice())
            && all_finite(self.h.as_slice())
            && all_finite(self.noise.as_slice())
    }

    /// The variance of the `row`-th residual component under `p`:
    /// `H_i P H_i^T + R_ii` (for per-component gating). `None` for a row
    /// outside the measurement.
    pub fn component_variance(&self, p: &Covariance, row: usize) -> Option<f32> {
        if row >= M {
            return None;
        }
        let h = self.h.row(row);
        let ph = p * h.transpose();
        let r = self.noise.get((row, row)).copied()?;
        Some((h * ph).sum() + r)
    }

    /// `P H^T` for a symmetric `P`, over the nonzero columns of `H` only
    /// (see [`Support::p_ht`]).
    pub fn p_ht(&self, p: &Covariance) -> SMatrix<f32, DIM, M> {
        Support::of(&self.h).p_ht(p)
    }

    /// Keeps the rows `rows` (a sub-measurement).
    pub fn select<const K: usize>(&self, rows: [usize; K]) -> Option<Measurement<K>> {
        let mut out = Measurement {
            residual: SVector::<f32, K>::zeros(),
            h: SMatrix::<f32, K, DIM>::zeros(),
            noise: SMatrix::<f32, K, K>::zeros(),
        };
        for (i, &ri) in rows.iter().enumerate() {
            if ri >= M {
                return None;
            }
            *out.residual.get_mut(i)? = *self.residual.get(ri)?;
            out.h.set_row(i, &self.h.row(ri));
            for (j, &rj) in rows.iter().enumerate() {
                *out.noise.get_mut((i, j))? = *self.noise.get((ri, rj))?;
            }
        }
        Some(out)
    }
}

/// What an accepted update did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateReport {
    /// Normalised innovation squared `y^T S^-1 y`.
    pub nis: f32,
}

/// Fuses `m` into the state: gated by `gate` on the NIS when given.
///
/// Errors: [`Reject::NonFinite`] for a non-finite residual or Jacobian,
/// [`Reject::Gated`] when the NIS exceeds the gate, [`Reject::Degenerate`]
/// when `S` is not positive definite or the update would break `P`. On any
/// error the state and covariance are unchanged.
pub fn gated_update<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &Measurement<M>,
    gate: Option<f32>,
) -> Result<UpdateReport, Reject> {
    if !m.is_finite() {
        return Err(Reject::NonFinite);
    }
    let support = Support::of(&m.h);
    let pht = support.p_ht(p);
    update_with_support(x, p, m, &support, &pht, gate)
}

/// [`gated_update`] with `P H^T` already computed by the caller (who used
/// it, e.g., for per-component gating). `pht` must equal `P H^T`.
pub fn gated_update_with<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &Measurement<M>,
    pht: &SMatrix<f32, DIM, M>,
    gate: Option<f32>,
) -> Result<UpdateReport, Reject> {
    update_with_support(x, p, m, &Support::of(&m.h), pht, gate)
}

/// The update proper, with the support of `H` and `P H^T` known.
fn update_with_support<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &Measurement<M>,
    support: &Support<'_, M>,
    pht: &SMatrix<f32, DIM, M>,
    gate: Option<f32>,
) -> Result<UpdateReport, Reject> {
    if !m.is_finite() {
        return Err(Reject::NonFinite);
    }
    // S = H (P H^T) + R over the support of H: column c gains
    // (P H^T)[j, c] times column j of H, for each nonzero column j.
    let mut s = m.noise;
    for (j, h) in support.iter() {
        for (s_col, pht_col) in s.data.0.iter_mut().zip(pht.data.0.iter()) {
            let v = pht_col.get(j).copied().unwrap_or(0.0);
            for (sv, hv) in s_col.iter_mut().zip(h) {
                *sv += v * hv;
            }
        }
    }
    fuse_prepared(x, p, pht, &s, &m.residual, gate)
}

/// The update from its ingredients: `pht = P H^T`, `s = H P H^T + R` and
/// the residual `y`, for a measurement whose finiteness the caller checked
/// (a non-finite `P H^T` is caught as [`Reject::Degenerate`] by the
/// variance check below, so it is not scanned separately). Gated by `gate`
/// on the NIS when given; errors and guarantees as [`gated_update`].
///
/// Equal to `M` sequential scalar updates (the rows' noises need not be
/// uncorrelated: the Cholesky factor of `S` decorrelates them), each
/// `P <- P - k k^T s_r`, but with the `M` rank-one downdates applied in one
/// pass over the upper triangle of `P`: the scalar updates change only the
/// `35 x M` block `P H^T` (by forward substitution), never `P` itself until
/// the end.
pub fn fuse_prepared<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    pht: &SMatrix<f32, DIM, M>,
    s: &SMatrix<f32, M, M>,
    residual: &SVector<f32, M>,
    gate: Option<f32>,
) -> Result<UpdateReport, Reject> {
    fuse_prepared_in_place(x, p, &mut pht.clone_owned(), s, residual, gate)
}

/// [`fuse_prepared`] in the caller's `P H^T`: its storage becomes `W`
/// (no copy of the `35 x M` block; its contents are garbage afterwards).
pub(crate) fn fuse_prepared_in_place<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    w: &mut SMatrix<f32, DIM, M>,
    s: &SMatrix<f32, M, M>,
    residual: &SVector<f32, M>,
    gate: Option<f32>,
) -> Result<UpdateReport, Reject> {
    let (l, inv_diag) = cholesky(s).ok_or(Reject::Degenerate)?;
    let l = &l;
    // z = L^-1 y: NIS = |z|^2.
    let mut z = residual.data.0[0].map(|v| [v]);
    forward_substitute(l, &inv_diag, &mut z);
    let nis = z.iter().map(|[v]| v * v).sum::<f32>();
    if !nis.is_finite() {
        return Err(Reject::Degenerate);
    }
    if gate.is_some_and(|g| nis > g) {
        return Err(Reject::Gated);
    }
    // W = P H^T L^-T, so that K S K^T = W W^T and K y = W z, with the
    // diagonal of `W W^T` and the correction `dx = W z`: one pass over the
    // rows of `P H^T` ([`whiten_rows`]), skipping the clone's rows when
    // they are zero (a decoupled clone).
    let z = z.map(|[v]| v);
    let skip = clone_rows_zero(w);
    let mut dx = ErrorState::zeros();
    // Refuse an update that would leave a non-positive (or non-finite)
    // variance: the diagonal of `W W^T` against that of `P`.
    if !whiten_rows(l, &inv_diag, &z, w, p, &mut dx.data.0[0], skip) {
        return Err(Reject::Degenerate);
    }
    // `P - W W^T`, then the reset `G P G^T` where it matters (see
    // [`reset_needed`]), both on the upper triangle (Cortex-M's downdate
    // writes the lower one too; the mirror overwrites it); the mirror makes
    // `P` exactly symmetric. Without a reset, Cortex-M writes both triangles
    // in the downdate itself (the same bits, no mirror).
    if reset_needed(&dx) {
        downdate_upper_with(p, w, skip);
        reset_upper(p, &dx);
        mirror_upper_to_lower(p);
    } else {
        downdate_symmetric_with(p, w, skip);
    }
    x.inject(&dx);
    Ok(UpdateReport { nis })
}

/// Copies the upper triangle of `p` onto the lower one.
///
/// In 4x4 blocks: each block above the diagonal is loaded by its four
/// column pieces (contiguous), transposed in registers and stored as the
/// four column pieces of its mirror image; a diagonal block by the same
/// transpose, keeping its upper half; the last three columns (35 = 8 x 4 +
/// 3) four rows at a time. The strided entry-by-entry copy cost about
/// twice as many instructions (callgrind, `examples/ekf_steps`).
pub fn mirror_upper_to_lower(p: &mut Covariance) {
    mirror_leading(p, DIM);
}

/// [`mirror_upper_to_lower`] on the leading `n x n` block only (`n <= DIM`;
/// the rest is left as it is): the columns past the block's last whole
/// 4x4 block entry by entry, unless `n = DIM`.
fn mirror_leading(p: &mut Covariance, n: usize) {
    const QUADS: usize = DIM / 4;
    if n < DIM {
        let first = 4 * (n / 4);
        let cols = &mut p.data.0;
        for j in first..n {
            let Some((left, [col, ..])) = cols.split_at_mut_checked(j) else {
                continue;
            };
            // Entry (i, j) above the diagonal, in column j, to (j, i).
            for (dst, &v) in left.iter_mut().zip(col.iter()) {
                if let Some(d) = dst.get_mut(j) {
                    *d = v;
                }
            }
        }
    }
    let (quads, last) = p.data.0.as_chunks_mut::<4>();
    for bj in 0..quads.len().min(n / 4) {
        let Some((left, right)) = quads.split_at_mut_checked(bj) else {
            continue;
        };
        let Some(src) = right.first_mut() else {
            continue;
        };
        // Blocks (bi, bj) above the diagonal to (bj, bi).
        let [c0, c1, c2, c3] = src.each_ref().map(|c| c.as_chunks::<4>().0);
        for ((((dst, b0), b1), b2), b3) in left.iter_mut().zip(c0).zip(c1).zip(c2).zip(c3) {
            let t = transpose4([*b0, *b1, *b2, *b3]);
            for (d, piece) in dst.iter_mut().zip(t) {
                if let Some(x) = d.as_chunks_mut::<4>().0.get_mut(bj) {
                    *x = piece;
                }
            }
        }
        // The diagonal block: below its diagonal from above it.
        let a = src
            .each_ref()
            .map(|c| c.as_chunks::<4>().0.get(bj).copied());
        if let [Some(a0), Some(a1), Some(a2), Some(a3)] = a {
            let a = [a0, a1, a2, a3];
            let t = transpose4(a);
            for (r, (d, (mut own, mirrored))) in
                src.iter_mut().zip(a.into_iter().zip(t)).enumerate()
            {
                for (c, (o, m)) in own.iter_mut().zip(mirrored).enumerate() {
                    if c > r {
                        *o = m;
                    }
                }
                if let Some(x) = d.as_chunks_mut::<4>().0.get_mut(bj) {
                    *x = own;
                }
            }
        }
    }
    // The last columns' rows above the diagonal go to the last rows of the
    // columns on their left, four rows (one column quad) at a time.
    const _: () = assert!(DIM - 4 * QUADS == 3);
    if let ([l0, l1, l2], true) = (last, n == DIM) {
        let blocks = l0.as_chunks::<4>().0.iter();
        let blocks = blocks.zip(l1.as_chunks::<4>().0).zip(l2.as_chunks::<4>().0);
        for (dst, ((b0, b1), b2)) in quads.iter_mut().zip(blocks) {
            for (m, d) in dst.iter_mut().enumerate() {
                let pick = |b: &[f32; 4]| b.get(m).copied().unwrap_or(0.0);
                if let Some(tail) = d.as_chunks_mut::<4>().1.first_chunk_mut::<3>() {
                    *tail = [pick(b0), pick(b1), pick(b2)];
                }
            }
        }
        // The corner: below its diagonal from above it.
        let first = 4 * QUADS;
        if let (Some(v10), Some(v20), Some(v21)) = (
            l1.get(first).copied(),
            l2.get(first).copied(),
            l2.get(first + 1).copied(),
        ) {
            if let Some([_, d1, d2]) = l0.get_mut(first..).and_then(|s| s.first_chunk_mut::<3>()) {
                (*d1, *d2) = (v10, v20);
            }
            if let Some(d) = l1.get_mut(first + 2) {
                *d = v21;
            }
        }
    }
}

/// The transpose of a 4x4 block given by its columns: on hosts with SSE in
/// eight shuffles ([`wide::f32x4::transpose`]; written out entry by entry,
/// the compiler moved every entry on its own: two scalar moves each).
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn transpose4(a: [[f32; 4]; 4]) -> [[f32; 4]; 4] {
    wide::f32x4::transpose(a.map(wide::f32x4::new)).map(|v| v.to_array())
}

/// The transpose of a 4x4 block given by its columns.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn transpose4(a: [[f32; 4]; 4]) -> [[f32; 4]; 4] {
    let [
        [a00, a10, a20, a30],
        [a01, a11, a21, a31],
        [a02, a12, a22, a32],
        [a03, a13, a23, a33],
    ] = a;
    [
        [a00, a01, a02, a03],
        [a10, a11, a12, a13],
        [a20, a21, a22, a23],
        [a30, a31, a32, a33],
    ]
}

/// The Cholesky factor `L` (lower triangle; `S = L L^T`) of the symmetric
/// part `(S + S^T) / 2` of `s`, and the inverses of its diagonal; `None`
/// unless positive definite. Column by column (Cholesky-Banachiewicz).
fn cholesky<const M: usize>(s: &SMatrix<f32, M, M>) -> Option<(SMatrix<f32, M, M>, [f32; M])> {
    let mut l = SMatrix::<f32, M, M>::zeros();
    let mut inv_diag = [0.0f32; M];
    let sym = |r: usize, c: usize| -> f32 {
        let a = s.data.0.get(c).and_then(|col| col.get(r)).copied();
        let b = s.data.0.get(r).and_then(|col| col.get(c)).copied();
        0.5 * (a.unwrap_or(f32::NAN) + b.unwrap_or(f32::NAN))
    };
    for c in 0..M {
        let (done, rest) = l.data.0.split_at_mut_checked(c)?;
        let col = rest.first_mut()?;
        // Row c of the columns already done: L[c, k] for k < c.
        let row_c = |k: &[f32; M]| k.get(c).copied().unwrap_or(0.0);
        let d = sym(c, c) - done.iter().map(|k| row_c(k) * row_c(k)).sum::<f32>();
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let diag = libm::sqrtf(d);
        let inv = 1.0 / diag;
        *inv_diag.get_mut(c)? = inv;
        for (r, v) in col.iter_mut().enumerate().skip(c) {
            *v = if r == c {
                diag
            } else {
                let dot = done
                    .iter()
                    .map(|k| k.get(r).copied().unwrap_or(0.0) * row_c(k))
                    .sum::<f32>();
                (sym(r, c) - dot) * inv
            };
        }
    }
    Some((l, inv_diag))
}

/// Solves `L V = B` in place (`B` becomes `V`) for the lower-triangular
/// `L` (upper part ignored), given the inverses of its diagonal, where `B`
/// is given by its `M` rows of `N` entries each: row `k` is scaled, then
/// subtracted from the rows below it (whole rows at a time, so the loops
/// vectorise over `N`).
#[inline(always)]
fn forward_substitute<const M: usize, const N: usize>(
    l: &SMatrix<f32, M, M>,
    inv_diag: &[f32; M],
    b: &mut [[f32; N]; M],
) {
    for (k, (l_col, inv)) in l.data.0.iter().zip(inv_diag).enumerate() {
        let Some((head, below)) = b.split_at_mut_checked(k + 1) else {
            continue;
        };
        let Some(row_k) = head.last_mut() else {
            continue;
        };
        for v in row_k.iter_mut() {
            *v *= inv;
        }
        for (row_r, l_rk) in below.iter_mut().zip(l_col.iter().skip(k + 1)) {
            for (v, vk) in row_r.iter_mut().zip(row_k.iter()) {
                *v -= l_rk * vk;
            }
        }
    }
}

/// Row by row, `W = B L^-T` in place of `B = P H^T` (the forward
/// substitution of [`forward_substitute`] applied to each row, the same
/// operations in the same order), with `dx[i] = W[i, ..] . z`; returns
/// whether every variance `P[i, i] - |W[i, ..]|^2` after the update would
/// be positive and finite, and `dx` finite. One pass instead of four over
/// the `35 x M` block. Rows in [`CLONE`] are skipped when `skip_clone`
/// (they are zero and stay so: their correction is zero, their variance
/// unchanged). On hosts four rows at a time ([`Lanes`]: a column's
/// consecutive rows; only the clone's rows past the last whole block are
/// skipped, the others computed as the zeros they are), on Cortex-M one.
fn whiten_rows<const M: usize>(
    l: &SMatrix<f32, M, M>,
    inv_diag: &[f32; M],
    z: &[f32; M],
    w: &mut SMatrix<f32, DIM, M>,
    p: &Covariance,
    dx: &mut [f32; DIM],
    skip_clone: bool,
) -> bool {
    #[cfg(not(target_arch = "arm"))]
    let diag = |i: usize| p.data.0.get(i).and_then(|c| c.get(i)).copied();
    let mut zeros = 0.0f32;
    #[cfg(not(target_arch = "arm"))]
    let (first_single, valid) = {
        // Whole blocks, also over a skipped clone's rows (zeros stay zeros:
        // fewer instructions than taking the rows before the clone's block
        // one by one); the rest row by row below.
        let blocks = DIM / 4;
        // The variances after the update as their lane-wise minimum (all
        // positive when it is), their finiteness and the corrections' as
        // their sum times zero (zero while they are all finite; an infinite
        // or NaN value makes it NaN): three vector operations a block, not
        // two comparisons a lane (681 fewer instructions in the wheel step,
        // callgrind).
        let mut lowest = Lanes::<4>::from(f32::MAX);
        let mut lane_zeros = Lanes::<4>::from(0.0);
        for at in (0..blocks).map(|k| 4 * k) {
            let b = w.data.0.each_ref().map(|c| Lanes::<4>::load(c, at));
            let (v, red, d) = whiten(l, inv_diag, z, b);
            for (c, lanes) in w.data.0.iter_mut().zip(v) {
                lanes.store(c, at);
            }
            d.store(dx, at);
            let before = Lanes::<4>(core::array::from_fn(|t| diag(at + t).unwrap_or(0.0)));
            let after = before - red;
            lowest = lowest.min(after);
            lane_zeros = lane_zeros + (d * Lanes::from(0.0) + after * Lanes::from(0.0));
        }
        let valid = lowest.0.iter().fold(true, |all, &a| all & (a > 0.0))
            & lane_zeros.0.iter().fold(true, |all, &a| all & (a == 0.0));
        (4 * blocks, valid)
    };
    #[cfg(target_arch = "arm")]
    let (first_single, valid) = (0, true);
    // The variances checked as one running maximum of their codes (see
    // [`variance_code`]: about 5 instructions a row on Cortex-M, against
    // about 19 for the two float comparisons), the corrections' finiteness
    // as their sum times zero.
    let mut worst = 0u32;
    let singles = p.data.0.iter().zip(dx.iter_mut()).enumerate();
    for (i, (col, x)) in singles.skip(first_single) {
        let before = col.get(i).copied().unwrap_or(0.0);
        if skip_clone && CLONE.contains(&i) {
            worst = worst.max(variance_code(before));
            continue;
        }
        let (v, red, d) = whiten(l, inv_diag, z, row_of(w, i));
        for (c, value) in w.data.0.iter_mut().zip(v) {
            if let Some(e) = c.get_mut(i) {
                *e = value;
            }
        }
        *x = d;
        worst = worst.max(variance_code(before - red));
        zeros += d * 0.0;
    }
    // Finite corrections: `d * 0` is NaN for an infinite or NaN `d`.
    valid & (worst < VARIANCE_CODE_LIMIT) & (zeros == 0.0)
}

/// A code of `v` below [`VARIANCE_CODE_LIMIT`] exactly when `v` is
/// positive and finite (`v > 0 && v < inf`): its bits minus one, wrapping.
/// The positive finite values are the bit patterns `0x0000_0001` (the
/// smallest subnormal) to `0x7F7F_FFFF` (`f32::MAX`); zero wraps to
/// `u32::MAX`, `+inf` and NaNs lie above, negative values (sign bit) far
/// above.
#[inline(always)]
fn variance_code(v: f32) -> u32 {
    v.to_bits().wrapping_sub(1)
}

/// See [`variance_code`].
const VARIANCE_CODE_LIMIT: u32 = 0x7F7F_FFFF;

/// One row (or block of rows) `b` of [`whiten_rows`]: `b L^-T`, its
/// squared norm and its product with `z`.
#[inline(always)]
fn whiten<T: Lane, const M: usize>(
    l: &SMatrix<f32, M, M>,
    inv_diag: &[f32; M],
    z: &[f32; M],
    mut b: [T; M],
) -> ([T; M], T, T) {
    for (k, (l_col, &inv)) in l.data.0.iter().zip(inv_diag).enumerate() {
        let Some((head, below)) = b.split_at_mut_checked(k + 1) else {
            continue;
        };
        let Some(vk) = head.last_mut() else {
            continue;
        };
        *vk = *vk * T::from(inv);
        for (v, &l_rk) in below.iter_mut().zip(l_col.iter().skip(k + 1)) {
            *v = *v - T::from(l_rk) * *vk;
        }
    }
    let zero = T::from(0.0);
    let red = b.iter().fold(zero, |acc, &v| acc + v * v);
    let d = b
        .iter()
        .zip(z)
        .fold(zero, |acc, (&v, &zr)| acc + T::from(zr) * v);
    (b, red, d)
}

/// `P <- P - W W^T` on every entry, column by column: entry `(i, j)` is
/// `P[i, j] - W[i, 0] W[j, 0] - W[i, 1] W[j, 1] - ...` in that order, so
/// the result is exactly symmetric if `P` was, and bit for bit equal to
/// [`downdate_upper`] followed by [`mirror_upper_to_lower`] (which the
/// update uses: half the products; measured cheaper on the host too, with
/// the reset done on the triangle before the mirror).
pub fn downdate<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>) {
    for (j, col) in p.data.0.iter_mut().enumerate() {
        let wj = row_of(w, j);
        for (i, pij) in col.iter_mut().enumerate() {
            *pij = entry_minus(*pij, w, i, &wj);
        }
    }
}

/// `P <- P - W W^T` on the upper triangle of `P` (row <= column): every
/// entry is `P[i, j] - W[i, 0] W[j, 0] - W[i, 1] W[j, 1] - ...` in that
/// order, as in [`downdate`] (so that with [`mirror_upper_to_lower`] the
/// two agree bit for bit, and the host with the firmware). On hosts with
/// vector units each column's rows are taken in blocks of four (rounded up
/// past the diagonal: the few lower-triangle entries this also updates are
/// overwritten by the mirror), in a loop (not unrolled: see below);
/// on Cortex-M (`target_arch = "arm"`, scalar) four columns at a time, so
/// that their rows of `W` stay in registers and each row of `W` is loaded
/// once per four entries, and the lower triangle written too (the
/// symmetric downdate's code: one copy in flash).
pub fn downdate_upper<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>) {
    downdate_upper_with(p, w, clone_rows_zero(w));
}

/// [`downdate_upper`] with [`clone_rows_zero`] known: `skip_clone` must
/// equal `clone_rows_zero(w)`.
fn downdate_upper_with<const M: usize>(
    p: &mut Covariance,
    w: &SMatrix<f32, DIM, M>,
    skip_clone: bool,
) {
    #[cfg(not(target_arch = "arm"))]
    {
        // W's rows in blocks of four, block by block: `wb[k][r]` holds
        // rows `4k..4k + 4` of column `r`.
        let wb: [[Lanes<4>; M]; DIM / 4] =
            core::array::from_fn(|k| w.data.0.each_ref().map(|c| Lanes::load(c, 4 * k)));
        // Each column's blocks down to the one holding its diagonal: `j / 4
        // + 1` for column `j`, a loop, not unrolled. Unrolled per quad of
        // columns (session 8) the wheel step took 570 fewer instructions,
        // but the function was 15.3 KB instead of 1.2 KB, and run side by
        // side with the loop on the other core the 3-D update was slower
        // in 22 of 30 rounds (the 4-row wheel update: no difference; see
        // `benches/README.md`, session 9). With W zero on the clone's rows
        // (a decoupled clone), its columns are left as they are: the same
        // bits as subtracting zeros. The clone starts at column 29.
        const _: () = assert!(CLONE.start == 29 && DIM == 35);
        let (quads, last) = p.data.0.as_chunks_mut::<4>();
        let columns = if skip_clone {
            CLONE.start
        } else {
            4 * (DIM / 4)
        };
        for (j, col) in quads
            .as_flattened_mut()
            .iter_mut()
            .enumerate()
            .take(columns)
        {
            downdate_column(col, &wb, row_of(w, j), j / 4 + 1);
        }
        if !skip_clone {
            // The last three columns: eight blocks, then their rows past
            // the last whole block down to the diagonal.
            let first = 4 * (DIM / 4);
            for (t, col) in last.iter_mut().enumerate() {
                let j = first + t;
                let wj = row_of(w, j);
                downdate_column(col, &wb, wj, DIM / 4);
                if let Some(rows) = col.get_mut(first..=j) {
                    for (r, pij) in rows.iter_mut().enumerate() {
                        *pij = entry_minus(*pij, w, first + r, &wj);
                    }
                }
            }
        }
    }
    // Cortex-M: both triangles, the same code as the symmetric downdate
    // (the lower triangle is the mirror's anyway; one copy of the unrolled
    // blocks in flash instead of two).
    #[cfg(target_arch = "arm")]
    downdate_blocked(p, w, skip_clone);
}

/// The first `blocks` blocks of four rows of a column of
/// [`downdate_upper`], given `W` in blocks (`wb`) and the column's row of
/// `W` (`wj`).
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn downdate_column<const M: usize>(
    col: &mut [f32; DIM],
    wb: &[[Lanes<4>; M]; DIM / 4],
    wj: [f32; M],
    blocks: usize,
) {
    for (block, wk) in col.as_chunks_mut::<4>().0.iter_mut().zip(wb).take(blocks) {
        let mut v = Lanes(*block);
        for (w_r, a) in wk.iter().zip(wj) {
            v = v - *w_r * Lanes::from(a);
        }
        *block = v.0;
    }
}

/// `P <- P - W W^T` on both triangles, bit for bit [`downdate_upper`]
/// followed by [`mirror_upper_to_lower`]: on hosts exactly that; on
/// Cortex-M the four-column pass also stores each entry above the diagonal
/// into its mirror image (contiguous in the column of its row), so no
/// separate mirror pass runs.
pub fn downdate_symmetric<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>) {
    downdate_symmetric_with(p, w, clone_rows_zero(w));
}

/// [`downdate_symmetric`] with [`clone_rows_zero`] known: `skip_clone`
/// must equal `clone_rows_zero(w)`.
fn downdate_symmetric_with<const M: usize>(
    p: &mut Covariance,
    w: &SMatrix<f32, DIM, M>,
    skip_clone: bool,
) {
    #[cfg(not(target_arch = "arm"))]
    {
        downdate_upper_with(p, w, skip_clone);
        // A decoupled clone's rows and columns were left as they were
        // (symmetric): only the states before it need the mirror.
        mirror_leading(p, if skip_clone { CLONE.start } else { DIM });
    }
    #[cfg(target_arch = "arm")]
    downdate_blocked(p, w, skip_clone);
}

/// The Cortex-M downdate, four columns `j..j + 4` at a time
/// ([`downdate_block`]), then the columns left over (35 = 8 x 4 + 3;
/// 29 = 7 x 4 + 1) over all the rows taking part ([`downdate_tail`]).
/// With `skip` (a decoupled clone), only the states before the clone: the
/// first `CLONE.start` rows and columns (the clone is the last block of
/// the state). Both triangles are written: each entry above the diagonal
/// also at its mirror image. Every block's columns are constants, so its
/// rows of `W` and its addresses need no checks: with the column start a
/// run-time value the wheel update took 1,720 more instructions
/// (`firmware/profile --annotate`: about 289 per block for its setup and
/// diagonal rows, much of it checks and address arithmetic). The price is
/// flash: 7 to 16 KB per `M`.
#[cfg(target_arch = "arm")]
#[inline(never)]
fn downdate_blocked<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>, skip: bool) {
    // With W zero on the clone's rows (a decoupled clone: `skip`), the
    // clone's rows and columns are left as they are: the same bits as
    // subtracting zeros.
    let cols = &mut p.data.0;
    downdate_block::<0, M>(cols, w);
    downdate_block::<4, M>(cols, w);
    downdate_block::<8, M>(cols, w);
    downdate_block::<12, M>(cols, w);
    downdate_block::<16, M>(cols, w);
    downdate_block::<20, M>(cols, w);
    downdate_block::<24, M>(cols, w);
    if skip {
        downdate_tail::<28, { CLONE.start }, M>(cols, w);
    } else {
        downdate_block::<28, M>(cols, w);
        downdate_tail::<32, DIM, M>(cols, w);
    }
}

// The blocks above: seven of four columns up to the clone, which starts
// in the eighth, and the last columns; the clone is the state's last block.
const _: () = assert!(CLONE.start == 29 && DIM == 35);

/// Columns `J..J + 4` of the Cortex-M downdate: the rows `0..J` above the
/// block (each entry also stored at its mirror image `(J.., i)`,
/// contiguous in the column of its row), then the diagonal
/// block's four rows whole (its lower entries are the same products as its
/// upper ones, so equal bit for bit).
#[cfg(target_arch = "arm")]
#[inline(always)]
fn downdate_block<const J: usize, const M: usize>(
    cols: &mut [[f32; DIM]; DIM],
    w: &SMatrix<f32, DIM, M>,
) {
    let Some((left, [c0, c1, c2, c3, ..])) = cols.split_at_mut_checked(J) else {
        return;
    };
    let a = [
        row_of(w, J),
        row_of(w, J + 1),
        row_of(w, J + 2),
        row_of(w, J + 3),
    ];
    let rows = c0.iter_mut().zip(c1.iter_mut()).zip(c2.iter_mut());
    let mut rows = rows.zip(c3.iter_mut()).enumerate();
    // Above the block, with the mirror (`left` first: the zip stops on it
    // without taking a row).
    for (mirror, (i, (((p0, p1), p2), p3))) in left.iter_mut().zip(rows.by_ref()) {
        let v = block_entries(w, i, &a, [*p0, *p1, *p2, *p3]);
        [*p0, *p1, *p2, *p3] = v;
        if let Some(dst) = mirror.get_mut(J..J + 4) {
            dst.copy_from_slice(&v);
        }
    }
    // The diagonal block.
    for (i, (((p0, p1), p2), p3)) in rows.take(4) {
        [*p0, *p1, *p2, *p3] = block_entries(w, i, &a, [*p0, *p1, *p2, *p3]);
    }
}

/// Columns `J..N` (fewer than four) of the Cortex-M downdate over the rows
/// `0..N`, each entry above the diagonal also stored at its mirror image.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn downdate_tail<const J: usize, const N: usize, const M: usize>(
    cols: &mut [[f32; DIM]; DIM],
    w: &SMatrix<f32, DIM, M>,
) {
    let Some((left, right)) = cols.get_mut(..N).and_then(|c| c.split_at_mut_checked(J)) else {
        return;
    };
    for (c, col) in right.iter_mut().enumerate() {
        let jc = J + c;
        let wj = row_of(w, jc);
        let mut entries = col.iter_mut().enumerate().take(N);
        for (mirror, (i, pij)) in left.iter_mut().zip(entries.by_ref()) {
            let v = entry_minus(*pij, w, i, &wj);
            *pij = v;
            if let Some(dst) = mirror.get_mut(jc) {
                *dst = v;
            }
        }
        for (i, pij) in entries {
            *pij = entry_minus(*pij, w, i, &wj);
        }
    }
}

/// Entries `(i, j..j + 4)` of `P - W W^T` from their values `v` and the
/// rows `a` of `W` of the four columns: `v - W[i, 0] a[..][0] - ...`, in
/// that order (as [`entry_minus`]).
#[cfg(target_arch = "arm")]
#[inline(always)]
fn block_entries<const M: usize>(
    w: &SMatrix<f32, DIM, M>,
    i: usize,
    a: &[[f32; M]; 4],
    mut v: [f32; 4],
) -> [f32; 4] {
    let [a0, a1, a2, a3] = a;
    for (r, wir) in row_of(w, i).iter().enumerate() {
        let at = |a: &[f32; M]| a.get(r).copied().unwrap_or(0.0);
        v = mul_sub4(v, [at(a0), at(a1), at(a2), at(a3)], *wir);
    }
    v
}

/// The error-state rows of the pose clone: the last ones.
pub(crate) const CLONE: core::ops::Range<usize> = CP..CTH + 3;
const _: () = assert!(CTH == CP + 3 && CLONE.end == DIM);

/// Whether `W` is exactly zero on the clone's rows: then `P - W W^T`
/// leaves the clone's rows and columns as they are (this is so while the
/// filter keeps the clone decoupled, see
/// [`crate::covariance::decouple_clone`]: its cross terms are zero and no
/// measurement Jacobian has clone columns).
fn clone_rows_zero<const M: usize>(w: &SMatrix<f32, DIM, M>) -> bool {
    // The bits of every entry but the sign, or-ed: zero exactly when every
    // entry is `+0.0` or `-0.0` (an integer test, cheaper than comparing
    // floats on Cortex-M).
    let bits = w.data.0.iter().fold(0u32, |acc, col| {
        let rows = col.get(CLONE).unwrap_or(&[]);
        rows.iter().fold(acc, |a, v| a | (v.to_bits() << 1))
    });
    bits == 0
}

/// Row `i` of `W`.
#[inline(always)]
fn row_of<const M: usize>(w: &SMatrix<f32, DIM, M>, i: usize) -> [f32; M] {
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
fn entry_minus<const M: usize>(p: f32, w: &SMatrix<f32, DIM, M>, i: usize, wj: &[f32; M]) -> f32 {
    let mut v = p;
    for (w_r, a) in w.data.0.iter().zip(wj) {
        v -= w_r.get(i).copied().unwrap_or(0.0) * a;
    }
    v
}

/// `acc - v a`, lane by lane.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn mul_sub4(acc: [f32; 4], v: [f32; 4], a: f32) -> [f32; 4] {
    let ([s0, s1, s2, s3], [v0, v1, v2, v3]) = (acc, v);
    [s0 - v0 * a, s1 - v1 * a, s2 - v2 * a, s3 - v3 * a]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded xorshift in [-1, 1).
    fn rng(seed: u32) -> impl FnMut() -> f32 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s as f32 / u32::MAX as f32) * 2.0 - 1.0
        }
    }

    /// The four passes `whiten_rows` replaces: the forward substitution
    /// over whole columns, the squared norms, `W z`, and the variance check.
    fn four_passes<const M: usize>(
        l: &SMatrix<f32, M, M>,
        inv_diag: &[f32; M],
        z: &[f32; M],
        w: &mut SMatrix<f32, DIM, M>,
        p: &Covariance,
    ) -> ([f32; DIM], bool) {
        forward_substitute(l, inv_diag, &mut w.data.0);
        let mut reduction = [0.0f32; DIM];
        for w_r in w.data.0.iter() {
            for (red, v) in reduction.iter_mut().zip(w_r) {
                *red += v * v;
            }
        }
        let mut dx = [0.0f32; DIM];
        for (w_r, zr) in w.data.0.iter().zip(z) {
            axpy(&mut dx, *zr, w_r);
        }
        let mut valid = true;
        for (i, red) in reduction.iter().enumerate() {
            let after = p[(i, i)] - red;
            valid &= (after > 0.0) & (after < f32::INFINITY);
        }
        (dx, valid && all_finite(&dx))
    }

    fn whitening_matches<const M: usize>(seed: u32, zero_clone: bool) -> bool {
        let mut r = rng(seed);
        let a = SMatrix::<f32, M, M>::from_fn(|_, _| r());
        let s = a * a.transpose() + SMatrix::<f32, M, M>::identity() * 0.1;
        let (l, inv_diag) = cholesky(&s).unwrap();
        let mut z: [f32; M] = core::array::from_fn(|_| r());
        if seed.is_multiple_of(7) {
            // A non-finite correction.
            z[M - 1] = f32::INFINITY;
        }
        let mut b = SMatrix::<f32, DIM, M>::from_fn(|_, _| r() * 3.0);
        if zero_clone {
            for col in b.data.0.iter_mut() {
                col[CLONE].fill(0.0);
            }
        }
        // Variances twice the reductions (valid), except for one row just
        // below its reduction now and then, or a zero variance in the
        // clone (invalid).
        let mut reduction = b;
        forward_substitute(&l, &inv_diag, &mut reduction.data.0);
        let mut p = Covariance::zeros();
        for i in 0..DIM {
            let red: f32 = reduction.row(i).iter().map(|v| v * v).sum();
            p[(i, i)] = 2.0 * red + 1e-3;
        }
        // The row outside the clone spreads over the host's four-row
        // blocks; the clone's row is in one of them or, every other time,
        // one of the single last rows.
        let k = (seed as usize * 11) % CLONE.start;
        if seed.is_multiple_of(3) {
            let red: f32 = reduction.row(k).iter().map(|v| v * v).sum();
            p[(k, k)] = 0.9 * red;
        }
        // A variance that is not finite: infinite or NaN.
        if seed.is_multiple_of(11) {
            p[(k, k)] = f32::INFINITY;
        } else if seed.is_multiple_of(13) {
            p[(k, k)] = f32::NAN;
        }
        if seed.is_multiple_of(5) {
            let c = if seed.is_multiple_of(2) {
                CLONE.end - 1
            } else {
                CLONE.start + 1
            };
            p[(c, c)] = 0.0;
        }
        let mut old = b;
        let (old_dx, old_valid) = four_passes(&l, &inv_diag, &z, &mut old, &p);
        for skip in [false, zero_clone] {
            let mut new = b;
            let mut dx = [0.0f32; DIM];
            let valid = whiten_rows(&l, &inv_diag, &z, &mut new, &p, &mut dx, skip);
            let bits = |v: &[f32]| {
                v.iter()
                    .map(|x| x.to_bits())
                    .collect::<heapless::Vec<u32, 140>>()
            };
            assert_eq!(
                bits(new.as_slice()),
                bits(old.as_slice()),
                "W, seed {seed}, skip {skip}"
            );
            // (A non-finite correction differs on skipped rows: zero
            // there, `0 * inf` without the skip; refused either way.)
            if all_finite(&old_dx) {
                assert_eq!(bits(&dx), bits(&old_dx), "dx, seed {seed}, skip {skip}");
            }
            assert_eq!(valid, old_valid, "validity, seed {seed}, skip {skip}");
        }
        old_valid
    }

    #[test]
    fn the_variance_code_is_below_its_limit_exactly_for_positive_finite_values() {
        let ok = |v: f32| (v > 0.0) & (v < f32::INFINITY);
        let special = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            -f32::from_bits(1),
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            1.0,
            -1.0,
        ];
        let swept = (0..=u32::MAX / 65_521).map(|k| f32::from_bits(k.wrapping_mul(65_521)));
        let mut counts = [0usize; 2];
        for v in special.into_iter().chain(swept) {
            let below = variance_code(v) < VARIANCE_CODE_LIMIT;
            assert_eq!(below, ok(v), "{v:e} ({:#010x})", v.to_bits());
            counts[usize::from(below)] += 1;
        }
        assert!(counts[0] > 30_000 && counts[1] > 30_000, "{counts:?}");
    }

    #[test]
    fn whitening_row_by_row_gives_the_bits_of_the_column_passes() {
        let mut valid = [0usize; 2];
        for seed in 1..40 {
            for v in [
                whitening_matches::<1>(seed, false),
                whitening_matches::<2>(seed, seed.is_multiple_of(2)),
                whitening_matches::<3>(seed, seed.is_multiple_of(3)),
                whitening_matches::<4>(seed, !seed.is_multiple_of(2)),
            ] {
                valid[usize::from(v)] += 1;
            }
        }
        // Both outcomes of the variance check occur.
        assert!(valid[0] > 10 && valid[1] > 10, "{valid:?}");
    }
}
