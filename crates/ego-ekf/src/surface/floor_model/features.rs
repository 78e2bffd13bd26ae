//! Per-cell texture features of a grayscale image: contrast (standard
//! deviation), mean horizontal first and second difference and mean vertical
//! first difference magnitudes over three square windows (4, 8 and 16 px)
//! centred on the cell, the small window's brightness against the large
//! one's, and the cell's row in the image. The absolute brightness is left
//! out: it tells one photograph from another, not one kind of floor from
//! another.
//!
//! Contrast and gradients are divided by the window's mean brightness (plus
//! 16) so that a brighter or dimmer lit floor gives about the same features,
//! the texture-energy idea of Laws ("Rapid texture identification", SPIE 238,
//! 1980) reduced to first differences. All sums are integers; a window is
//! clipped at the image border, so every cell of every image has features.

use vslam_core::image::ImageView;

/// Pixels per map cell along each axis.
pub const CELL: usize = 2;

/// Half-widths of the three windows, px.
pub const WINDOWS: [usize; 3] = [2, 4, 8];

/// Number of features per cell.
pub const FEATURES: usize = PER_WINDOW * WINDOWS.len() + 2;

/// Features per window.
const PER_WINDOW: usize = 4;

/// Integer sums over one window.
#[derive(Clone, Copy, Debug, Default)]
struct WindowSums {
    n: u32,
    sum: u32,
    sum_sq: u32,
    n_dx: u32,
    sum_dx: u32,
    n_dy: u32,
    sum_dy: u32,
    n_dx2: u32,
    sum_dx2: u32,
}

fn window_sums(image: &ImageView<'_>, cx: usize, cy: usize, half: usize) -> WindowSums {
    let (w, h) = (image.width(), image.height());
    let (px, py) = (cx * CELL + CELL / 2, cy * CELL + CELL / 2);
    let (x0, x1) = (px.saturating_sub(half), (px + half).min(w));
    let (y0, y1) = (py.saturating_sub(half), (py + half).min(h));
    let mut s = WindowSums::default();
    for y in y0..y1 {
        let Some(row) = image.row(y) else { continue };
        let next = if y + 1 < y1 { image.row(y + 1) } else { None };
        let Some(cells) = row.get(x0..x1) else {
            continue;
        };
        let below = next.and_then(|r| r.get(x0..x1));
        let mut prev: Option<u32> = None;
        let mut prev2: Option<u32> = None;
        for (i, &p) in cells.iter().enumerate() {
            let p = u32::from(p);
            s.n += 1;
            s.sum += p;
            s.sum_sq += p * p;
            if let Some(q) = prev {
                s.n_dx += 1;
                s.sum_dx += p.abs_diff(q);
            }
            if let Some(q) = prev2 {
                s.n_dx2 += 1;
                s.sum_dx2 += p.abs_diff(q);
            }
            prev2 = prev;
            prev = Some(p);
            if let Some(b) = below.and_then(|b| b.get(i)) {
                s.n_dy += 1;
                s.sum_dy += p.abs_diff(u32::from(*b));
            }
        }
    }
    s
}

/// Ratio that is zero for an empty count.
fn per(sum: u32, n: u32) -> f32 {
    if n == 0 { 0.0 } else { sum as f32 / n as f32 }
}

/// The features of map cell `(cx, cy)` (cell `CELL` px square) of `image`,
/// each window summed pixel by pixel (see [`RowFeatures`] for the same
/// features of a whole row of cells from running sums).
pub fn cell_features(image: &ImageView<'_>, cx: usize, cy: usize) -> [f32; FEATURES] {
    let sums = WINDOWS.map(|half| window_sums(image, cx, cy, half));
    features_from(&sums, cy, image.height())
}

/// The features of a cell of map row `cy` from its windows' sums.
fn features_from(sums: &[WindowSums; WINDOWS.len()], cy: usize, height: usize) -> [f32; FEATURES] {
    let mut f = [0.0f32; FEATURES];
    let mut means = [0.0f32; WINDOWS.len()];
    for (k, s) in sums.iter().enumerate() {
        let m = per(s.sum, s.n);
        let var = (per(s.sum_sq, s.n) - m * m).max(0.0);
        let norm = 1.0 / (m + 16.0);
        let out = [
            per(s.sum_dx2, s.n_dx2) * norm,
            libm::sqrtf(var) * norm,
            per(s.sum_dx, s.n_dx) * norm,
            per(s.sum_dy, s.n_dy) * norm,
        ];
        for (j, v) in out.into_iter().enumerate() {
            if let Some(slot) = f.get_mut(PER_WINDOW * k + j) {
                *slot = v;
            }
        }
        if let Some(slot) = means.get_mut(k) {
            *slot = m;
        }
    }
    let [small, _, large] = means;
    f[FEATURES - 2] = (small - large) / (large + 16.0);
    f[FEATURES - 1] = (cy * CELL + CELL / 2) as f32 / height as f32;
    f
}

