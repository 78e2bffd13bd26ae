//! The template window of one point at one level (Bouguet 2000, section
//! 2.4): its intensities, Scharr gradients and inverse spatial gradient
//! matrix, and the image mismatch against it that each Lucas-Kanade
//! iteration solves. Shared by the translational pass ([`super::track`]) and
//! the affine refinement ([`super::affine`]); a leaf of the `lk` module.

use crate::geometry::Vec2;
use crate::image::ImageView;

use super::columns;
use super::config::MAX_WINDOW;
use super::isa::{Isa, twins};
use super::window::{self, LANES, MAX_CHUNKS, ROW, Row, SRC, SourceRows};

/// Whether [`Template::mismatch`] takes the column kernels (`columns`) for
/// the windows they serve: on Arm cores without NEON (Cortex-M), which have
/// no vector unit for the row kernels' lanes; elsewhere the row kernels
/// vectorise. Both give the same bits.
const COLUMN_ORDER: bool = cfg!(all(target_arch = "arm", not(target_feature = "neon")));

/// Width of the template rows the gradients fill (`MAX_WINDOW` rounded up to lanes).
pub(super) const TPL: usize = MAX_WINDOW.div_ceil(LANES) * LANES;
/// One template row: intensities, gradients or the column mask.
pub(super) type TplRow = [f32; TPL];

/// The left, centre and right [`TPL`]-wide views of a patch row.
type Taps<'a> = (&'a [f32; TPL], &'a [f32; TPL], &'a [f32; TPL]);
fn taps(p: &Row) -> Option<Taps<'_>> {
    Some((
        p.first_chunk::<TPL>()?,
        p.get(1..)?.first_chunk::<TPL>()?,
        p.get(2..)?.first_chunk::<TPL>()?,
    ))
}

/// The rows of a template for windows up to `R` pixels high: the storage a
/// [`Template`] borrows, on the stack of the tracker's call and sized for the
/// configured window (`3 * R * 128` bytes: 2,688 for 7x7, 11,904 for
/// [`MAX_WINDOW`]).
pub(super) struct TemplateRows<const R: usize> {
    t: [TplRow; R],
    gx: [TplRow; R],
    gy: [TplRow; R],
}

impl<const R: usize> TemplateRows<R> {
    pub(super) fn zeroed() -> Self {
        TemplateRows {
            t: [[0.0; TPL]; R],
            gx: [[0.0; TPL]; R],
            gy: [[0.0; TPL]; R],
        }
    }
}

/// The template window of one point at one level: intensities, Scharr
/// gradients (zero past column `n`, so padded columns add nothing) and the
/// inverse of the spatial gradient matrix `G`; rows are [`Row`]s. Windows up
/// to as many rows as its borrowed [`TemplateRows`] have.
pub(super) struct Template<'r> {
    pub(super) n: usize,
    pub(super) t: &'r mut [TplRow],
    pub(super) gx: &'r mut [TplRow],
    pub(super) gy: &'r mut [TplRow],
    /// 1 for the `n` window columns, 0 for the padding.
    pub(super) mask: TplRow,
    /// Windows of at most [`columns::MAX_COLUMNS`] columns take the column
    /// kernels ([`COLUMN_ORDER`]; the tests switch it).
    pub(super) column_order: bool,
    /// The row kernels' instruction set ([`Isa::detect`]; the tests switch it).
    pub(super) isa: Isa,
    /// `G⁻¹` as `[a, b, c]` for `[[a, b], [b, c]]`.
    g_inv: [f32; 3],
    /// Three consecutive rows of the sampled window with its one-pixel
    /// frame (the gradients' support), used as a ring while filling.
    patch: [Row; 3],
    /// A copied source row (near edges) and two horizontally interpolated
    /// rows: scratch of [`Template::mismatch`], kept here so that no call
    /// zeroes buffers.
    src: [u8; SRC],
    rows: [Row; 2],
    /// Edge-replicated copies of the images the AVX2 kernels' windows hang
    /// over (`borders`).
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    pub(super) borders: super::borders::Borders,
}

/// Why a template could not be built.
pub(super) enum TemplateFault {
    OutOfBounds,
    LowEigenvalue,
}

/// The sums one pass over the window yields.
pub(super) struct Mismatch {
    /// `sum (T - J) gx`, `sum (T - J) gy`.
    pub(super) b: Vec2,
    /// `sum |T - J|` (only when asked for, else 0).
    pub(super) abs: f32,
}

