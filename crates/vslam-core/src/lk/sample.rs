//! Bilinear subpixel sampling of image windows.
//!
//! A window of `cols x rows` samples one pixel apart, whose top-left sample
//! sits at the subpixel position `(x, y)`, reads the pixels
//! `floor(x) ..= floor(x) + cols` and `floor(y) ..= floor(y) + rows`. All
//! samples share the four weights of the fractional offset, so the check that
//! the window is inside happens once, and each window row is two source row
//! slices combined element-wise (no per-pixel bounds tests).

use crate::image::ImageView;

use super::config::MAX_WINDOW;

/// Where a window starts and the four bilinear weights of its fractional offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bilinear {
    x0: usize,
    y0: usize,
    cols: usize,
    rows: usize,
    w00: f32,
    w01: f32,
    w10: f32,
    w11: f32,
    ax: f32,
    ay: f32,
}

impl Bilinear {
    /// A `cols x rows` window with its top-left sample at `(x, y)`, or `None`
    /// when any pixel it reads is outside `image` (or `x`, `y` are not finite).
    pub fn new(image: &ImageView<'_>, x: f32, y: f32, cols: usize, rows: usize) -> Option<Self> {
        // `x < width - cols` keeps `floor(x) + cols <= width - 1`; NaN fails every test.
        let x_end = image.width() as f32 - cols as f32;
        let y_end = image.height() as f32 - rows as f32;
        if !(x >= 0.0 && y >= 0.0 && x < x_end && y < y_end) {
            return None;
        }
        let (fx, fy) = (libm::floorf(x), libm::floorf(y));
        let (ax, ay) = (x - fx, y - fy);
        let (x0, y0) = (fx as usize, fy as usize);
        if x0 + cols >= image.width() || y0 + rows >= image.height() {
            return None; // rounding at the edge of f32 precision
        }
        Some(Bilinear {
            x0,
            y0,
            cols,
            rows,
            w00: (1.0 - ax) * (1.0 - ay),
            w01: ax * (1.0 - ay),
            w10: (1.0 - ax) * ay,
            w11: ax * ay,
            ax,
            ay,
        })
    }

    /// The four weights `(top-left, top-right, bottom-left, bottom-right)`.
    pub fn weights(&self) -> [f32; 4] {
        [self.w00, self.w01, self.w10, self.w11]
    }

    /// The source pixels of window row `i`: four slices of `cols` bytes
    /// (top row, top row shifted by one, bottom row, bottom row shifted).
    #[inline(always)]
    pub fn source_rows<'a>(&self, image: &ImageView<'a>, i: usize) -> Option<[&'a [u8]; 4]> {
        let top = image.row(self.y0 + i)?.get(self.x0..=self.x0 + self.cols)?;
        let bottom = image
            .row(self.y0 + i + 1)?
            .get(self.x0..=self.x0 + self.cols)?;
        Some([
            top.get(..self.cols)?,
            top.get(1..)?,
            bottom.get(..self.cols)?,
            bottom.get(1..)?,
        ])
    }

    /// The vertical fraction: window row `i` is `h(i) + ay (h(i+1) - h(i))`
    /// of the [`Bilinear::horizontal`] rows.
    pub fn ay(&self) -> f32 {
        self.ay
    }

    /// Source row `y0 + i` interpolated horizontally: `cols` values into
    /// `out`. Converting the bytes first and interpolating after keeps both
    /// loops simple enough to vectorise; consecutive window rows share these.
    #[inline(always)]
    pub fn horizontal(&self, image: &ImageView<'_>, i: usize, out: &mut [f32]) -> Option<()> {
        let src = image.row(self.y0 + i)?.get(self.x0..=self.x0 + self.cols)?;
        let mut wide = [0.0f32; WIDE];
        let Some(wide) = wide.get_mut(..src.len()) else {
            // Wider than the stack row: the direct formula.
            let pairs = src.iter().zip(src.get(1..)?);
            for (o, (&a, &b)) in out.iter_mut().zip(pairs) {
                let (a, b) = (f32::from(a), f32::from(b));
                *o = a + self.ax * (b - a);
            }
            return Some(());
        };
        for (w, &s) in wide.iter_mut().zip(src) {
            *w = f32::from(s);
        }
        let (left, right) = (wide.get(..self.cols)?, wide.get(1..)?);
        for ((o, &a), &b) in out.iter_mut().zip(left).zip(right) {
            *o = a + self.ax * (b - a);
        }
        Some(())
    }

    /// Samples the window into `out` (row-major, `cols` per row); `false`
    /// when `out` is too short.
    pub fn sample(&self, image: &ImageView<'_>, out: &mut [f32]) -> bool {
        let Some(out) = out.get_mut(..self.cols * self.rows) else {
            return false;
        };
        if self.cols < WIDE {
            let (mut top, mut bottom) = ([0.0f32; WIDE], [0.0f32; WIDE]);
            let (Some(t), Some(b)) = (top.get_mut(..self.cols), bottom.get_mut(..self.cols)) else {
                return false;
            };
            let (mut t, mut b) = (t, b);
            if self.horizontal(image, 0, t).is_none() {
                return false;
            }
            for (i, out_row) in out.chunks_exact_mut(self.cols).enumerate() {
                if self.horizontal(image, i + 1, b).is_none() {
                    return false;
                }
                for ((o, &h0), &h1) in out_row.iter_mut().zip(t.iter()).zip(b.iter()) {
                    *o = h0 + self.ay * (h1 - h0);
                }
                core::mem::swap(&mut t, &mut b);
            }
            return true;
        }
        for (i, out_row) in out.chunks_exact_mut(self.cols).enumerate() {
            let Some([a0, a1, b0, b1]) = self.source_rows(image, i) else {
                return false;
            };
            let taps = a0.iter().zip(a1).zip(b0).zip(b1);
            for (o, (((&p00, &p01), &p10), &p11)) in out_row.iter_mut().zip(taps) {
                *o = self.w00 * f32::from(p00)
                    + self.w01 * f32::from(p01)
                    + self.w10 * f32::from(p10)
                    + self.w11 * f32::from(p11);
            }
        }
        true
    }
}

