//! Forward substitution with the Cholesky factor `L` of `S`
//! ([`super::cholesky`]): `L^-1 y` for the normalised innovation, and the
//! whitening `W = P H^T L^-T` row by row with the correction `W z` and the
//! variance check of the update (the `M` sequential scalar updates' gains,
//! see [`crate::update::fuse_prepared`]), written over [`DIM`] rows and the
//! clone's rows [`CLONE`] of the state table.

use nalgebra::SMatrix;

use super::lanes::Lane;
#[cfg(not(target_arch = "arm"))]
use super::lanes::Lanes;
use super::row_of;
use crate::state::{CLONE, Covariance, DIM};

/// Solves `L V = B` in place (`B` becomes `V`) for the lower-triangular
/// `L` (upper part ignored), given the inverses of its diagonal, where `B`
/// is given by its `M` rows of `N` entries each: row `k` is scaled, then
/// subtracted from the rows below it (whole rows at a time, so the loops
/// vectorise over `N`).
#[inline(always)]
pub(crate) fn forward_substitute<const M: usize, const N: usize>(
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
/// the `DIM x M` block. Rows in [`CLONE`] are skipped when `skip_clone`
/// (they are zero and stay so: their correction is zero, their variance
/// unchanged). On hosts four rows at a time ([`Lanes`]: a column's
/// consecutive rows; only the clone's rows past the last whole block are
/// skipped, the others computed as the zeros they are), on Cortex-M one.
#[inline]
pub(crate) fn whiten_rows<const M: usize>(
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
#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::cholesky;
    use crate::update::{all_finite, axpy};

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
                    .collect::<heapless::Vec<u32, { 4 * DIM }>>()
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
