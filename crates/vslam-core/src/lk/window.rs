//! Window rows for the tracker's inner loops.
//!
//! Every window the tracker reads (the template patch once per level, the
//! moving window once per iteration) is a block of samples one pixel apart
//! whose top-left sample sits at a subpixel position: all samples share the
//! same fractional offset `(ax, ay)`. So each source row is interpolated
//! horizontally once ([`horizontal`]), and each window row is the vertical
//! blend of two such rows. Rows are handled in fixed-width chunks of
//! [`LANES`] (`C` chunks, a const generic chosen from the window width), so
//! the loops have constant trip counts and compile to straight SIMD code;
//! columns past the window width are computed too and masked by the caller
//! (zero gradients), which is cheaper than a scalar tail.
//!
//! A window fully inside the image borrows its source rows straight from the
//! image (copying only near the right edge). A window hanging over the border
//! of a coarse level (allowed there, as OpenCV's padded pyramids allow) gets
//! its rows from [`SourceRows::row`] with the edge pixels repeated
//! (`BORDER_REPLICATE`), which for bilinear sampling equals clamping each
//! sample coordinate into the image (the AVX2 kernels read the same bytes
//! from an edge-replicated copy of the level, `borders`). Both run the same
//! arithmetic.

use crate::image::ImageView;

use super::config::MAX_WINDOW;

/// Lane count of the window loops.
pub(super) const LANES: usize = 8;
/// Widest window row in chunks: the template patch of a [`MAX_WINDOW`]
/// window with its one-pixel frame (`MAX_WINDOW + 2` columns).
pub(super) const MAX_CHUNKS: usize = (MAX_WINDOW + 2).div_ceil(LANES);
/// Stored row width (samples).
pub(super) const ROW: usize = MAX_CHUNKS * LANES;
/// Source bytes per row: one more than a row for the right bilinear neighbour.
pub(super) const SRC: usize = ROW + 1;

/// One window row of samples.
pub(super) type Row = [f32; ROW];

/// Where a window's source pixels are and how they are read.
#[derive(Clone, Copy, Debug)]
pub(super) struct SourceRows {
    /// Column of the top-left source pixel (may be negative when clamping).
    x0: isize,
    /// Row of the top-left source pixel (may be negative when clamping).
    y0: isize,
    /// Horizontal fraction.
    pub ax: f32,
    /// Vertical fraction.
    pub ay: f32,
    /// Whether every source pixel is inside the image.
    inside: bool,
}

impl SourceRows {
    /// The window of `cols x rows` samples with its top-left sample at
    /// `(x, y)`. `None` when `x`, `y` are not finite, or when the window
    /// reads outside the image and `clamp` is off. With `clamp`, a window over
    /// the border repeats the edge pixels (the caller limits how far out).
    #[inline]
    pub fn new(
        image: &ImageView<'_>,
        x: f32,
        y: f32,
        cols: usize,
        rows: usize,
        clamp: bool,
    ) -> Option<Self> {
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let (fx, fy) = (libm::floorf(x), libm::floorf(y));
        let (ax, ay) = (x - fx, y - fy);
        // Inside: floor(x) >= 0 and floor(x) + cols <= width - 1 (the right
        // bilinear neighbour of the last sample), likewise for rows.
        let x_end = image.width() as f32 - cols as f32;
        let y_end = image.height() as f32 - rows as f32;
        let inside = fx >= 0.0 && fy >= 0.0 && fx < x_end && fy < y_end;
        if !inside && !clamp {
            return None;
        }
        // Saturating casts; the clamped path tolerates any value.
        Some(SourceRows {
            x0: fx as isize,
            y0: fy as isize,
            ax,
            ay,
            inside,
        })
    }

    /// The column and row of the top-left source pixel.
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[inline(always)]
    pub fn origin(&self) -> (isize, isize) {
        (self.x0, self.y0)
    }

