//! Fixtures shared by the gap bridges' unit tests.

use crate::covariance::symmetrize;
use crate::state::Covariance;

/// A seeded random symmetric positive definite covariance with a mix of
/// scales (a linear congruential generator: no dependency).
pub fn random_covariance(seed: u32) -> Covariance {
    let mut s = seed;
    let mut a = Covariance::zeros();
    for v in a.iter_mut() {
        s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *v = (s >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
    }
    let mut p = a * a.transpose() * 1e-4 + Covariance::identity() * 1e-6;
    symmetrize(&mut p);
    p
}

/// Whether `p` is positive definite: Cholesky of its correlation matrix in
/// `f64`.
pub fn positive_definite(p: &Covariance) -> bool {
    let p64 = p.cast::<f64>();
    let d = p64.diagonal().map(|v| 1.0 / v.sqrt());
    p64.component_mul(&(d * d.transpose())).cholesky().is_some()
}
