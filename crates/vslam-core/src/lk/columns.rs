//! Column-order window kernels for cores without vector units (Cortex-M).
//!
//! The tracker's row kernels (`template`, `window`) work on rows of
//! [`LANES`] lanes so that a vector unit handles a row chunk per
//! instruction: lane `k` sums the terms of the window's columns `k`,
//! `k + 8`, ... down the rows, and the lanes are added at the end. A core
//! without vector units runs such a row as scalar code, and the lane sums
//! go through memory at every row (a Cortex-M4 has 32 single-precision
//! registers; eight lanes of three sums and a row of samples do not fit),
//! and the rows are computed a whole chunk wide whatever the window.
//! For windows of one chunk (at most eight columns: the 7x7 window of
//! 160x120 frames) the kernels here compute only the window's columns and
//! walk it one column (lane) at a time, the lane's sums in registers. They
//! give the row kernels' results bit for bit: every sample, gradient and
//! lane sum of the window's columns is the same expression of the same
//! source bytes, added in the same order (rows top to bottom); the lanes
//! past the window, which the row kernels fill with zero gradients and a
//! zero mask, hold zero gradients and sums of `+0.0` (a row kernel's lane
//! there adds only products with a zero factor to `+0.0`, which stays
//! `+0.0`). The tests compare both, sums and tracks.
//!
//! - [`template`]: the template window, its Scharr gradients and the lane
//!   sums of `G` (`Template::fill`);
//! - [`mismatch`]: the lane sums of one iteration (`Template::mismatch`).

use super::template::TplRow;
use super::window::{LANES, SRC, SourceRows};
use crate::image::ImageView;

/// Per-lane sums of three quantities: `sum (T - J) gx`, `sum (T - J) gy`
/// and `sum |T - J|` for [`mismatch`]; `gx²`, `gx gy`, `gy²` for
/// [`template`].
pub(super) type Sums = [[f32; LANES]; 3];

/// The widest window the column kernels serve: one chunk of lanes, odd.
pub(super) const MAX_COLUMNS: usize = LANES - 1;

/// Patch rows and columns of the widest window: the window and its
/// one-pixel frame.
const PATCH: usize = MAX_COLUMNS + 2;

/// The source rows of a window, read as the row kernels read them: a
/// window inside the image borrows the image's rows, one over the border of
/// a coarse level gets them with the edge pixels repeated (`SourceRows`).
/// The first columns of a row, those the window's samples use, are the same
/// bytes either way.
struct Source<'a, 'i> {
    src: &'a SourceRows,
    image: &'a ImageView<'i>,
    inside: Option<(&'i [u8], usize, usize)>,
    /// The border rows' buffer, zeroed only when a row needs it.
    buf: Option<[u8; SRC]>,
}

impl<'a, 'i> Source<'a, 'i> {
    fn new(src: &'a SourceRows, image: &'a ImageView<'i>) -> Self {
        Source {
            src,
            image,
            inside: src.inside_rows(image),
            buf: None,
        }
    }

    /// The first `need` bytes of source row `i` (fewer when the image
    /// has no such row).
    #[inline(always)]
    fn bytes(&mut self, i: usize, need: usize) -> &[u8] {
        let inside = self.inside.and_then(|(data, start, stride)| {
            let at = stride.checked_mul(i)?.checked_add(start)?;
            data.get(at..)?.get(..need)
        });
        match inside {
            Some(row) => row,
            None => {
                let buf = self.buf.get_or_insert([0; SRC]);
                self.src.row(self.image, i, need, buf)
            }
        }
    }

    /// Source row `i`, interpolated horizontally into the first `w` samples
    /// of `out`: `a + ax (b - a)` of byte pairs (the expression of
    /// `window::horizontal`), from `w + 1` bytes.
    #[inline(always)]
    fn horizontal(&mut self, i: usize, w: usize, out: &mut [f32; PATCH]) {
        let ax = self.src.ax;
        let row = self.bytes(i, w.saturating_add(1));
        let pairs = row.iter().zip(row.iter().skip(1));
        for (o, (&a, &b)) in out.iter_mut().zip(pairs).take(w) {
            let (a, b) = (f32::from(a), f32::from(b));
            *o = a + ax * (b - a);
        }
    }