    /// For a window inside the image: the image buffer, the index of its
    /// first source byte and the stride (source row `i` starts `i` strides on).
    #[inline(always)]
    pub fn inside_rows<'a>(&self, image: &ImageView<'a>) -> Option<(&'a [u8], usize, usize)> {
        if !self.inside {
            return None;
        }
        let start = (self.y0 as usize)
            .checked_mul(image.stride())?
            .checked_add(self.x0 as usize)?;
        Some((image.data(), start, image.stride()))
    }

    /// Source row `i` of the window (image row `y0 + i`) from column `x0`:
    /// at least `need` (at most [`SRC`]) bytes, where bytes past the image's
    /// right edge (or, when clamping, outside it anywhere) repeat the nearest
    /// edge pixel. Borrows the image row when it can, else fills `buf`.
    #[inline(always)]
    pub fn row<'a>(
        &self,
        image: &ImageView<'a>,
        i: usize,
        need: usize,
        buf: &'a mut [u8; SRC],
    ) -> &'a [u8] {
        let (w, h) = (image.width(), image.height());
        let y = self
            .y0
            .saturating_add_unsigned(i)
            .clamp(0, h.saturating_sub(1) as isize) as usize;
        let Some(row) = image.row(y) else {
            return buf;
        };
        // A row whose columns are all inside (the window may still hang
        // over the top or bottom) is borrowed, clamped row and all.
        if let Ok(x0) = usize::try_from(self.x0)
            && let Some(src) = row.get(x0..x0.saturating_add(need))
        {
            return src;
        }
        // Left of the image: the first pixel; right: the last.
        let first = row.first().copied().unwrap_or(0);
        let last = row.last().copied().unwrap_or(0);
        let left = self.x0.clamp(-(SRC as isize), 0).unsigned_abs();
        let start = self.x0.clamp(0, w as isize) as usize;
        let part = row.get(start..).unwrap_or(&[]);
        let (pad, rest) = buf.split_at_mut(left.min(SRC));
        pad.fill(first);
        let n = part.len().min(rest.len());
        let (copy, tail) = rest.split_at_mut(n);
        copy.copy_from_slice(part.get(..n).unwrap_or(&[]));
        tail.fill(last);
        buf
    }
}

super::isa::twins! {
    /// `out[k] = src[k] + ax (src[k + 1] - src[k])` for the first `C` chunks
    /// (`src` holds at least `C LANES + 1` bytes, see [`SourceRows::row`]).
    pub(super) fn horizontal<const C: usize>(isa, src: &[u8], ax: f32, out: &mut Row)
        => horizontal_inline;
}

/// [`horizontal`], inlined into a caller that is itself out of line.
#[inline(always)]
pub(super) fn horizontal_inline<const C: usize>(src: &[u8], ax: f32, out: &mut Row) {
    let (Some(left), Some(right)) = (src.get(..C * LANES), src.get(1..=C * LANES)) else {
        return;
    };
    let (out8, _) = out.as_chunks_mut::<LANES>();
    let (left8, _) = left.as_chunks::<LANES>();
    let (right8, _) = right.as_chunks::<LANES>();
    for ((o, l), r) in out8.iter_mut().zip(left8).zip(right8) {
        for ((o, &a), &b) in o.iter_mut().zip(l).zip(r) {
            let (a, b) = (f32::from(a), f32::from(b));
            *o = a + ax * (b - a);
        }
    }
}

/// `out[k] = top[k] + ay (bottom[k] - top[k])` for the first `C` chunks.
#[inline(always)]
pub(super) fn vertical<const C: usize>(top: &Row, bottom: &Row, ay: f32, out: &mut Row) {
    let (out8, _) = out.as_chunks_mut::<LANES>();
    let (t8, _) = top.as_chunks::<LANES>();
    let (b8, _) = bottom.as_chunks::<LANES>();
    for ((o, t), b) in out8.iter_mut().zip(t8).zip(b8).take(C) {
        for ((o, &t), &b) in o.iter_mut().zip(t).zip(b) {
            *o = t + ay * (b - t);
        }
    }
}

