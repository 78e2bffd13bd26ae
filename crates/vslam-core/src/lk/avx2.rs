//! The constant-brightness mismatch sweep written with AVX2 intrinsics (x86-64
//! with `std`, picked at run time by [`Isa`]): the whole window in one
//! function, the interpolated rows and the sums in vector registers.
//!
//! The portable sweep (`template::sweep_rows`) calls one out-of-line row
//! kernel per window row, because the compiler stops vectorising the
//! interpolation when the row loop and the kernel share a function; here the
//! vectors are written out, so the rows need no calls and the interpolated
//! row stays in registers. Each lane runs the portable kernel's operations in
//! its order (`f32` subtraction, multiplication and addition, no FMA), so the
//! sums are the same bits; `the_detected_instruction_set_tracks_as_the_baseline`
//! (`track`) and the tests below compare them.

#![allow(unsafe_code)]

use core::arch::x86_64::{
    __m256, _mm_loadl_epi64, _mm256_add_ps, _mm256_andnot_ps, _mm256_cvtepi32_ps,
    _mm256_cvtepu8_epi32, _mm256_loadu_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps,
    _mm256_storeu_ps, _mm256_sub_ps,
};

use super::isa::Isa;
use super::template::{TPL, TplRow};
use super::window::LANES;

/// The lane sums `[sum d gx, sum d gy, sum |d| m]` (`d = T - J`) of a window
/// of `C` chunks whose `t.len() + 1` source rows start at `data[start..]`,
/// `stride` apart, with the fractions `[ax, ay]`; `None` when `isa` is not
/// AVX2 or the rows do not lie in `data` (the caller's portable sweep then
/// runs).
#[inline]
pub(super) fn plain_sweep<const C: usize, const ABS: bool>(
    isa: Isa,
    (data, start, stride): (&[u8], usize, usize),
    weights: [f32; 2],
    [t, gx, gy]: [&[TplRow]; 3],
    mask: &TplRow,
) -> Option<[[f32; LANES]; 3]> {
    let n = t.len();
    // Every read below: rows 0..=n, each C LANES + 1 bytes from its start.
    let end = stride
        .checked_mul(n)?
        .checked_add(start)?
        .checked_add(C * LANES + 1)?;
    if !isa.avx2() || C * LANES > TPL || gx.len() != n || gy.len() != n || end > data.len() {
        return None;
    }
    let rows = data.get(start..)?.as_ptr();
    // SAFETY: AVX2 is present (`Isa::avx2`); the reads stay inside `data`
    // (checked above: row `i <= n` reads bytes `start + i stride ..
    // start + i stride + C LANES + 1`) and inside the template rows
    // (`C LANES <= TPL`, `n` rows each).
    Some(unsafe { sweep::<C, ABS>(rows, stride, weights, [t, gx, gy], mask) })
}

/// [`plain_sweep`] after its checks.
///
/// # Safety
/// The CPU has AVX2; rows `0..=t.len()` at `rows + i stride` hold
/// `C LANES + 1` readable bytes each; `C LANES <= TPL`; `gx`, `gy` have
/// `t.len()` rows.
#[target_feature(enable = "avx2")]
unsafe fn sweep<const C: usize, const ABS: bool>(
    rows: *const u8,
    stride: usize,
    [ax, ay]: [f32; 2],
    [t, gx, gy]: [&[TplRow]; 3],
    mask: &TplRow,
) -> [[f32; LANES]; 3] {
    let (vax, vay) = (_mm256_set1_ps(ax), _mm256_set1_ps(ay));
    let sign = _mm256_set1_ps(-0.0);
    let mut h0 = [_mm256_setzero_ps(); C];
    // SAFETY (all blocks): the caller's contract, see `plain_sweep`.
    unsafe { horizontal::<C>(rows, vax, &mut h0) };
    let mut m = [_mm256_setzero_ps(); C];
    for (k, v) in m.iter_mut().enumerate() {
        *v = unsafe { _mm256_loadu_ps(mask.as_ptr().add(k * LANES)) };
    }
    let (mut sx, mut sy, mut sa) = (
        _mm256_setzero_ps(),
        _mm256_setzero_ps(),
        _mm256_setzero_ps(),
    );
    let mut h1 = [_mm256_setzero_ps(); C];
    for (i, ((t, gx), gy)) in t.iter().zip(gx).zip(gy).enumerate() {
        unsafe { horizontal::<C>(rows.add((i + 1) * stride), vax, &mut h1) };
        for (k, ((&a, &b), &m)) in h0.iter().zip(&h1).zip(&m).enumerate() {
            let j = _mm256_add_ps(a, _mm256_mul_ps(vay, _mm256_sub_ps(b, a)));
            let tk = unsafe { _mm256_loadu_ps(t.as_ptr().add(k * LANES)) };
            let d = _mm256_sub_ps(tk, j);
            let gxk = unsafe { _mm256_loadu_ps(gx.as_ptr().add(k * LANES)) };
            let gyk = unsafe { _mm256_loadu_ps(gy.as_ptr().add(k * LANES)) };
            sx = _mm256_add_ps(sx, _mm256_mul_ps(d, gxk));
            sy = _mm256_add_ps(sy, _mm256_mul_ps(d, gyk));
            if ABS {
                sa = _mm256_add_ps(sa, _mm256_mul_ps(_mm256_andnot_ps(sign, d), m));
            }
        }
        h0 = h1;
    }
    let mut out = [[0.0f32; LANES]; 3];
    for (o, v) in out.iter_mut().zip([sx, sy, sa]) {
        unsafe { _mm256_storeu_ps(o.as_mut_ptr(), v) };
    }
    out
}

