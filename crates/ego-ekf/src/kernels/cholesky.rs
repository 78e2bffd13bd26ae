//! The Cholesky factor of a small symmetric positive definite matrix, the
//! innovation covariance `S` of a measurement (Golub and Van Loan, "Matrix
//! Computations", 4th ed., sec. 4.2), with the
//! inverses of its diagonal for the substitutions of [`super::forward`].

use nalgebra::SMatrix;

/// The Cholesky factor `L` (lower triangle; `S = L L^T`) of the symmetric
/// part `(S + S^T) / 2` of `s`, and the inverses of its diagonal; `None`
/// unless positive definite. Column by column.
#[inline]
pub(crate) fn cholesky<const M: usize>(
    s: &SMatrix<f32, M, M>,
) -> Option<(SMatrix<f32, M, M>, [f32; M])> {
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