    /// [`Source::horizontal`] of `W` samples as a new row (zeros past a
    /// short row), with no zeroing beforehand.
    #[inline(always)]
    fn horizontal_row<const W: usize>(&mut self, i: usize) -> [f32; W] {
        let ax = self.src.ax;
        let row = self.bytes(i, W + 1);
        core::array::from_fn(|x| match (row.get(x), row.get(x + 1)) {
            (Some(&a), Some(&b)) => {
                let (a, b) = (f32::from(a), f32::from(b));
                a + ax * (b - a)
            }
            _ => 0.0,
        })
    }
}

/// The template window of `Template::fill` for a window of `N <=`
/// [`MAX_COLUMNS`] columns: the `N + 2` square patch with its top-left
/// sample where `src` says, its centre `N x N` into the first `N` lanes of
/// the rows of `t`, the Scharr gradients into those of `gx` and `gy` (lanes
/// `N..LANES` get zero gradients and a zero template), and the lane sums of
/// `gx²`, `gx gy`, `gy²` into `sums`. `false` (nothing written) when the
/// rows hold fewer than `N` rows.
#[inline(never)]
pub(super) fn template<const N: usize>(
    src: &SourceRows,
    image: &ImageView<'_>,
    [t, gx, gy]: [&mut [TplRow]; 3],
    sums: &mut Sums,
) -> bool {
    let (Some(t), Some(gx), Some(gy)) = (
        t.first_chunk_mut::<N>(),
        gx.first_chunk_mut::<N>(),
        gy.first_chunk_mut::<N>(),
    ) else {
        return false;
    };
    // The patch, N + 2 rows of N + 2 samples: each source row
    // interpolated horizontally, then blended with the next one
    // (`window::vertical`).
    let mut source = Source::new(src, image);
    let mut h = [[0.0f32; PATCH]; PATCH + 1];
    for (i, out) in h.iter_mut().enumerate().take(N + 3) {
        source.horizontal(i, N + 2, out);
    }
    let ay = src.ay;
    let mut patch = [[0.0f32; PATCH]; PATCH];
    for (out, pair) in patch.iter_mut().zip(h.windows(2)).take(N + 2) {
        let [h0, h1] = pair else {
            break;
        };
        for ((o, &a), &b) in out.iter_mut().zip(h0).zip(h1).take(N + 2) {
            *o = a + ay * (b - a);
        }
    }
    // Template rows: separable Scharr as `gradient_row` (smooth [3 10 3]
    // down the columns and difference across for gx; difference down and
    // smooth across for gy), scaled by 1/32 (the mask of the window's
    // lanes).
    let rows = t.iter_mut().zip(gx.iter_mut()).zip(gy.iter_mut());
    for (((t, gx), gy), p) in rows.zip(patch.windows(3)) {
        let [p0, p1, p2] = p else {
            break;
        };
        let (mut smooth, mut diff) = ([0.0f32; PATCH], [0.0f32; PATCH]);
        let columns = p0.iter().zip(p1).zip(p2).take(N + 2);
        for ((s, d), ((&a, &b), &c)) in smooth.iter_mut().zip(diff.iter_mut()).zip(columns) {
            *s = 3.0 * (a + c) + 10.0 * b;
            *d = c - a;
        }
        let out = t.iter_mut().zip(gx.iter_mut()).zip(gy.iter_mut());
        for ((t, gx), gy) in out.take(LANES).skip(N) {
            (*t, *gx, *gy) = (0.0, 0.0, 0.0);
        }
        let taps = p1
            .iter()
            .skip(1)
            .zip(smooth.windows(3))
            .zip(diff.windows(3));
        let out = t.iter_mut().zip(gx.iter_mut()).zip(gy.iter_mut());
        for (((t, gx), gy), ((&centre, s), d)) in out.zip(taps).take(N) {
            let ([s0, _, s2], [d0, d1, d2]) = (s, d) else {
                break;
            };
            *t = centre;
            *gx = (s2 - s0) * (1.0 / 32.0);
            *gy = (3.0 * (d0 + d2) + 10.0 * d1) * (1.0 / 32.0);
        }
    }
    // G in lanes: lane k sums its column down the rows.
    *sums = [[0.0f32; LANES]; 3];
    let [sxx, sxy, syy] = sums;
    let lanes = sxx.iter_mut().zip(sxy.iter_mut()).zip(syy.iter_mut());
    for (k, ((sxx, sxy), syy)) in lanes.enumerate().take(N) {
        let (mut xx, mut xy, mut yy) = (0.0f32, 0.0f32, 0.0f32);
        for (gx, gy) in gx.iter().zip(gy.iter()) {
            let (Some(&gx), Some(&gy)) = (gx.get(k), gy.get(k)) else {
                break;
            };
            xx += gx * gx;
            xy += gx * gy;
            yy += gy * gy;
        }
        (*sxx, *sxy, *syy) = (xx, xy, yy);
    }
    true
}

/// The lane sums of `Template::mismatch` for a window of `N <=`
/// [`MAX_COLUMNS`] columns with its top-left sample where `src` says, each
/// lane `k` handed to `lane(k, x, y, s)` in lane order: `sum (T - J) gx`,
/// `sum (T - J) gy` and, with `ABS`, `sum |T - J|` (else zero); lanes
/// `N..LANES` get `+0.0` (what the row kernels leave there). `tpl` are the
/// template and gradient rows, `mask` their column mask. `false` (no lane
/// handed over) when the template has fewer than `N` rows.
#[inline(never)]
pub(super) fn mismatch<const N: usize, const ABS: bool>(
    src: &SourceRows,
    image: &ImageView<'_>,
    [t, gx, gy]: [&[TplRow]; 3],
    mask: &TplRow,
    mut lane: impl FnMut(usize, f32, f32, f32),
) -> bool {
    let (Some(t), Some(gx), Some(gy)) = (
        t.first_chunk::<N>(),
        gx.first_chunk::<N>(),
        gy.first_chunk::<N>(),
    ) else {
        return false;
    };
    // The N + 1 source rows interpolated horizontally; the vertical blend
    // follows per sample (`J = h0 + ay (h1 - h0)`).
    let mut source = Source::new(src, image);
    let h: [[f32; N]; LANES] = core::array::from_fn(|i| {
        if i <= N {
            source.horizontal_row::<N>(i)
        } else {
            [0.0; N]
        }
    });
    let ay = src.ay;
    let [first, below @ ..] = &h;
    for k in 0..LANES {
        let (mut x, mut y, mut s) = (0.0f32, 0.0f32, 0.0f32);
        if let (true, Some(&m), Some(&top)) = (k < N, mask.get(k), first.get(k)) {
            let mut h0 = top;
            for (((t, gx), gy), h) in t.iter().zip(gx).zip(gy).zip(below) {
                let (Some(&t), Some(&gx), Some(&gy), Some(&h1)) =
                    (t.get(k), gx.get(k), gy.get(k), h.get(k))
                else {
                    break;
                };
                let d = t - (h0 + ay * (h1 - h0));
                x += d * gx;
                y += d * gy;
                if ABS {
                    s += d.abs() * m;
                }
                h0 = h1;
            }
        }
        lane(k, x, y, s);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::LANES;
    use crate::geometry::Vec2;
    use crate::image::ImageView;
    use crate::lk::template::{Template, TemplateRows};

    const W: usize = 48;
    const H: usize = 40;

    /// A textured image with sharp and smooth parts (seeded, no pattern the
    /// lanes could align with).
    fn image(seed: u32) -> [u8; W * H] {
        let mut state = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
        let mut px = [0u8; W * H];
        for (i, p) in px.iter_mut().enumerate() {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let (x, y) = ((i % W) as f32, (i / W) as f32);
            let smooth = 120.0 + 60.0 * libm::sinf(0.4 * x + 0.23 * y);
            *p = (smooth as u32 ^ (state >> 28)) as u8;
        }
        px
    }

    fn bits<const N: usize>(v: &[f32; N]) -> [u32; N] {
        v.map(f32::to_bits)
    }

    /// Centres inside, near and over every border (over it only with
    /// clamping), at subpixel offsets of every kind.
    fn centres() -> impl Iterator<Item = Vec2> {
        (0..60).map(|k| {
            let k = k as f32;
            Vec2::new(-1.5 + 0.913 * k, 41.9 - 0.731 * k)
        })
    }

    /// The column kernels' template equals the row kernels' in the
    /// window's lanes bit for bit (intensities, gradients, `G⁻¹`), has zero
    /// gradients past them, and fails where the row kernels fail.
    #[test]
    fn column_templates_equal_row_templates_bit_for_bit() {
        let mut compared = 0;
        for seed in 0..4 {
            let a = image(seed);
            let va = ImageView::packed(&a, W, H).unwrap();
            for n in [3, 5, 7] {
                let (mut r1, mut r2) = (TemplateRows::<7>::zeroed(), TemplateRows::<7>::zeroed());
                let (mut col, mut row) = (Template::empty(&mut r1), Template::empty(&mut r2));
                col.column_order = true;
                row.column_order = false;
                for c in centres() {
                    for clamp in [false, true] {
                        let got = col.fill(&va, c, n, 0.0, clamp).is_ok();
                        assert_eq!(got, row.fill(&va, c, n, 0.0, clamp).is_ok(), "{c:?}");
                        if !got {
                            continue;
                        }
                        for i in 0..n {
                            for k in 0..n {
                                assert_eq!(col.t[i][k].to_bits(), row.t[i][k].to_bits());
                                assert_eq!(col.gx[i][k].to_bits(), row.gx[i][k].to_bits());
                                assert_eq!(col.gy[i][k].to_bits(), row.gy[i][k].to_bits());
                            }
                            for k in n..LANES {
                                assert_eq!((col.gx[i][k], col.gy[i][k]), (0.0, 0.0));
                            }
                        }
                        for b in [Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)] {
                            let (p, q) = (col.solve(&b), row.solve(&b));
                            assert_eq!(bits(&[p.x, p.y]), bits(&[q.x, q.y]), "{c:?}");
                        }
                        compared += 1;
                    }
                }
            }
        }
        assert!(compared > 300, "{compared}");
    }

    /// The column kernels give the row kernels' lane sums bit for bit, for
    /// every window they serve, with and without the absolute sums, inside
    /// and over the border, and refuse what they do not serve.
    #[test]
    fn column_sums_equal_row_sums_bit_for_bit() {
        let mut compared = 0;
        for seed in 0..4 {
            let (a, b) = (image(seed), image(seed + 100));
            let (va, vb) = (
                ImageView::packed(&a, W, H).unwrap(),
                ImageView::packed(&b, W, H).unwrap(),
            );
            for n in [3, 5, 7] {
                let mut rows = TemplateRows::<7>::zeroed();
                let mut tpl = Template::empty(&mut rows);
                tpl.column_order = false;
                for c in centres() {
                    if tpl.fill(&va, c, n, 0.0, true).is_err() {
                        continue;
                    }
                    for (dx, dy) in [(0.0, 0.0), (0.37, -0.61), (-1.25, 0.5), (2.999, 1.001)] {
                        let at = Vec2::new(c.x + dx, c.y + dy);
                        for (clamp, abs) in
                            [(false, false), (false, true), (true, false), (true, true)]
                        {
                            let col = tpl.column_sums(&vb, at, clamp, abs);
                            let row = tpl.row_sums(&vb, at, clamp, abs);
                            let sums = |s: [[f32; 8]; 3]| s.map(|l| bits(&l));
                            let (col, row) = (col.map(sums), row.map(sums));
                            assert_eq!(col, row, "n {n} at {at:?} clamp {clamp} abs {abs}");
                            compared += usize::from(col.is_some());
                            // The totals `Template::mismatch` makes of the
                            // lanes, each way.
                            let mut totals = [None, None];
                            for (order, total) in [false, true].into_iter().zip(&mut totals) {
                                tpl.column_order = order;
                                *total = tpl
                                    .mismatch(&vb, at, clamp, abs)
                                    .map(|m| bits(&[m.b.x, m.b.y, m.abs]));
                            }
                            tpl.column_order = false;
                            assert_eq!(totals[0], totals[1], "n {n} at {at:?}");
                        }
                    }
                }
            }
        }
        assert!(compared > 1000, "{compared}");
        // Wider windows are not served.
        let a = image(9);
        let va = ImageView::packed(&a, W, H).unwrap();
        let mut rows = TemplateRows::<9>::zeroed();
        let mut tpl = Template::empty(&mut rows);
        let c = Vec2::new(20.3, 18.6);
        assert!(tpl.fill(&va, c, 9, 0.0, false).is_ok());
        assert!(tpl.column_sums(&va, c, false, true).is_none());
        assert!(tpl.row_sums(&va, c, false, true).is_some());
    }
}
