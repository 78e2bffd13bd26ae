//! The Cholesky factor of a small symmetric positive definite matrix, the
//! innovation covariance `S` of a measurement (Golub and Van Loan, "Matrix
//! Computations", 4th ed., sec. 4.2), with the
//! inverses of its diagonal for the substitutions of [`super::forward`].
//! The square roots are `vslam_core::fsqrt::sqrtf`: on Cortex-M4F and M7
//! `VSQRT.F32` in five instructions, against about 50 for `libm::sqrtf`,
//! with the same bits.

use nalgebra::SMatrix;

/// The Cholesky factor `L` (lower triangle; `S = L L^T`) of the symmetric
/// part `(S + S^T) / 2` of `s`, and the inverses of its diagonal; `None`
/// unless positive definite. Column by column.
#[inline]
pub(crate) fn cholesky<const M: usize>(
    s: &SMatrix<f32, M, M>,
) -> Option<(SMatrix<f32, M, M>, [f32; M])> {
    // Column-major, `l[k][r]` is `L[r, k]`; indices from loops with
    // constant bounds, so the loops unroll for a small `M`.
    let mut l = [[0.0f32; M]; M];
    let mut inv_diag = [0.0f32; M];
    let sym = |r: usize, c: usize| -> f32 {
        let a = s.data.0.get(c).and_then(|col| col.get(r)).copied();
        let b = s.data.0.get(r).and_then(|col| col.get(c)).copied();
        0.5 * (a.unwrap_or(f32::NAN) + b.unwrap_or(f32::NAN))
    };
    let at = |l: &[[f32; M]; M], r: usize, k: usize| -> f32 {
        l.get(k).and_then(|col| col.get(r)).copied().unwrap_or(0.0)
    };
    for c in 0..M {
        // Row c of the columns already done: L[c, k] for k < c.
        let d = sym(c, c) - (0..c).map(|k| at(&l, c, k) * at(&l, c, k)).sum::<f32>();
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let diag = vslam_core::fsqrt::sqrtf(d);
        let inv = 1.0 / diag;
        *inv_diag.get_mut(c)? = inv;
        *l.get_mut(c)?.get_mut(c)? = diag;
        for r in (c + 1)..M {
            let dot = (0..c).map(|k| at(&l, r, k) * at(&l, c, k)).sum::<f32>();
            *l.get_mut(c)?.get_mut(r)? = (sym(r, c) - dot) * inv;
        }
    }
    Some((SMatrix::from_data(nalgebra::ArrayStorage(l)), inv_diag))
}