/// `out[k] = a + ax (b - a)` for the `C LANES` bytes `a` at `row` and `b`
/// one byte on (`window::horizontal`'s arithmetic).
///
/// # Safety
/// AVX2; `C LANES + 1` bytes readable at `row`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn horizontal<const C: usize>(row: *const u8, vax: __m256, out: &mut [__m256; C]) {
    for (k, o) in out.iter_mut().enumerate() {
        // SAFETY: the caller's contract; each load reads 8 bytes ending at
        // most at byte `C LANES` of the row.
        let (a, b) = unsafe {
            (
                _mm_loadl_epi64(row.add(k * LANES).cast()),
                _mm_loadl_epi64(row.add(k * LANES + 1).cast()),
            )
        };
        let a = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(a));
        let b = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(b));
        *o = _mm256_add_ps(a, _mm256_mul_ps(vax, _mm256_sub_ps(b, a)));
    }
}

#[cfg(test)]
mod tests {
    use crate::geometry::Vec2;
    use crate::image::ImageView;
    use crate::lk::isa::Isa;
    use crate::lk::template::{Template, TemplateRows};

    const W: usize = 80;
    const H: usize = 64;

    /// A seeded textured image (smooth waves with noise in the low bits).
    fn image(seed: u32) -> [u8; W * H] {
        let mut state = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
        let mut px = [0u8; W * H];
        for (i, p) in px.iter_mut().enumerate() {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            let smooth = 120.0 + 60.0 * libm::sinf(0.37 * x + 0.21 * y);
            *p = (smooth as u32 ^ (state >> 27)) as u8;
        }
        px
    }

    /// The AVX2 sweep gives the portable row kernels' lane sums bit for bit
    /// for every window size, with and without the absolute sums, at every
    /// subpixel phase, and stands aside (the portable sweep runs) for
    /// windows over the border.
    #[test]
    fn the_avx2_sweep_gives_the_portable_sums_bit_for_bit() {
        let (a, b) = (image(1), image(2));
        let (va, vb) = (
            ImageView::packed(&a, W, H).unwrap(),
            ImageView::packed(&b, W, H).unwrap(),
        );
        let avx2 = Isa::detect().avx2();
        let (mut compared, mut by_avx2) = (0, 0);
        for n in (3..=31).step_by(2) {
            let mut rows = TemplateRows::<31>::zeroed();
            let mut tpl = Template::empty(&mut rows);
            tpl.column_order = false;
            for k in 0..40 {
                let k = k as f32;
                let c = Vec2::new(-2.0 + 2.113 * k, 70.0 - 1.731 * k);
                if tpl.fill(&va, c, n, 0.0, true).is_err() {
                    continue;
                }
                for (dx, dy) in [(0.0, 0.0), (0.37, -0.61), (-1.25, 0.5), (2.999, 1.001)] {
                    let at = Vec2::new(c.x + dx, c.y + dy);
                    for (clamp, abs) in [(false, false), (false, true), (true, false), (true, true)]
                    {
                        tpl.isa = Isa::BASELINE;
                        let portable = tpl.row_sums(&vb, at, clamp, abs);
                        tpl.isa = Isa::detect();
                        let fast = tpl.row_sums(&vb, at, clamp, abs);
                        let bits = |s: [[f32; 8]; 3]| s.map(|l| l.map(f32::to_bits));
                        assert_eq!(portable.map(bits), fast.map(bits), "n {n} at {at:?} {abs}");
                        compared += usize::from(portable.is_some());
                        by_avx2 +=
                            usize::from(avx2 && tpl.avx2_sums(&vb, at, clamp, abs).is_some());
                    }
                }
            }
        }
        assert!(compared > 3000, "{compared}");
        if avx2 {
            assert!(
                by_avx2 > 1000 && by_avx2 < compared,
                "{by_avx2} of {compared}"
            );
        }
    }
}
