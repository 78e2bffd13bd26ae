//! The tracker's two hottest loops written with AVX2 intrinsics (x86-64 with
//! `std`, picked at run time by [`Isa`]): the template fill ([`fill`]: the
//! patch, its Scharr gradients and `G`) and the constant-brightness sweep
//! ([`plain_sweep`]: `sum (T - J) [gx gy]` and `sum |T - J|`), each a whole
//! window per call with the interpolated rows and the sums in registers.
//!
//! The portable code (`template`) calls one out-of-line row kernel per
//! window row, because the compiler stops vectorising the interpolation when
//! the row loop and the kernel share a function; here the vectors are written
//! out, so the rows need no calls. Each lane runs the portable kernels'
//! operations in their order (`f32` subtraction, multiplication and
//! addition, no FMA; shifting lanes only moves data), and the source rows are
//! read as the portable code reads them ([`Source`]: row 0 through
//! `SourceRows::row`, the others from the image buffer where they lie in it),
//! so every lane the portable code writes gets the same bits, down to the
//! signed zeros of the masked gradient lanes. The tests below compare them
//! for every window size, inside the image and over its border, packed and
//! strided, and `the_detected_instruction_set_tracks_as_the_baseline`
//! (`track`) compares whole tracks.
//!
//! A window over a coarse level's border reads its rows from the level's
//! edge-replicated copy (`borders`) as a window inside reads the image;
//! until that copy is made (the first few such windows of an image in a
//! tracking call), each of its rows is copied with the edge pixels repeated.
//!
//! Cost on the `lk` bench's input (callgrind, 10 tracking calls of
//! `examples/lk_profile`): the fill 3,485 instructions per template inside
//! the image (152 per patch row of a 21x21 window), the sweep 1,209 per pass
//! (55 per row); over the border with the rows copied one by one 5,586 and
//! 2,945.

#![allow(unsafe_code)]

use core::arch::x86_64::{
    __m256, _mm_loadl_epi64, _mm256_add_ps, _mm256_andnot_ps, _mm256_blend_ps, _mm256_cvtepi32_ps,
    _mm256_cvtepu8_epi32, _mm256_loadu_ps, _mm256_mul_ps, _mm256_permutevar8x32_ps, _mm256_set1_ps,
    _mm256_setr_epi32, _mm256_setzero_ps, _mm256_storeu_ps, _mm256_sub_ps,
};

use core::marker::PhantomData;

use crate::image::ImageView;

use super::borders::Borders;
use super::isa::Isa;
use super::template::{TPL, TplRow};
use super::window::{self, LANES, ROW, Row, SRC, SourceRows};

/// Where the source rows of a window are, holding the bytes the portable
/// code reads (so that even the bytes past the window's last column agree):
/// for a window inside the image, row 0 through [`SourceRows::row`] and the
/// others straight from the image buffer where they lie in it; for a window
/// over the border, every row from the image's edge-replicated copy
/// (`borders`) once it is made; else each row through [`SourceRows::row`].
/// Each call gives a pointer to at least `need` readable bytes, valid until
/// the next call.
trait Source {
    /// Row 0.
    fn first(&mut self) -> *const u8;
    /// Row `i >= 1`.
    fn row(&mut self, i: usize) -> *const u8;
}

/// A window whose rows `1..rows` lie one stride apart in a buffer
/// borrowed for `'r`: the image buffer (a window inside the image) or the
/// image's edge-replicated copy (a window over its border): row `i` is `i`
/// strides on from row 0's place there.
struct Strided<'r> {
    /// Row 0 as [`SourceRows::row`] gives it (for a window over the
    /// border, its place in the copy, which holds those bytes).
    row0: *const u8,
    /// Row 0's place in the buffer.
    origin: *const u8,
    stride: usize,
    /// The buffers the pointers point into stay borrowed.
    rows: PhantomData<&'r [u8]>,
}

impl Source for Strided<'_> {
    #[inline(always)]
    fn first(&mut self) -> *const u8 {
        self.row0
    }

    #[inline(always)]
    fn row(&mut self, i: usize) -> *const u8 {
        self.origin.wrapping_add(i.wrapping_mul(self.stride))
    }
}

