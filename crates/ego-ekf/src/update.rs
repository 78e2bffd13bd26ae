//! The shared gated Kalman update of the error-state filter.
//!
//! For a linearised measurement `y = z - h(x_hat) = H dx + n`, `n ~ N(0, R)`
//! (Solà 2017, sec. 6.1-6.3): innovation covariance `S = H P H^T + R`,
//! normalised innovation squared `y^T S^-1 y` tested against a chi-square
//! gate, gain `K = P H^T S^-1`, error estimate `dx = K y` injected into the
//! nominal state, covariance in the symmetric form
//! `P <- P - K S K^T = P - K (P H^T)^T` (equal to the Joseph form for the
//! optimal gain; cheaper, and exactly symmetric after [`symmetrize`]), then
//! the error reset `P <- G P G^T`. An update that would leave a
//! non-positive variance is refused and the state left untouched.

use nalgebra::{SMatrix, SVector};
use vslam_core::Reject;

use crate::covariance::{reset, symmetrize};
use crate::state::{Covariance, DIM, ErrorState, NominalState};

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
        self.residual.iter().all(|v| v.is_finite())
            && self.h.iter().all(|v| v.is_finite())
            && self.noise.iter().all(|v| v.is_finite())
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
    let pht: SMatrix<f32, DIM, M> = *p * m.h.transpose();
    gated_update_with(x, p, m, &pht, gate)
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
    if !m.is_finite() || !pht.iter().all(|v| v.is_finite()) {
        return Err(Reject::NonFinite);
    }
    let mut s = m.h * pht + m.noise;
    s = (s + s.transpose()) * 0.5;
    let chol = nalgebra::Cholesky::new(s).ok_or(Reject::Degenerate)?;
    let s_inv_y = chol.solve(&m.residual);
    let nis = m.residual.dot(&s_inv_y);
    if !nis.is_finite() {
        return Err(Reject::Degenerate);
    }
    if gate.is_some_and(|g| nis > g) {
        return Err(Reject::Gated);
    }
    // K^T = S^-1 (P H^T)^T.
    let kt: SMatrix<f32, M, DIM> = chol.solve(&pht.transpose());
    // Refuse an update that would leave a non-positive variance.
    let reductions = pht.component_mul(&kt.transpose()).column_sum();
    let valid = p
        .diagonal()
        .iter()
        .zip(reductions.iter())
        .all(|(d, r)| (d - r).is_finite() && d - r > 0.0);
    if !valid {
        return Err(Reject::Degenerate);
    }
    let dx: ErrorState = kt.transpose() * m.residual;
    if !dx.iter().all(|v| v.is_finite()) {
        return Err(Reject::Degenerate);
    }
    *p -= pht * kt;
    x.inject(&dx);
    reset(p, &dx);
    symmetrize(p);
    Ok(UpdateReport { nis })
}