impl<'r> Template<'r> {
    /// One template in `rows`, filled per point and level by [`Template::fill`]
    /// (one instance serves a whole batch: no per-point zeroing).
    pub(super) fn empty<const R: usize>(rows: &'r mut TemplateRows<R>) -> Self {
        let TemplateRows { t, gx, gy } = rows;
        Template {
            n: 0,
            t,
            gx,
            gy,
            mask: [0.0; TPL],
            column_order: COLUMN_ORDER,
            isa: Isa::detect(),
            g_inv: [0.0; 3],
            patch: [[0.0; ROW]; 3],
            src: [0; SRC],
            rows: [[0.0; ROW]; 2],
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            borders: super::borders::Borders::new(),
        }
    }

    /// Samples the window of side `n` centred on `c` and its gradients.
    /// With `clamp`, a window hanging over the border repeats the edge pixels
    /// (the centre must still be inside); without, it is out of bounds.
    pub(super) fn fill(
        &mut self,
        image: &ImageView<'_>,
        c: Vec2,
        n: usize,
        min_eig: f32,
        clamp: bool,
    ) -> Result<(), TemplateFault> {
        let half = (n / 2) as f32;
        let m = n + 2;
        let (x, y) = (c.x - half - 1.0, c.y - half - 1.0);
        let clamp = clamp && inside(image, c);
        let Some(src) = SourceRows::new(image, x, y, m, m, clamp) else {
            return Err(TemplateFault::OutOfBounds);
        };
        if n > MAX_WINDOW || n > self.t.len() {
            return Err(TemplateFault::OutOfBounds);
        }
        if self.n != n {
            self.n = n;
            for (k, v) in self.mask.iter_mut().enumerate() {
                *v = if k < n { 1.0 } else { 0.0 };
            }
        }
        // Whole windows at once where they serve: the column kernels
        // (Cortex-M) or the AVX2 fill; else the row kernels below.
        let whole = if self.column_order {
            self.sample_by_columns(image, &src)
        } else {
            self.sample_by_avx2(image, &src)
        };
        // (patch chunks, window chunks) for n = 3..=31, odd.
        let [gxx, gxy, gyy] = match whole {
            Some(sums) => sums.map(|lanes| lanes.iter().sum::<f32>()),
            None => match (window::chunks(m), window::chunks(n)) {
                (1, _) => self.sample::<1, 1>(image, &src),
                (2, 1) => self.sample::<2, 1>(image, &src),
                (2, _) => self.sample::<2, 2>(image, &src),
                (3, 2) => self.sample::<3, 2>(image, &src),
                (3, _) => self.sample::<3, 3>(image, &src),
                (4, 3) => self.sample::<4, 3>(image, &src),
                (4, _) => self.sample::<4, 4>(image, &src),
                _ => self.sample::<MAX_CHUNKS, 4>(image, &src),
            },
        };
        let area = (n * n) as f32;
        let half_diff = 0.5 * (gxx - gyy);
        let lambda_min = 0.5 * (gxx + gyy) - crate::fsqrt::sqrtf(half_diff * half_diff + gxy * gxy);
        let det = gxx * gyy - gxy * gxy;
        let well_conditioned = lambda_min / area >= min_eig && det > f32::EPSILON * area * area;
        if !well_conditioned {
            return Err(TemplateFault::LowEigenvalue);
        }
        self.g_inv = [gyy / det, -gxy / det, gxx / det];
        Ok(())
    }

    /// The template and the lane sums of `G` by the column kernels, the
    /// same bits as [`Template::sample`] in the window's lanes: for windows
    /// of at most [`columns::MAX_COLUMNS`] columns, `None` for the others.
    fn sample_by_columns(
        &mut self,
        image: &ImageView<'_>,
        src: &SourceRows,
    ) -> Option<columns::Sums> {
        let mut sums = [[0.0; LANES]; 3];
        let rows = [&mut *self.t, &mut *self.gx, &mut *self.gy];
        let done = match self.n {
            3 => columns::template::<3>(src, image, rows, &mut sums),
            5 => columns::template::<5>(src, image, rows, &mut sums),
            7 => columns::template::<7>(src, image, rows, &mut sums),
            _ => false,
        };
        done.then_some(sums)
    }