/// Widest image whose cell rows [`RowFeatures`] computes from running sums
/// (its buffers are sized for it); wider images take [`cell_features`].
pub const MAX_ROW_WIDTH: usize = 160;

/// Per column, sums over one window's rows, as prefix sums along the row:
/// entry `x` holds the sum over the columns before `x`. Quantities: the
/// pixel, its square, `|p(x) - p(x - 1)|` (columns `x >= 1`),
/// `|p(x) - p(x - 2)|` (columns `x >= 2`) and `|p(x, y) - p(x, y + 1)|`
/// over the window's rows but its last.
struct ColumnPrefix([[u32; MAX_ROW_WIDTH + 1]; 5]);

/// Indices into [`ColumnPrefix`].
const SUM: usize = 0;
const SUM_SQ: usize = 1;
const DX: usize = 2;
const DX2: usize = 3;
const DY: usize = 4;

impl ColumnPrefix {
    /// The column sums over rows `y0..y1` of `image` (at most
    /// [`MAX_ROW_WIDTH`] wide), as prefix sums.
    fn fill(&mut self, image: &ImageView<'_>, y0: usize, y1: usize) {
        let w = image.width().min(MAX_ROW_WIDTH);
        for table in self.0.iter_mut() {
            table.fill(0);
        }
        let [sum, sum_sq, dx, dx2, dy] = &mut self.0;
        for y in y0..y1 {
            let Some(row) = image.row(y).and_then(|r| r.get(..w)) else {
                continue;
            };
            let below = if y + 1 < y1 {
                image.row(y + 1).and_then(|r| r.get(..w))
            } else {
                None
            };
            // Column x's sums go to entry x + 1, turned into prefix sums below.
            for (x, &p) in row.iter().enumerate() {
                let p = u32::from(p);
                let i = x + 1;
                if let Some(v) = sum.get_mut(i) {
                    *v += p;
                }
                if let Some(v) = sum_sq.get_mut(i) {
                    *v += p * p;
                }
                if let (Some(&q), Some(v)) =
                    (x.checked_sub(1).and_then(|j| row.get(j)), dx.get_mut(i))
                {
                    *v += p.abs_diff(u32::from(q));
                }
                if let (Some(&q), Some(v)) =
                    (x.checked_sub(2).and_then(|j| row.get(j)), dx2.get_mut(i))
                {
                    *v += p.abs_diff(u32::from(q));
                }
                if let (Some(&b), Some(v)) = (below.and_then(|b| b.get(x)), dy.get_mut(i)) {
                    *v += p.abs_diff(u32::from(b));
                }
            }
        }
        for table in self.0.iter_mut() {
            let mut run = 0u32;
            for v in table.iter_mut().take(w + 1) {
                run += *v;
                *v = run;
            }
        }
    }

    /// Sum of quantity `q` over columns `a..b` (0 when empty).
    fn span(&self, q: usize, a: usize, b: usize) -> u32 {
        let table = self.0.get(q);
        match (table.and_then(|t| t.get(a)), table.and_then(|t| t.get(b))) {
            (Some(&lo), Some(&hi)) if b > a => hi - lo,
            _ => 0,
        }
    }
}

/// The features of every cell of one map row from running sums: per window,
/// the column sums over the window's rows once per map row, then each cell's
/// window from their prefix sums in constant time. The same integer sums as
/// [`cell_features`], so the same features bit for bit, at a fraction of the
/// cost (Cortex-M4: `segment.floor_model` in `firmware/README.md`). Fixed
/// memory, about 12 KB: the prefix sums and the window sums of one row of
/// cells of an image at most [`MAX_ROW_WIDTH`] wide.
pub struct RowFeatures {
    prefix: ColumnPrefix,
    sums: [[WindowSums; WINDOWS.len()]; MAX_ROW_WIDTH / CELL],
}