/// Any other window: each row as the portable code reads it (edge pixels
/// repeated, copied into `buf`, where it does not take the image buffer).
struct Clamped<'r, 'i> {
    image: &'r ImageView<'i>,
    src: &'r SourceRows,
    buf: &'r mut [u8; SRC],
    need: usize,
    /// For a window inside the image: the buffer, row 0's index, the stride.
    inside: Option<(&'i [u8], usize, usize)>,
}

impl Source for Clamped<'_, '_> {
    #[inline(always)]
    fn first(&mut self) -> *const u8 {
        // At least `need` bytes (`need <= SRC`, see `SourceRows::row`).
        self.src.row(self.image, 0, self.need, self.buf).as_ptr()
    }

    #[inline(always)]
    fn row(&mut self, i: usize) -> *const u8 {
        let borrowed = self.inside.and_then(|(data, start, stride)| {
            let at = start.checked_add(i.checked_mul(stride)?)?;
            data.get(at..at.checked_add(self.need)?)
        });
        match borrowed {
            Some(row) => row.as_ptr(),
            None => self.src.row(self.image, i, self.need, self.buf).as_ptr(),
        }
    }
}

/// The [`Source`] of the `rows` source rows of `need` bytes each (`need <=
/// SRC`) that `src` reads from `image`: [`Strided`] where it applies (a
/// window inside the image, or one over its border whose rows lie in the
/// image's edge-replicated copy in `borders`, for windows of side `n`),
/// else [`Clamped`]; `buf` holds the rows that are copied.
#[inline(always)]
fn source<'r, 'i>(
    (image, src, buf, borders): Rows<'r, 'i>,
    n: usize,
    rows: usize,
    need: usize,
) -> Result<Strided<'r>, Clamped<'r, 'i>> {
    let inside = src.inside_rows(image);
    let block = inside.and_then(|(data, start, stride)| {
        let end = stride
            .checked_mul(rows.checked_sub(1)?)?
            .checked_add(start)?
            .checked_add(need)?;
        Some((data.get(start..end)?.as_ptr(), stride))
    });
    if let Some((origin, stride)) = block {
        let row0 = src.row(image, 0, need, buf).as_ptr();
        return Ok(Strided {
            row0,
            origin,
            stride,
            rows: PhantomData,
        });
    }
    if inside.is_none() {
        let margin = Borders::margin(n, window::chunks(n + 2) * LANES + 1);
        if let Some((block, stride)) = borders.block(image, margin, src.origin(), rows, need) {
            // The copy holds row 0's bytes as `SourceRows::row` gives them.
            let origin = block.as_ptr();
            return Ok(Strided {
                row0: origin,
                origin,
                stride,
                rows: PhantomData,
            });
        }
    }
    Err(Clamped {
        image,
        src,
        buf,
        need,
        inside,
    })
}

/// What the kernels read a window from: the image, where the window lies
/// in it, scratch for a copied row and the edge-replicated copies.
pub(super) type Rows<'r, 'i> = (
    &'r ImageView<'i>,
    &'r SourceRows,
    &'r mut [u8; SRC],
    &'r mut Borders,
);

/// The lane sums `[sum d gx, sum d gy, sum |d| m]` (`d = T - J`, `J` the
/// window `src` samples from `image`) of a window of `C` chunks and
/// `t.len()` rows; `None` when `isa` is not AVX2 (the caller's portable
/// sweep then runs). `rows`: the image and the window in it, with scratch
/// for the rows over the border (see [`source`]).
#[inline]
pub(super) fn plain_sweep<const C: usize, const ABS: bool>(
    isa: Isa,
    rows: Rows<'_, '_>,
    [t, gx, gy]: [&[TplRow]; 3],
    mask: &TplRow,
) -> Option<[[f32; LANES]; 3]> {
    let n = t.len();
    let need = C * LANES + 1;
    if !isa.avx2() || C * LANES > TPL || need > SRC || gx.len() != n || gy.len() != n {
        return None;
    }
    let (w, tpl) = ([rows.1.ax, rows.1.ay], [t, gx, gy]);
    // SAFETY: AVX2 is present (`Isa::avx2`); each source gives `need` bytes
    // per row (`source` checked that the strided rows lie in the image
    // buffer or its copy; a borrowed row has `need` bytes; `SourceRows::row`
    // gives at least `need <= SRC`); the template reads stay inside its
    // rows (`C LANES <= TPL`, `n` rows each).
    Some(match source(rows, n, n + 1, need) {
        Ok(rows) => unsafe { sweep::<C, ABS, _>(rows, w, tpl, mask) },
        Err(rows) => unsafe { sweep::<C, ABS, _>(rows, w, tpl, mask) },
    })
}

