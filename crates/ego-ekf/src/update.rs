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
//!   wheel rows touch 20 of the [`DIM`] = 36 columns, the flow rows 18,
//!   the ZUPT rows 15; the wheel computes it from its factored rows, see
//!   [`crate::wheel::model::WheelRows::p_ht`]);
//! - with the Cholesky factor `S = L L^T`, `W = P H^T L^-T` gives
//!   `K S K^T = W W^T`, `dx = W (L^-1 y)` and the NIS `|L^-1 y|^2`: the
//!   sequence of scalar updates row by row, with all their rank-one
//!   downdates in one pass over `P` ([`fuse_prepared`]);
//! - `P <- P - W W^T` in place, no `DIM x DIM` temporary, on the upper triangle
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
use crate::kernels::{
    cholesky, clone_rows_zero, downdate_symmetric_with, downdate_upper_with, forward_substitute,
    whiten_rows,
};
pub use crate::kernels::{downdate, downdate_symmetric, downdate_upper, mirror_upper_to_lower};
use crate::state::{Covariance, DIM, ErrorState, NominalState};

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
pub(crate) fn axpy(y: &mut [f32; DIM], a: f32, x: &[f32; DIM]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

/// Whether every entry is finite (branch-free, so it vectorises).
pub(crate) fn all_finite(values: &[f32]) -> bool {
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

/// [`gated_update`] that also hands back the innovation covariance
/// `S = H P H^T + R` it formed, for the aid's status record (its diagonal,
/// and the NIS of a gated measurement), so the caller does not form `P H^T`
/// or `S` a second time. `S` is `None` when the measurement was refused as
/// non-finite before it was formed. The same bits as [`gated_update`].
pub fn gated_update_reporting<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &Measurement<M>,
    gate: Option<f32>,
) -> (Result<UpdateReport, Reject>, Option<SMatrix<f32, M, M>>) {
    if !m.is_finite() {
        return (Err(Reject::NonFinite), None);
    }
    let support = Support::of(&m.h);
    let pht = support.p_ht(p);
    let s = innovation_covariance(m, &support, &pht);
    (fuse_prepared(x, p, &pht, &s, &m.residual, gate), Some(s))
}

/// `S = H (P H^T) + R` over the support of `H`: column `c` gains
/// `(P H^T)[j, c]` times column `j` of `H`, for each nonzero column `j`.
fn innovation_covariance<const M: usize>(
    m: &Measurement<M>,
    support: &Support<'_, M>,
    pht: &SMatrix<f32, DIM, M>,
) -> SMatrix<f32, M, M> {
    let mut s = m.noise;
    for (j, h) in support.iter() {
        for (s_col, pht_col) in s.data.0.iter_mut().zip(pht.data.0.iter()) {
            let v = pht_col.get(j).copied().unwrap_or(0.0);
            for (sv, hv) in s_col.iter_mut().zip(h) {
                *sv += v * hv;
            }
        }
    }
    s
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
    let s = innovation_covariance(m, support, pht);
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
/// `DIM x M` block `P H^T` (by forward substitution), never `P` itself until
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
/// (no copy of the `DIM x M` block; its contents are garbage afterwards).
pub(crate) fn fuse_prepared_in_place<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    w: &mut SMatrix<f32, DIM, M>,
    s: &SMatrix<f32, M, M>,
    residual: &SVector<f32, M>,
    gate: Option<f32>,
) -> Result<UpdateReport, Reject> {
    fuse_prepared_holding(x, p, w, s, residual, gate, &[])
}

/// [`fuse_prepared_in_place`] with the error-state entries `hold` treated
/// as Schmidt consider parameters (Schmidt 1966; Simon, *Optimal State
/// Estimation*, 2006, sec. 7.5): their gain is zero, so their value and
/// their own covariance block stay as they were, while the other states'
/// update and their cross-covariance with the held ones are those of the
/// full update (with `K_c = 0`, the Joseph form gives `P_ss - W_s W_s^T`
/// and `P_sc - W_s W_c^T`, the full update's blocks, and `P_cc`
/// unchanged). The measurement's variance still includes the held states'
/// uncertainty. With `hold` empty this is [`fuse_prepared_in_place`].
pub(crate) fn fuse_prepared_holding<const M: usize, const H: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    w: &mut SMatrix<f32, DIM, M>,
    s: &SMatrix<f32, M, M>,
    residual: &SVector<f32, M>,
    gate: Option<f32>,
    hold: &[usize; H],
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
    // The held states' own block, restored after the downdate (the reset
    // `G P G^T` does not touch it: `G` is the identity outside attitude).
    let held: [[f32; H]; H] = hold.map(|a| hold.map(|b| p.get((a, b)).copied().unwrap_or(0.0)));
    for &a in hold {
        if let Some(v) = dx.get_mut(a) {
            *v = 0.0;
        }
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
    for (&a, row) in hold.iter().zip(held.iter()) {
        for (&b, v) in hold.iter().zip(row.iter()) {
            if let Some(e) = p.get_mut((a, b)) {
                *e = *v;
            }
        }
    }
    x.inject(&dx);
    Ok(UpdateReport { nis })
}