    /// The template and the lane sums of `G` by the AVX2 fill (`avx2`), the
    /// same bits as [`Template::sample`]; `None` on a CPU without AVX2 (and
    /// on every other target).
    pub(super) fn sample_by_avx2(
        &mut self,
        image: &ImageView<'_>,
        src: &SourceRows,
    ) -> Option<columns::Sums> {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            use super::avx2::fill;
            let n = self.n;
            let (isa, patch, mask) = (self.isa, &mut self.patch, &self.mask);
            let rows = (image, src, &mut self.src, &mut self.borders);
            let out = [&mut *self.t, &mut *self.gx, &mut *self.gy]
                .map(|rows| rows.get_mut(..n).unwrap_or(&mut []));
            match (window::chunks(n + 2), window::chunks(n)) {
                (1, _) => fill::<1, 1>(isa, rows, patch, out, mask),
                (2, 1) => fill::<2, 1>(isa, rows, patch, out, mask),
                (2, _) => fill::<2, 2>(isa, rows, patch, out, mask),
                (3, 2) => fill::<3, 2>(isa, rows, patch, out, mask),
                (3, _) => fill::<3, 3>(isa, rows, patch, out, mask),
                (4, 3) => fill::<4, 3>(isa, rows, patch, out, mask),
                (4, _) => fill::<4, 4>(isa, rows, patch, out, mask),
                _ => fill::<MAX_CHUNKS, 4>(isa, rows, patch, out, mask),
            }
        }
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        {
            let _ = (image, src);
            None
        }
    }

    /// Samples the `n + 2` square patch (`P` chunks wide) row by row into
    /// the ring `self.patch`; once three rows are there, the template row
    /// between them and its Scharr gradients (`C` chunks wide) follow.
    /// Returns the sums `[gxx, gxy, gyy]` of `G`.
    #[inline(always)]
    fn sample<const P: usize, const C: usize>(
        &mut self,
        image: &ImageView<'_>,
        src: &SourceRows,
    ) -> [f32; 3] {
        let Template {
            n,
            t,
            gx,
            gy,
            mask,
            isa,
            patch: [r0, r1, r2],
            src: buf,
            rows: [top, bottom],
            ..
        } = self;
        let isa = *isa;
        let mut sums = [[0.0f32; LANES]; 3];
        let (mut h0, mut h1) = (top, bottom);
        let need = P * LANES + 1;
        let weights = [src.ax, src.ay];
        window::horizontal::<P>(isa, src.row(image, 0, need, buf), src.ax, h0);
        let inside = src.inside_rows(image);
        let (data, mut start, stride) = inside.unwrap_or((&[], 0, 0));
        let outputs = t.iter_mut().zip(gx.iter_mut()).zip(gy.iter_mut());
        let mut outputs = outputs.take(*n);
        // Ring slots: the oldest, the middle and the newest patch row.
        let (mut a, mut b, mut c) = (r0, r1, r2);
        for i in 0..*n + 2 {
            // Inside: the source rows are stride apart in the image buffer.
            start = start.saturating_add(stride);
            let next = match data.get(start..start.saturating_add(need)) {
                Some(next) if inside.is_some() => next,
                _ => src.row(image, i + 1, need, buf),
            };
            // The new row goes where the oldest was.
            patch_row::<P>(isa, next, weights, [h0, h1], a);
            core::mem::swap(&mut h0, &mut h1);
            (a, b, c) = (b, c, a);
            if i >= 2
                && let Some(((t, gx), gy)) = outputs.next()
            {
                gradient_row::<C>(isa, [&*a, &*b, &*c], mask, [t, gx, gy], &mut sums);
            }
        }
        let [sxx, sxy, syy] = sums;
        [
            sxx.iter().sum::<f32>(),
            sxy.iter().sum::<f32>(),
            syy.iter().sum::<f32>(),
        ]
    }

    /// One pass over the window centred on `c` in `image`: the right-hand
    /// side `b` and, with `with_abs`, the absolute error; `None` when the
    /// window is outside (with `clamp`, only when its centre is).
    #[inline]
    pub(super) fn mismatch(
        &mut self,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        with_abs: bool,
    ) -> Option<Mismatch> {
        // The column kernels hand over their lanes in order: each total
        // adds them as `Iterator::sum` adds the row kernels' lanes.
        if self.column_order {
            let mut totals = [-0.0f32; 3];
            let by_columns = self.column_lanes(image, c, clamp, with_abs, |_, x, y, s| {
                totals[0] += x;
                totals[1] += y;
                totals[2] += s;
            });
            if by_columns {
                let [x, y, abs] = totals;
                return Some(Mismatch {
                    b: Vec2::new(x, y),
                    abs,
                });
            }
        }
        let [sx, sy, sa] = self.row_sums(image, c, clamp, with_abs)?;
        Some(Mismatch {
            b: Vec2::new(sx.iter().sum::<f32>(), sy.iter().sum::<f32>()),
            abs: sa.iter().sum::<f32>(),
        })
    }

    /// The lane sums of [`Template::mismatch`] by the row kernels (any
    /// window; on a CPU with AVX2 by the AVX2 sweep, the same bits); `None`
    /// when the window is outside.
    pub(super) fn row_sums(
        &mut self,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        with_abs: bool,
    ) -> Option<columns::Sums> {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if self.isa.avx2()
            && let Some(sums) = self.avx2_sums(image, c, clamp, with_abs)
        {
            return Some(sums);
        }
        if with_abs {
            self.sweep(image, c, clamp, &Plain::<true>)
        } else {
            self.sweep(image, c, clamp, &Plain::<false>)
        }
    }

    /// [`Template::row_sums`] by the AVX2 sweep (`avx2`); `None` on a CPU
    /// without AVX2 and when the window is outside.
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    pub(super) fn avx2_sums(
        &mut self,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        with_abs: bool,
    ) -> Option<columns::Sums> {
        use super::avx2::plain_sweep;
        let n = self.n;
        let src = self.window_rows(image, c, clamp)?;
        let tpl = [&*self.t, &*self.gx, &*self.gy].map(|rows| rows.get(..n).unwrap_or(&[]));
        let (isa, m) = (self.isa, &self.mask);
        let rows = (image, &src, &mut self.src, &mut self.borders);
        match (window::chunks(n), with_abs) {
            (1, false) => plain_sweep::<1, false>(isa, rows, tpl, m),
            (1, true) => plain_sweep::<1, true>(isa, rows, tpl, m),
            (2, false) => plain_sweep::<2, false>(isa, rows, tpl, m),
            (2, true) => plain_sweep::<2, true>(isa, rows, tpl, m),
            (3, false) => plain_sweep::<3, false>(isa, rows, tpl, m),
            (3, true) => plain_sweep::<3, true>(isa, rows, tpl, m),
            (_, false) => plain_sweep::<4, false>(isa, rows, tpl, m),
            (_, true) => plain_sweep::<4, true>(isa, rows, tpl, m),
        }
    }

    /// The lane sums of [`Template::mismatch`] by the column kernels, the
    /// same bits as [`Template::row_sums`]: for windows of at most
    /// [`columns::MAX_COLUMNS`] columns, `None` for the others and when the
    /// window is outside.
    #[cfg(test)]
    pub(super) fn column_sums(
        &self,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        with_abs: bool,
    ) -> Option<columns::Sums> {
        let mut sums = [[f32::NAN; LANES]; 3];
        let [sx, sy, sa] = &mut sums;
        let done = self.column_lanes(image, c, clamp, with_abs, |k, x, y, s| {
            for (lanes, v) in [&mut *sx, &mut *sy, &mut *sa].into_iter().zip([x, y, s]) {
                if let Some(slot) = lanes.get_mut(k) {
                    *slot = v;
                }
            }
        });
        done.then_some(sums)
    }

    /// The column kernels' lanes of [`Template::mismatch`] handed to `lane`
    /// in order (`columns::mismatch`); `false` (none handed over) for a
    /// window the column kernels do not serve or one outside.
    fn column_lanes(
        &self,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        with_abs: bool,
        lane: impl FnMut(usize, f32, f32, f32),
    ) -> bool {
        let n = self.n;
        let Some(src) = self.window_rows(image, c, clamp) else {
            return false;
        };
        let (rows, mask) = ([&*self.t, &*self.gx, &*self.gy], &self.mask);
        match (n, with_abs) {
            (3, false) => columns::mismatch::<3, false>(&src, image, rows, mask, lane),
            (3, true) => columns::mismatch::<3, true>(&src, image, rows, mask, lane),
            (5, false) => columns::mismatch::<5, false>(&src, image, rows, mask, lane),
            (5, true) => columns::mismatch::<5, true>(&src, image, rows, mask, lane),
            (7, false) => columns::mismatch::<7, false>(&src, image, rows, mask, lane),
            (7, true) => columns::mismatch::<7, true>(&src, image, rows, mask, lane),
            _ => false,
        }
    }

    /// One pass of `kernel` over the window centred on `c` in `image`: its
    /// per-lane sums; `None` when the window is outside (with `clamp`, only
    /// when its centre is).
    #[inline]
    pub(super) fn sweep<K: RowKernel>(
        &mut self,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        kernel: &K,
    ) -> Option<K::Sums> {
        let src = self.window_rows(image, c, clamp)?;
        Some(match window::chunks(self.n) {
            1 => self.sweep_in::<1, K>(image, &src, kernel),
            2 => self.sweep_in::<2, K>(image, &src, kernel),
            3 => self.sweep_in::<3, K>(image, &src, kernel),
            _ => self.sweep_in::<4, K>(image, &src, kernel),
        })
    }

    /// [`Template::sweep`] for rows of `C` chunks. Eight lanes in local
    /// arrays: the loop body is straight-line code over fixed-size arrays,
    /// which the compiler turns into SIMD; each lane sums its own columns.
    #[inline(always)]
    fn sweep_in<const C: usize, K: RowKernel>(
        &mut self,
        image: &ImageView<'_>,
        src: &SourceRows,
        kernel: &K,
    ) -> K::Sums {
        let Template {
            n,
            t,
            gx,
            gy,
            mask,
            isa,
            src: buf,
            rows: [top, bottom],
            ..
        } = self;
        let isa = *isa;
        let need = C * LANES + 1;
        window::horizontal::<C>(isa, src.row(image, 0, need, buf), src.ax, top);
        let n = *n;
        let tpl = [&**t, &**gx, &**gy].map(|rows| rows.get(..n).unwrap_or(&[]));
        sweep_rows::<C, K>(kernel, isa, image, src, buf, [top, bottom], tpl, mask)
    }

    /// Where the window centred on `c` reads `image`; with `clamp`, a window
    /// over the border whose centre is inside repeats the edge pixels, else
    /// a window outside is `None`.
    #[inline(always)]
    fn window_rows(&self, image: &ImageView<'_>, c: Vec2, clamp: bool) -> Option<SourceRows> {
        let n = self.n;
        let half = (n / 2) as f32;
        let clamp = clamp && inside(image, c);
        SourceRows::new(image, c.x - half, c.y - half, n, n, clamp)
    }

    /// `G⁻¹ b`.
    pub(super) fn solve(&self, b: &Vec2) -> Vec2 {
        let [a, o, c] = self.g_inv;
        Vec2::new(a * b.x + o * b.y, o * b.x + c * b.y)
    }
}