impl RowFeatures {
    /// Empty buffers.
    pub const fn new() -> Self {
        const EMPTY: WindowSums = WindowSums {
            n: 0,
            sum: 0,
            sum_sq: 0,
            n_dx: 0,
            sum_dx: 0,
            n_dy: 0,
            sum_dy: 0,
            n_dx2: 0,
            sum_dx2: 0,
        };
        RowFeatures {
            prefix: ColumnPrefix([[0; MAX_ROW_WIDTH + 1]; 5]),
            sums: [[EMPTY; WINDOWS.len()]; MAX_ROW_WIDTH / CELL],
        }
    }

    /// Calls `f(cx, features)` for every cell of map row `cy` of `image`
    /// (`image.width() / CELL` of them), in order; `false` (and no call)
    /// when the image is wider than [`MAX_ROW_WIDTH`].
    pub fn row(
        &mut self,
        image: &ImageView<'_>,
        cy: usize,
        mut f: impl FnMut(usize, [f32; FEATURES]),
    ) -> bool {
        let (w, h) = (image.width(), image.height());
        if w > MAX_ROW_WIDTH {
            return false;
        }
        let cells = w / CELL;
        let py = cy * CELL + CELL / 2;
        for (k, &half) in WINDOWS.iter().enumerate() {
            let (y0, y1) = (py.saturating_sub(half), (py + half).min(h));
            let rows = y1.saturating_sub(y0) as u32;
            self.prefix.fill(image, y0, y1);
            let t = &self.prefix;
            for (cx, cell) in self.sums.iter_mut().take(cells).enumerate() {
                let px = cx * CELL + CELL / 2;
                let (x0, x1) = (px.saturating_sub(half), (px + half).min(w));
                let len = x1.saturating_sub(x0) as u32;
                if let Some(s) = cell.get_mut(k) {
                    *s = WindowSums {
                        n: len * rows,
                        sum: t.span(SUM, x0, x1),
                        sum_sq: t.span(SUM_SQ, x0, x1),
                        n_dx: len.saturating_sub(1) * rows,
                        sum_dx: t.span(DX, x0 + 1, x1),
                        n_dy: len * rows.saturating_sub(1),
                        sum_dy: t.span(DY, x0, x1),
                        n_dx2: len.saturating_sub(2) * rows,
                        sum_dx2: t.span(DX2, x0 + 2, x1),
                    };
                }
            }
        }
        for (cx, s) in self.sums.iter().take(cells).enumerate() {
            f(cx, features_from(s, cy, h));
        }
        true
    }
}

impl Default for RowFeatures {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudo-random texture (xorshift) with a bright blob, so windows
    /// differ in every quantity.
    fn image(w: usize, h: usize, seed: u32) -> [u8; MAX_ROW_WIDTH * 64] {
        let mut px = [0u8; MAX_ROW_WIDTH * 64];
        let mut s = seed | 1;
        for (i, p) in px.iter_mut().take(w * h).enumerate() {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let (x, y) = (i % w, i / w);
            let blob = if x.abs_diff(w / 3) + y.abs_diff(h / 2) < 6 {
                120
            } else {
                0
            };
            *p = ((s >> 24) as u8 / 2).saturating_add(blob);
        }
        px
    }

    #[test]
    fn row_features_equal_cell_features_bit_for_bit() {
        // Sizes with odd widths and heights, windows clipped at every border,
        // and the widest the row path takes.
        for (w, h, seed) in [
            (160, 64, 7),
            (37, 21, 3),
            (4, 3, 11),
            (2, 2, 5),
            (159, 17, 9),
        ] {
            let px = image(w, h, seed);
            let view = ImageView::new(&px[..w * h], w, h, w).unwrap();
            let mut rows = RowFeatures::new();
            for cy in 0..h / CELL {
                let mut seen = 0;
                assert!(rows.row(&view, cy, |cx, f| {
                    let direct = cell_features(&view, cx, cy);
                    assert_eq!(
                        f.map(f32::to_bits),
                        direct.map(f32::to_bits),
                        "{w}x{h} cell ({cx}, {cy})"
                    );
                    seen += 1;
                }));
                assert_eq!(seen, w / CELL);
            }
        }
    }

    #[test]
    fn row_features_refuse_wider_images() {
        let w = MAX_ROW_WIDTH + 2;
        let px = [0u8; (MAX_ROW_WIDTH + 2) * 4];
        let view = ImageView::new(&px, w, 4, w).unwrap();
        let mut calls = 0;
        assert!(!RowFeatures::new().row(&view, 0, |_, _| calls += 1));
        assert_eq!(calls, 0);
    }
}
