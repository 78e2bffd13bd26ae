//! Covariance bookkeeping shared by propagation and updates: symmetry, the
//! error-reset Jacobian (Solà 2017, sec. 6.3), the pose clone, and the
//! positive-definiteness check used in debug builds and tests.

use nalgebra::Matrix3;

use crate::state::{CP, CTH, Covariance, ErrorState, P, RB, TH};

/// Makes `p` exactly symmetric by averaging it with its transpose.
pub fn symmetrize(p: &mut Covariance) {
    *p = (*p + p.transpose()) * 0.5;
}

/// Skew-symmetric (cross-product) matrix `[v]x`.
pub fn skew(v: &nalgebra::Vector3<f32>) -> Matrix3<f32> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The error reset after an update: `P <- G P G^T` with `G = I` except
/// `I - [dtheta/2]x` on every rotation block (IMU attitude, clone attitude,
/// body-to-robot rotation); Solà 2017, eq. 287.
pub fn reset(p: &mut Covariance, dx: &ErrorState) {
    let blocks = [TH, CTH, RB];
    let gs = blocks.map(|i| Matrix3::identity() - skew(&(dx.fixed_rows::<3>(i) * 0.5)));
    for (i, g) in blocks.iter().zip(gs.iter()) {
        let rows = g * p.fixed_rows::<3>(*i);
        p.fixed_rows_mut::<3>(*i).copy_from(&rows);
    }
    for (i, g) in blocks.iter().zip(gs.iter()) {
        let cols = p.fixed_columns::<3>(*i) * g.transpose();
        p.fixed_columns_mut::<3>(*i).copy_from(&cols);
    }
}

/// Replaces the clone's rows and columns by the current pose's, so that the
/// clone is the pose, plus `copy_var` on the clone's diagonal: the copy is
/// taken as a measurement of the pose with that tiny variance, which keeps
/// `P` positive definite in `f32` (an exact copy makes it singular).
pub fn clone_pose(p: &mut Covariance, copy_var_position: f32, copy_var_attitude: f32) {
    // Columns (contiguous) first, then the rows by symmetry, then the
    // clone-clone block from the pose-pose block.
    let cols_p = p.fixed_columns::<3>(P).into_owned();
    let cols_th = p.fixed_columns::<3>(TH).into_owned();
    p.fixed_columns_mut::<3>(CP).copy_from(&cols_p);
    p.fixed_columns_mut::<3>(CTH).copy_from(&cols_th);
    let rows = p.fixed_columns::<6>(CP).transpose();
    p.fixed_rows_mut::<6>(CP).copy_from(&rows);
    let pp = p.fixed_view::<3, 3>(P, P).into_owned();
    let pt = p.fixed_view::<3, 3>(P, TH).into_owned();
    let tt = p.fixed_view::<3, 3>(TH, TH).into_owned();
    let i3 = Matrix3::<f32>::identity();
    p.fixed_view_mut::<3, 3>(CP, CP)
        .copy_from(&(pp + i3 * copy_var_position));
    p.fixed_view_mut::<3, 3>(CP, CTH).copy_from(&pt);
    p.fixed_view_mut::<3, 3>(CTH, CP).copy_from(&pt.transpose());
    p.fixed_view_mut::<3, 3>(CTH, CTH)
        .copy_from(&(tt + i3 * copy_var_attitude));
}

// The clone's position and attitude are adjacent.
const _: () = assert!(CTH == CP + 3);

/// Whether `p` is finite, symmetric (relative tolerance `1e-5`) and has a
/// positive diagonal: the cheap check run after every step in debug builds.
pub fn looks_valid(p: &Covariance) -> bool {
    if !p.iter().all(|v| v.is_finite()) || !p.diagonal().iter().all(|d| *d > 0.0) {
        return false;
    }
    let s = p.diagonal().map(libm::sqrtf);
    let scale = s * s.transpose();
    let asym = (p - p.transpose()).abs();
    // Asymmetry small against the scale, and no correlation outside [-1, 1]
    // (impossible for a positive semi-definite matrix).
    asym.iter().zip(scale.iter()).all(|(a, s)| *a <= 1e-5 * s)
        && p.iter()
            .zip(scale.iter())
            .all(|(c, s)| libm::fabsf(*c) <= 1.001 * s)
}

/// Whether `p` is symmetric positive definite: a Cholesky factorisation of
/// the diagonally normalised matrix (correlations) exists.
pub fn is_positive_definite(p: &Covariance) -> bool {
    if !looks_valid(p) {
        return false;
    }
    let d = p.diagonal().map(|v| 1.0 / libm::sqrtf(v));
    let c = p.component_mul(&(d * d.transpose()));
    nalgebra::Cholesky::new(c).is_some()
}