/// The rows of one [`Template::sweep`] after the first interpolated source
/// row (in `h[0]`): each next source row through `kernel` against the
/// template rows `tpl` (`T`, `gx`, `gy`), its lane sums returned. Out of
/// line: the loop's state stays in registers, apart from the large caller's.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn sweep_rows<const C: usize, K: RowKernel>(
    kernel: &K,
    isa: Isa,
    image: &ImageView<'_>,
    src: &SourceRows,
    buf: &mut [u8; SRC],
    [mut h0, mut h1]: [&mut Row; 2],
    [t, gx, gy]: [&[TplRow]; 3],
    mask: &TplRow,
) -> K::Sums {
    let mut sums = K::Sums::default();
    let need = C * LANES + 1;
    let weights = [src.ax, src.ay];
    if let Some((data, mut start, stride)) = src.inside_rows(image) {
        // Inside: the source rows are stride apart in the image buffer.
        // Rows in pairs, so that the two interpolated rows keep their roles
        // in each call (no pointer swap to carry through the loop).
        let (t2, t_last) = t.as_chunks::<2>();
        let (gx2, gx_last) = gx.as_chunks::<2>();
        let (gy2, gy_last) = gy.as_chunks::<2>();
        let mut i = 1;
        for (([t0, t1], [gx0, gx1]), [gy0, gy1]) in t2.iter().zip(gx2).zip(gy2) {
            start = start.saturating_add(stride);
            let next = match data.get(start..start.saturating_add(need)) {
                Some(next) => next,
                None => src.row(image, i, need, buf),
            };
            let h = [&mut *h0, &mut *h1];
            kernel.row::<C>(isa, next, weights, h, [t0, gx0, gy0, mask], &mut sums);
            start = start.saturating_add(stride);
            let next = match data.get(start..start.saturating_add(need)) {
                Some(next) => next,
                None => src.row(image, i + 1, need, buf),
            };
            let h = [&mut *h1, &mut *h0];
            kernel.row::<C>(isa, next, weights, h, [t1, gx1, gy1, mask], &mut sums);
            i += 2;
        }
        if let (Some(t), Some(gx), Some(gy)) = (t_last.first(), gx_last.first(), gy_last.first()) {
            start = start.saturating_add(stride);
            let next = match data.get(start..start.saturating_add(need)) {
                Some(next) => next,
                None => src.row(image, i, need, buf),
            };
            kernel.row::<C>(isa, next, weights, [h0, h1], [t, gx, gy, mask], &mut sums);
        }
    } else {
        for (i, ((t, gx), gy)) in t.iter().zip(gx).zip(gy).enumerate() {
            let next = src.row(image, i + 1, need, buf);
            kernel.row::<C>(isa, next, weights, [h0, h1], [t, gx, gy, mask], &mut sums);
            core::mem::swap(&mut h0, &mut h1);
        }
    }
    sums
}