/// Longest source row [`Bilinear::horizontal`] converts on the stack.
const WIDE: usize = MAX_WINDOW + 3;

/// Samples a `cols x rows` window with its top-left sample at `(x, y)` into
/// `out` (row-major), repeating the edge pixels outside the image (the slow
/// path for windows that hang over the border of a coarse pyramid level).
/// `false` when `x`, `y` are not finite, `out` is too short or `cols` exceeds
/// `MAX_WINDOW + 3`.
pub fn sample_clamped(
    image: &ImageView<'_>,
    x: f32,
    y: f32,
    cols: usize,
    rows: usize,
    out: &mut [f32],
) -> bool {
    if !(x.is_finite() && y.is_finite()) {
        return false;
    }
    let Some(out) = out.get_mut(..cols * rows) else {
        return false;
    };
    let (w, h) = (image.width(), image.height());
    let (wmax, hmax) = ((w - 1) as f32, (h - 1) as f32);
    // Column taps once for all rows: left pixel, right pixel, fraction.
    let mut taps = [(0usize, 0usize, 0.0f32); WIDE];
    let Some(taps) = taps.get_mut(..cols) else {
        return false;
    };
    for (j, tap) in taps.iter_mut().enumerate() {
        let sx = (x + j as f32).clamp(0.0, wmax);
        let fx = libm::floorf(sx);
        let x0 = fx as usize;
        *tap = (x0, (x0 + 1).min(w - 1), sx - fx);
    }
    let mut top_h = [0.0f32; WIDE];
    let mut bottom_h = [0.0f32; WIDE];
    for (i, out_row) in out.chunks_exact_mut(cols).enumerate() {
        let sy = (y + i as f32).clamp(0.0, hmax);
        let fy = libm::floorf(sy);
        let ay = sy - fy;
        let y0 = fy as usize;
        let (Some(top), Some(bottom)) = (image.row(y0), image.row((y0 + 1).min(h - 1))) else {
            return false;
        };
        let p = |r: &[u8], c: usize| f32::from(r.get(c).copied().unwrap_or(0));
        let rows = top_h.iter_mut().zip(bottom_h.iter_mut());
        for ((t, b), &(x0, x1, ax)) in rows.zip(taps.iter()) {
            *t = p(top, x0) + ax * (p(top, x1) - p(top, x0));
            *b = p(bottom, x0) + ax * (p(bottom, x1) - p(bottom, x0));
        }
        for ((o, &t), &b) in out_row.iter_mut().zip(&top_h).zip(&bottom_h) {
            *o = t + ay * (b - t);
        }
    }
    true
}

/// Samples one pixel bilinearly, `None` outside the image.
pub fn sample_pixel(image: &ImageView<'_>, x: f32, y: f32) -> Option<f32> {
    let mut v = [0.0f32; 1];
    let b = Bilinear::new(image, x, y, 1, 1)?;
    b.sample(image, &mut v).then_some(v[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_refuses_the_outside() {
        // f(x, y) = 10 x + 3 y is reproduced exactly by bilinear interpolation.
        let mut buf = [0u8; 6 * 5];
        for y in 0..5 {
            for x in 0..6 {
                buf[y * 6 + x] = (10 * x + 3 * y) as u8;
            }
        }
        let img = ImageView::packed(&buf, 6, 5).unwrap();
        let v = sample_pixel(&img, 2.25, 1.5).unwrap();
        assert!((v - (22.5 + 4.5)).abs() < 1e-4, "{v}");
        let b = Bilinear::new(&img, 1.5, 0.5, 4, 3).unwrap();
        let mut out = [0f32; 12];
        assert!(b.sample(&img, &mut out));
        assert!((out[4 + 2] - (10.0 * 3.5 + 3.0 * 1.5)).abs() < 1e-4);
        // The last readable top-left for 4 columns is x < 2 (pixels 1..=5).
        assert!(Bilinear::new(&img, 1.99, 0.0, 4, 3).is_some());
        assert!(Bilinear::new(&img, 2.0, 0.0, 4, 3).is_none());
        assert!(Bilinear::new(&img, -0.01, 0.0, 1, 1).is_none());
        assert!(Bilinear::new(&img, f32::NAN, 0.0, 1, 1).is_none());
        assert!(Bilinear::new(&img, 1.0, f32::INFINITY, 1, 1).is_none());
        assert!(Bilinear::new(&img, 1e30, 1.0, 1, 1).is_none());
        assert_eq!(sample_pixel(&img, 5.0, 0.0), None);
    }
}
