//! Dense reference formulas of the update, written as in the textbook
//! (Solà 2017, sec. 6.1-6.3; Bucy and Joseph, *Filtering for Stochastic
//! Processes*, 1968, for the Joseph form): full 36x36 products, no structure
//! exploited. The tests compare the fast [`crate::update`] against these,
//! and the benchmarks time them for comparison; the filter never calls them.
//! (The propagation's dense reference is
//! [`crate::propagate::propagate_covariance_dense`].)

use nalgebra::SMatrix;
use vslam_core::Reject;

use crate::covariance::reset_dense;
use crate::state::{Covariance, DIM, ErrorState, NominalState};
use crate::update::{Measurement, UpdateReport};

/// The gated update with dense matrices: `S = H P H^T + R`,
/// `K = P H^T S^-1`, `dx = K y`, the Joseph form
/// `P <- (I - K H) P (I - K H)^T + K R K^T`, injection, and the reset
/// `P <- G P G^T` as a dense product. Same errors as
/// [`crate::update::gated_update`]; on any error nothing changes.
pub fn gated_update_dense<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &Measurement<M>,
    gate: Option<f32>,
) -> Result<UpdateReport, Reject> {
    if !m.is_finite() {
        return Err(Reject::NonFinite);
    }
    let pht: SMatrix<f32, DIM, M> = *p * m.h.transpose();
    let s = m.h * pht + m.noise;
    let s_inv = s.try_inverse().ok_or(Reject::Degenerate)?;
    let nis = (m.residual.transpose() * s_inv * m.residual).x;
    if !nis.is_finite() || nis < 0.0 {
        return Err(Reject::Degenerate);
    }
    if gate.is_some_and(|g| nis > g) {
        return Err(Reject::Gated);
    }
    let k: SMatrix<f32, DIM, M> = pht * s_inv;
    let ikh = Covariance::identity() - k * m.h;
    let joseph = ikh * *p * ikh.transpose() + k * m.noise * k.transpose();
    let dx: ErrorState = k * m.residual;
    if !dx.iter().all(|v| v.is_finite()) || !joseph.diagonal().iter().all(|d| *d > 0.0) {
        return Err(Reject::Degenerate);
    }
    *p = joseph;
    x.inject(&dx);
    reset_dense(p, &dx);
    Ok(UpdateReport { nis })
}