/// [`plain_sweep`] after its checks.
///
/// # Safety
/// The CPU has AVX2; `rows` gives `C LANES + 1` readable bytes for rows
/// `0..=t.len()`; `C LANES <= TPL`; `gx`, `gy` have `t.len()` rows.
#[target_feature(enable = "avx2")]
unsafe fn sweep<const C: usize, const ABS: bool, S: Source>(
    mut rows: S,
    [ax, ay]: [f32; 2],
    [t, gx, gy]: [&[TplRow]; 3],
    mask: &TplRow,
) -> [[f32; LANES]; 3] {
    let (vax, vay) = (_mm256_set1_ps(ax), _mm256_set1_ps(ay));
    let sign = _mm256_set1_ps(-0.0);
    let mut h0 = [_mm256_setzero_ps(); C];
    // SAFETY (all blocks): the caller's contract, see `plain_sweep`.
    unsafe { horizontal::<C>(rows.first(), vax, &mut h0) };
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
        unsafe { horizontal::<C>(rows.row(i + 1), vax, &mut h1) };
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

/// The template of a window of `C` chunks and `t.len()` rows that `src`
/// samples from `image` (its patch, with the one-pixel frame, `P` chunks):
/// the patch rows through the ring `patch`, the template rows `t`, `gx`,
/// `gy` as `template::gradient_row` writes them, and the lane sums `[gx²,
/// gx gy, gy²]` of `G`; `None` when `isa` is not AVX2 (the caller's
/// portable fill then runs). `rows`: see [`plain_sweep`].
#[inline]
pub(super) fn fill<const P: usize, const C: usize>(
    isa: Isa,
    rows: Rows<'_, '_>,
    patch: &mut [Row; 3],
    [t, gx, gy]: [&mut [TplRow]; 3],
    mask: &TplRow,
) -> Option<[[f32; LANES]; 3]> {
    let n = t.len();
    let need = P * LANES + 1;
    let fits = P * LANES <= ROW && (C + 1) * LANES <= ROW && C * LANES <= TPL && TPL < ROW;
    if !isa.avx2() || !fits || need > SRC || gx.len() != n || gy.len() != n {
        return None;
    }
    let (w, tpl) = ([rows.1.ax, rows.1.ay], [t, gx, gy]);
    // SAFETY: AVX2 is present (`Isa::avx2`); each source gives `need` bytes
    // per row (see `plain_sweep`); the row reads and writes stay inside the
    // patch and template rows (`fits`).
    Some(match source(rows, n, n + 3, need) {
        Ok(rows) => unsafe { fill_rows::<P, C, _>(rows, w, patch, tpl, mask) },
        Err(rows) => unsafe { fill_rows::<P, C, _>(rows, w, patch, tpl, mask) },
    })
}

/// [`fill`] after its checks.
///
/// # Safety
/// The CPU has AVX2; `rows` gives `P LANES + 1` readable bytes for rows
/// `0..=t.len() + 2`; `P LANES <= ROW`, `(C + 1) LANES <= ROW`,
/// `C LANES <= TPL < ROW`; `gx`, `gy` have `t.len()` rows.
#[target_feature(enable = "avx2")]
unsafe fn fill_rows<const P: usize, const C: usize, S: Source>(
    mut rows: S,
    [ax, ay]: [f32; 2],
    patch: &mut [Row; 3],
    [t, gx, gy]: [&mut [TplRow]; 3],
    mask: &TplRow,
) -> [[f32; LANES]; 3] {
    let (vax, vay) = (_mm256_set1_ps(ax), _mm256_set1_ps(ay));
    let (three, ten) = (_mm256_set1_ps(3.0), _mm256_set1_ps(10.0));
    // `m / 32` per column, as `gradient_row` scales the gradients.
    let mut weight = [0.0f32; TPL];
    for (w, &m) in weight.iter_mut().zip(mask) {
        *w = m / 32.0;
    }
    let (mut sxx, mut sxy, mut syy) = (
        _mm256_setzero_ps(),
        _mm256_setzero_ps(),
        _mm256_setzero_ps(),
    );
    let mut h0 = [_mm256_setzero_ps(); P];
    let mut h1 = [_mm256_setzero_ps(); P];
    // SAFETY (all blocks): the caller's contract, see `fill`.
    unsafe { horizontal::<P>(rows.first(), vax, &mut h0) };
    let n = t.len();
    let mut outputs = t.iter_mut().zip(gx.iter_mut()).zip(gy.iter_mut());
    // The patch ring's slots, as `Template::sample` takes them: the oldest,
    // the middle and the newest row.
    let [r0, r1, r2] = patch;
    let (mut a, mut b, mut c) = (r0.as_mut_ptr(), r1.as_mut_ptr(), r2.as_mut_ptr());
    for i in 0..n + 2 {
        unsafe { horizontal::<P>(rows.row(i + 1), vax, &mut h1) };
        // The new patch row goes where the oldest was.
        for (k, (&top, &bottom)) in h0.iter().zip(&h1).enumerate() {
            let v = _mm256_add_ps(top, _mm256_mul_ps(vay, _mm256_sub_ps(bottom, top)));
            unsafe { _mm256_storeu_ps(a.add(k * LANES), v) };
        }
        h0 = h1;
        (a, b, c) = (b, c, a);
        if i < 2 {
            continue;
        }
        let Some(((t, gx), gy)) = outputs.next() else {
            break;
        };
        let (p0, p1, p2) = (a.cast_const(), b.cast_const(), c.cast_const());
        // The template: the centre patch row shifted by one column.
        for k in 0..TPL / LANES {
            let v = unsafe { _mm256_loadu_ps(p1.add(k * LANES + 1)) };
            unsafe { _mm256_storeu_ps(t.as_mut_ptr().add(k * LANES), v) };
        }
        // Separable Scharr as `gradient_row`: smooth [3 10 3] down the
        // columns and difference across (gx), difference down the columns
        // and smooth across (gy); the taps of chunk `k` reach two columns
        // into chunk `k + 1`.
        let (mut s0, mut d0) = unsafe { smooth_diff([p0, p1, p2], 0, three, ten) };
        for k in 0..C {
            let (s_next, d_next) = unsafe { smooth_diff([p0, p1, p2], k + 1, three, ten) };
            let s2 = shift2(s0, s_next);
            let (d1, d2) = (shift1(d0, d_next), shift2(d0, d_next));
            let w = unsafe { _mm256_loadu_ps(weight.as_ptr().add(k * LANES)) };
            let x = _mm256_mul_ps(_mm256_sub_ps(s2, s0), w);
            let y = _mm256_add_ps(
                _mm256_mul_ps(three, _mm256_add_ps(d0, d2)),
                _mm256_mul_ps(ten, d1),
            );
            let y = _mm256_mul_ps(y, w);
            unsafe {
                _mm256_storeu_ps(gx.as_mut_ptr().add(k * LANES), x);
                _mm256_storeu_ps(gy.as_mut_ptr().add(k * LANES), y);
            }
            sxx = _mm256_add_ps(sxx, _mm256_mul_ps(x, x));
            sxy = _mm256_add_ps(sxy, _mm256_mul_ps(x, y));
            syy = _mm256_add_ps(syy, _mm256_mul_ps(y, y));
            (s0, d0) = (s_next, d_next);
        }
    }
    let mut out = [[0.0f32; LANES]; 3];
    for (o, v) in out.iter_mut().zip([sxx, sxy, syy]) {
        unsafe { _mm256_storeu_ps(o.as_mut_ptr(), v) };
    }
    out
}

/// Chunk `k` of the Scharr filter's vertical passes over the patch rows
/// `p`: `3 (p0 + p2) + 10 p1` and `p2 - p0`.
///
/// # Safety
/// AVX2; chunk `k` lies inside each row.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn smooth_diff(
    [p0, p1, p2]: [*const f32; 3],
    k: usize,
    three: __m256,
    ten: __m256,
) -> (__m256, __m256) {
    // SAFETY: the caller's contract.
    let (r0, r1, r2) = unsafe {
        (
            _mm256_loadu_ps(p0.add(k * LANES)),
            _mm256_loadu_ps(p1.add(k * LANES)),
            _mm256_loadu_ps(p2.add(k * LANES)),
        )
    };
    let smooth = _mm256_add_ps(
        _mm256_mul_ps(three, _mm256_add_ps(r0, r2)),
        _mm256_mul_ps(ten, r1),
    );
    (smooth, _mm256_sub_ps(r2, r0))
}