/// Chunks covering `cols` samples.
pub(super) const fn chunks(cols: usize) -> usize {
    cols.div_ceil(LANES)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lk::sample::sample_clamped;

    /// Samples a `cols x rows` window through [`SourceRows`] and the two blends.
    fn sample(image: &ImageView<'_>, x: f32, y: f32, cols: usize, rows: usize) -> [f32; 256] {
        let src = SourceRows::new(image, x, y, cols, rows, true).unwrap();
        let mut out = [0f32; 256];
        let (mut b0, mut b1) = ([0u8; SRC], [0u8; SRC]);
        let (mut h0, mut h1, mut v) = ([0f32; ROW], [0f32; ROW], [0f32; ROW]);
        for i in 0..rows {
            horizontal::<MAX_CHUNKS>(
                crate::lk::isa::Isa::BASELINE,
                src.row(image, i, SRC, &mut b0),
                src.ax,
                &mut h0,
            );
            horizontal::<MAX_CHUNKS>(
                crate::lk::isa::Isa::BASELINE,
                src.row(image, i + 1, SRC, &mut b1),
                src.ax,
                &mut h1,
            );
            vertical::<MAX_CHUNKS>(&h0, &h1, src.ay, &mut v);
            out[i * cols..(i + 1) * cols].copy_from_slice(&v[..cols]);
        }
        out
    }

    #[test]
    fn rows_match_clamped_sampling_inside_and_over_every_border() {
        let (w, h) = (40usize, 30usize);
        let mut buf = [0u8; 40 * 30];
        for (i, b) in buf.iter_mut().enumerate() {
            *b = ((i * 37 + i / w * 11) % 251) as u8;
        }
        let img = ImageView::packed(&buf, w, h).unwrap();
        for &(x, y) in &[
            (3.25f32, 4.5f32),
            (-6.75, 2.0),
            (30.4, -3.3),
            (20.1, 25.9),
            (-1.5, -1.5),
            (1.0, 1.0),
            (8.0, 0.0),
            (-50.0, 12.0),
        ] {
            let (cols, rows) = (13, 9);
            let got = sample(&img, x, y, cols, rows);
            let mut want = [0f32; 13 * 9];
            assert!(sample_clamped(&img, x, y, cols, rows, &mut want));
            for (g, e) in got.iter().zip(&want) {
                assert!((g - e).abs() < 1e-3, "({x}, {y}): {g} vs {e}");
            }
        }
        // Without clamping only windows whose every read is inside are given.
        assert!(SourceRows::new(&img, 26.9, 20.9, 13, 9, false).is_some());
        assert!(SourceRows::new(&img, 27.0, 3.0, 13, 9, false).is_none());
        assert!(SourceRows::new(&img, 3.0, 21.0, 13, 9, false).is_none());
        assert!(SourceRows::new(&img, -0.1, 3.0, 13, 9, false).is_none());
        assert!(SourceRows::new(&img, f32::NAN, 3.0, 13, 9, true).is_none());
        assert!(SourceRows::new(&img, 3.0, f32::INFINITY, 13, 9, true).is_none());
        // Huge coordinates saturate and stay panic-free when clamping.
        let far = SourceRows::new(&img, 1e30, -1e30, 13, 9, true).unwrap();
        let mut b = [0u8; SRC];
        assert_eq!(far.row(&img, 0, SRC, &mut b)[0], buf[w - 1]);
        // Inside, a row is borrowed with the bytes asked for.
        let inside = SourceRows::new(&img, 2.5, 3.5, 13, 9, false).unwrap();
        assert_eq!(inside.row(&img, 1, 14, &mut b), &buf[4 * w + 2..4 * w + 16]);
    }
}