twins! {
    /// One patch row: the next source row `next` interpolated horizontally
    /// into `h1`, then blended with the previous one `h0` into `out` (out of
    /// line, like [`mismatch_row`]).
    fn patch_row<const P: usize>(isa, next: &[u8], weights: [f32; 2], h: [&mut Row; 2], out: &mut Row)
        => patch_row_body;
}

#[inline(always)]
fn patch_row_body<const P: usize>(
    next: &[u8],
    [ax, ay]: [f32; 2],
    [h0, h1]: [&mut Row; 2],
    out: &mut Row,
) {
    window::horizontal_inline::<P>(next, ax, h1);
    window::vertical::<P>(h0, h1, ay, out);
}

twins! {
    /// One template row from three patch rows: the template (centre row,
    /// shifted by one), the Scharr gradients masked to the window, and the
    /// products `gx², gx gy, gy²` per lane into `sums` (out of line, like
    /// [`mismatch_row`]).
    fn gradient_row<const C: usize>(
        isa,
        p: [&Row; 3],
        mask: &TplRow,
        out: [&mut TplRow; 3],
        sums: &mut [[f32; LANES]; 3],
    ) => gradient_row_body;
}

#[inline(always)]
fn gradient_row_body<const C: usize>(
    [p0, p1, p2]: [&Row; 3],
    mask: &TplRow,
    [t, gx, gy]: [&mut TplRow; 3],
    sums: &mut [[f32; LANES]; 3],
) {
    let width = C * LANES;
    // Separable Scharr: smooth [3 10 3] down the columns and difference
    // across (gx), difference down the columns and smooth across (gy).
    // Only the `width + 2` columns the window's taps read.
    let (mut smooth, mut diff) = ([0.0f32; ROW], [0.0f32; ROW]);
    for (((s, d), &a), (&b, &c)) in smooth
        .iter_mut()
        .zip(diff.iter_mut())
        .zip(p0)
        .zip(p1.iter().zip(p2))
        .take(width + 2)
    {
        *s = 3.0 * (a + c) + 10.0 * b;
        *d = c - a;
    }
    let (Some((s0, _, s2)), Some((d0, d1, d2)), Some((_, centre, _))) =
        (taps(&smooth), taps(&diff), taps(p1))
    else {
        return;
    };
    t.copy_from_slice(centre);
    for ((g, &m), (&s0, &s2)) in gx.iter_mut().zip(mask).zip(s0.iter().zip(s2)).take(width) {
        *g = (s2 - s0) * (m / 32.0);
    }
    let y_taps = d0.iter().zip(d1).zip(d2);
    for ((g, &m), ((&d0, &d1), &d2)) in gy.iter_mut().zip(mask).zip(y_taps).take(width) {
        *g = (3.0 * (d0 + d2) + 10.0 * d1) * (m / 32.0);
    }
    // G = sum [gx² gx·gy; gx·gy gy²], in lanes.
    let [sxx, sxy, syy] = sums;
    let (gx8, _) = gx.as_chunks::<LANES>();
    let (gy8, _) = gy.as_chunks::<LANES>();
    for (gx, gy) in gx8.iter().zip(gy8).take(C) {
        let lanes = sxx.iter_mut().zip(sxy.iter_mut()).zip(syy.iter_mut());
        for (((xx, xy), yy), (&gx, &gy)) in lanes.zip(gx.iter().zip(gy)) {
            *xx += gx * gx;
            *xy += gx * gy;
            *yy += gy * gy;
        }
    }
}