/// Lanes 1..=8 of the 16 lanes `a, b`.
#[target_feature(enable = "avx2")]
#[inline]
fn shift1(a: __m256, b: __m256) -> __m256 {
    let rotate = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 0);
    let (a, b) = (
        _mm256_permutevar8x32_ps(a, rotate),
        _mm256_permutevar8x32_ps(b, rotate),
    );
    _mm256_blend_ps::<0b1000_0000>(a, b)
}

/// Lanes 2..=9 of the 16 lanes `a, b`.
#[target_feature(enable = "avx2")]
#[inline]
fn shift2(a: __m256, b: __m256) -> __m256 {
    let rotate = _mm256_setr_epi32(2, 3, 4, 5, 6, 7, 0, 1);
    let (a, b) = (
        _mm256_permutevar8x32_ps(a, rotate),
        _mm256_permutevar8x32_ps(b, rotate),
    );
    _mm256_blend_ps::<0b1100_0000>(a, b)
}

#[cfg(test)]
mod tests {
    use crate::geometry::Vec2;
    use crate::image::{ImageView, required_len};
    use crate::lk::isa::Isa;
    use crate::lk::template::{Template, TemplateRows};
    use crate::lk::window::{self, SourceRows};

    extern crate std;
    use std::vec::Vec;

    const W: usize = 80;
    const H: usize = 64;
    /// The strided view: narrower than its rows, and its buffer ends where
    /// its last row does (so the windows at the bottom right take rows
    /// through `SourceRows::row`, as the portable code does).
    const SW: usize = 70;
    const STRIDE: usize = 83;

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

    /// The packed view of `px` and a strided view of the same bytes.
    fn views(px: &[u8; W * H]) -> [ImageView<'_>; 2] {
        let rows = (px.len() - SW) / STRIDE + 1;
        let len = required_len(SW, rows, STRIDE).unwrap();
        [
            ImageView::packed(px, W, H).unwrap(),
            ImageView::new(&px[..len], SW, rows, STRIDE).unwrap(),
        ]
    }

    /// Window centres inside, near and over every border of `v`, at
    /// varied subpixel offsets, and the corner pixels (the farthest a
    /// window with its centre inside reaches out).
    fn centres(v: &ImageView<'_>) -> impl Iterator<Item = Vec2> {
        let (w, h) = (v.width() as f32, v.height() as f32);
        let spread = (0..60).map(move |k| {
            let k = k as f32 / 59.0;
            Vec2::new(
                -2.0 + (w + 3.0) * k,
                h + 1.5 - (h + 4.0) * k * 1.07 % (h + 4.0),
            )
        });
        let corners = [
            (0.0, 0.0),
            (w - 1.0, 0.0),
            (0.0, h - 1.0),
            (w - 1.0, h - 1.0),
        ];
        spread.chain(corners.map(|(x, y)| Vec2::new(x, y)))
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|v| v.to_bits()).collect()
    }

    /// A template on the baseline kernels and one on this CPU's, both on the
    /// row kernels' side (no column kernels).
    fn portable_and_fast<'r, const R: usize>(
        a: &'r mut TemplateRows<R>,
        b: &'r mut TemplateRows<R>,
    ) -> (Template<'r>, Template<'r>) {
        let (mut portable, mut fast) = (Template::empty(a), Template::empty(b));
        portable.isa = Isa::BASELINE;
        portable.column_order = false;
        fast.column_order = false;
        (portable, fast)
    }

    /// The two templates' rows agree bit for bit: intensities in every
    /// lane, gradients in the window's chunks. Returns the rows compared.
    fn assert_same_rows(portable: &Template<'_>, fast: &Template<'_>, what: &str) -> usize {
        let n = portable.n;
        let width = window::chunks(n) * window::LANES;
        for i in 0..n {
            let rows = |t: &Template<'_>| {
                [
                    bits(&t.t[i]),
                    bits(&t.gx[i][..width]),
                    bits(&t.gy[i][..width]),
                ]
            };
            assert_eq!(rows(portable), rows(fast), "{what} row {i}");
        }
        n
    }

    /// The AVX2 sweep gives the portable row kernels' lane sums bit for bit
    /// for every window size, with and without the absolute sums, at varied
    /// subpixel offsets, inside the image and over its border (its rows
    /// copied one by one, and read from the image's edge-replicated copy),
    /// packed and strided.
    #[test]
    fn the_avx2_sweep_gives_the_portable_sums_bit_for_bit() {
        let (a, b) = (image(1), image(2));
        let avx2 = Isa::detect().avx2();
        for copy_after in [u32::MAX, 1] {
            let (mut compared, mut by_avx2, mut over_border, mut from_copies) = (0, 0, 0, 0);
            for (va, vb) in views(&a).into_iter().zip(views(&b)) {
                for n in (3..=31).step_by(2) {
                    let mut rows = TemplateRows::<31>::zeroed();
                    let mut tpl = Template::empty(&mut rows);
                    tpl.column_order = false;
                    tpl.borders.copy_after = copy_after;
                    for c in centres(&va) {
                        if tpl.fill(&va, c, n, 0.0, true).is_err() {
                            continue;
                        }
                        let filled = tpl.borders.served;
                        for (dx, dy) in [(0.0, 0.0), (0.37, -0.61), (-1.25, 0.5), (2.999, 1.001)] {
                            let at = Vec2::new(c.x + dx, c.y + dy);
                            for (clamp, abs) in
                                [(false, false), (false, true), (true, false), (true, true)]
                            {
                                tpl.isa = Isa::BASELINE;
                                let portable = tpl.row_sums(&vb, at, clamp, abs);
                                tpl.isa = Isa::detect();
                                let fast = tpl.row_sums(&vb, at, clamp, abs);
                                let lanes = |s: [[f32; 8]; 3]| s.map(|l| bits(&l));
                                assert_eq!(portable.map(lanes), fast.map(lanes), "n {n} at {at:?}");
                                compared += usize::from(portable.is_some());
                                by_avx2 += usize::from(
                                    avx2 && tpl.avx2_sums(&vb, at, clamp, abs).is_some(),
                                );
                                let half = (n / 2) as f32;
                                let (x, y) = (at.x - half, at.y - half);
                                let src = SourceRows::new(&vb, x, y, n, n, false);
                                over_border += usize::from(portable.is_some() && src.is_none());
                            }
                        }
                        from_copies += tpl.borders.served - filled;
                        tpl.borders.served = 0;
                    }
                }
            }
            assert!(compared > 5000, "{compared}");
            assert!(
                over_border > 1000,
                "{over_border} of {compared} over the border"
            );
            if !avx2 {
                std::eprintln!("no AVX2 on this CPU: the portable sweep was compared with itself");
                return;
            }
            assert_eq!(by_avx2, compared);
            // Every window over the border, twice (`row_sums`, `avx2_sums`),
            // read from the copy when copies are made at once; none when never.
            let want = if copy_after == 1 { 2 * over_border } else { 0 };
            assert_eq!(from_copies, want, "copy after {copy_after}");
        }
    }

    /// The AVX2 fill gives the portable template bit for bit (intensities
    /// in every lane, gradients in the window's chunks, `G⁻¹`) for every
    /// window size at varied subpixel offsets, inside the image and over
    /// its border (rows copied one by one, and read from the image's
    /// edge-replicated copy), packed and strided, and fails where it fails.
    #[test]
    fn the_avx2_fill_gives_the_portable_template_bit_for_bit() {
        let a = image(3);
        let avx2 = Isa::detect().avx2();
        for copy_after in [u32::MAX, 1] {
            let (mut compared, mut by_avx2, mut over_border, mut from_copies) = (0, 0, 0, 0);
            for va in views(&a) {
                for n in (3..=31).step_by(2) {
                    let (mut rows_a, mut rows_b) =
                        (TemplateRows::<31>::zeroed(), TemplateRows::<31>::zeroed());
                    let (mut portable, mut fast) = portable_and_fast(&mut rows_a, &mut rows_b);
                    fast.borders.copy_after = copy_after;
                    for c in centres(&va) {
                        for min_eig in [0.0, 1e-3] {
                            let want = portable.fill(&va, c, n, min_eig, true);
                            let before = fast.borders.served;
                            let got = fast.fill(&va, c, n, min_eig, true);
                            from_copies += fast.borders.served - before;
                            assert_eq!(want.is_ok(), got.is_ok(), "n {n} at {c:?}");
                            // The source `Template::fill` samples, with its frame.
                            let half = (n / 2) as f32 + 1.0;
                            let (x, y) = (c.x - half, c.y - half);
                            let strict = SourceRows::new(&va, x, y, n + 2, n + 2, false);
                            let inside = c.x >= 0.0
                                && c.y >= 0.0
                                && c.x <= (va.width() - 1) as f32
                                && c.y <= (va.height() - 1) as f32;
                            over_border += usize::from(inside && strict.is_none());
                            if want.is_err() {
                                continue;
                            }
                            assert_same_rows(&portable, &fast, &std::format!("n {n} at {c:?}"));
                            for b in [Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)] {
                                let (p, q) = (portable.solve(&b), fast.solve(&b));
                                assert_eq!(bits(&[p.x, p.y]), bits(&[q.x, q.y]), "n {n} at {c:?}");
                            }
                            compared += 1;
                            let src = SourceRows::new(&va, x, y, n + 2, n + 2, inside).unwrap();
                            by_avx2 +=
                                usize::from(avx2 && fast.sample_by_avx2(&va, &src).is_some());
                        }
                    }
                }
            }
            assert!(compared > 1000, "{compared}");
            assert!(
                over_border > 600,
                "{over_border} of {compared} over the border"
            );
            if !avx2 {
                std::eprintln!("no AVX2 on this CPU: the portable fill was compared with itself");
                return;
            }
            assert_eq!(by_avx2, compared);
            // Every fill over the border read from the copy when copies are
            // made at once; none when never.
            let want = if copy_after == 1 { over_border } else { 0 };
            assert_eq!(from_copies, want, "copy after {copy_after}");
        }
    }

    /// A window inside the image whose row ends at the image's right edge:
    /// the fill's source rows run one byte past it, where the portable code
    /// repeats the edge pixel in row 0 and reads the buffer in the others;
    /// the AVX2 fill reads them alike, so even the masked lanes (whose
    /// signed zeros follow those bytes) agree.
    #[test]
    fn the_avx2_fill_reads_past_the_right_edge_as_the_portable_fill() {
        const EW: usize = 40;
        const EH: usize = 30;
        let mut px = [0u8; EW * EH];
        for (i, p) in px.iter_mut().enumerate() {
            let (x, y) = (i % EW, i / EW);
            *p = match x {
                0 => 255,
                x if x == EW - 1 => 0,
                _ => (180 + (x * 7 + y * 13) % 50) as u8,
            };
        }
        let va = ImageView::packed(&px, EW, EH).unwrap();
        let n = 21;
        let (mut rows_a, mut rows_b) = (TemplateRows::<21>::zeroed(), TemplateRows::<21>::zeroed());
        let (mut portable, mut fast) = portable_and_fast(&mut rows_a, &mut rows_b);
        let mut compared = 0;
        for y in [11.25f32, 12.5, 13.75, 15.0, 16.25, 17.5, 18.75] {
            // The patch (the window and its frame, 23 columns) starts at
            // column 16: its source bytes end at column 39, the last.
            let c = Vec2::new(27.9, y);
            let want = portable.fill(&va, c, n, 0.0, false);
            assert_eq!(want.is_ok(), fast.fill(&va, c, n, 0.0, false).is_ok());
            if want.is_err() {
                continue;
            }
            compared += assert_same_rows(&portable, &fast, &std::format!("at {c:?}"));
        }
        assert!(compared >= 3 * n, "{compared} rows compared");
    }
}