/// What one pass over a window sums per row: [`Template::sweep`] walks the
/// rows, a kernel adds each row into its lane arrays.
pub(super) trait RowKernel {
    /// The per-lane sums (zero by default).
    type Sums: Default;
    /// Interpolates the next source row `next` horizontally into `h1`, blends
    /// it with the previous one `h0` (`J = h0 + ay (h1 - h0)`) and adds the
    /// row's terms against the template row into `sums`, compiled for `isa`.
    fn row<const C: usize>(
        &self,
        isa: Isa,
        next: &[u8],
        weights: [f32; 2],
        h: [&mut Row; 2],
        tpl: [&TplRow; 4],
        sums: &mut Self::Sums,
    );
}

/// The constant-brightness kernel: `sum (T - J) gx`, `sum (T - J) gy` and,
/// with `ABS`, `sum |T - J|`.
struct Plain<const ABS: bool>;

impl<const ABS: bool> RowKernel for Plain<ABS> {
    type Sums = [[f32; LANES]; 3];
    #[inline(always)]
    fn row<const C: usize>(
        &self,
        isa: Isa,
        next: &[u8],
        weights: [f32; 2],
        h: [&mut Row; 2],
        tpl: [&TplRow; 4],
        sums: &mut [[f32; LANES]; 3],
    ) {
        mismatch_row::<C, ABS>(isa, next, weights, h, tpl, sums);
    }
}

twins! {
    /// One window row of [`Template::mismatch`]: interpolates the next
    /// source row `next` horizontally into `h1`; then with `d = T - J` and
    /// `J = h0 + ay (h1 - h0)` adds `d gx`, `d gy` and (with `ABS`) `|d|`
    /// per lane into `sums`. Kept out of line and one row per call: inlined
    /// into the large caller, or with the row loop or a second row in the
    /// same function, the compiler stops vectorising the interpolation.
    fn mismatch_row<const C: usize, const ABS: bool>(
        isa,
        next: &[u8],
        weights: [f32; 2],
        h: [&mut Row; 2],
        tpl: [&TplRow; 4],
        sums: &mut [[f32; LANES]; 3],
    ) => mismatch_row_body;
}

#[inline(always)]
fn mismatch_row_body<const C: usize, const ABS: bool>(
    next: &[u8],
    [ax, ay]: [f32; 2],
    [h0, h1]: [&mut Row; 2],
    [t, gx, gy, mask]: [&TplRow; 4],
    sums: &mut [[f32; LANES]; 3],
) {
    window::horizontal_inline::<C>(next, ax, h1);
    let [sx, sy, sa] = sums;
    let (t8, _) = t.as_chunks::<LANES>();
    let (gx8, _) = gx.as_chunks::<LANES>();
    let (gy8, _) = gy.as_chunks::<LANES>();
    let (a8, _) = h0.as_chunks::<LANES>();
    let (b8, _) = h1.as_chunks::<LANES>();
    let (m8, _) = mask.as_chunks::<LANES>();
    let chunks = t8.iter().zip(gx8).zip(gy8).zip(a8.iter().zip(b8)).zip(m8);
    for ((((t, gx), gy), (a, b)), m) in chunks.take(C) {
        let lanes = sx.iter_mut().zip(sy.iter_mut()).zip(sa.iter_mut());
        let pixels = t.iter().zip(gx).zip(gy).zip(a.iter().zip(b)).zip(m);
        for (((x, y), s), ((((&t, &gx), &gy), (&a, &b)), &m)) in lanes.zip(pixels) {
            let d = t - (a + ay * (b - a));
            *x += d * gx;
            *y += d * gy;
            if ABS {
                *s += d.abs() * m;
            }
        }
    }
}

/// `c` lies inside the image (pixel centres `0..=width-1`).
fn inside(image: &ImageView<'_>, c: Vec2) -> bool {
    c.x >= 0.0
        && c.y >= 0.0
        && c.x <= (image.width() - 1) as f32
        && c.y <= (image.height() - 1) as f32
}
