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
        // Clamped by a compare: `f32::max` calls the software `fmaxf` on
        // a Cortex-M4 (the difference is never -0.0, so the bits agree).
        let v = per(s.sum_sq, s.n) - m * m;
        let var = if v > 0.0 { v } else { 0.0 };
        let norm = 1.0 / (m + 16.0);
        let out = [
            per(s.sum_dx2, s.n_dx2) * norm,
            vslam_core::fsqrt::sqrtf(var) * norm,
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

/// Widest image whose cells [`RowFeatures`] computes from running sums (its
/// tables are sized for it); wider images take [`cell_features`].
pub const MAX_ROW_WIDTH: usize = 160;

/// Quantities summed per column, indices into [`WindowTable`]: the pixel,
/// its square, `|p(x) - p(x - 1)|` (columns `x >= 1`), `|p(x) - p(x - 2)|`
/// (columns `x >= 2`) and `|p(x, y) - p(x, y + 1)|`.
const SUM: usize = 0;
const SUM_SQ: usize = 1;
const DX: usize = 2;
const DX2: usize = 3;
const DY: usize = 4;
const QUANTITIES: usize = 5;

/// `a + b` (`ADD`) or `a - b`, wrapping: a row taken out was added before,
/// so no sum ever wraps.
#[inline(always)]
fn apply<const ADD: bool>(a: u32, b: u32) -> u32 {
    if ADD {
        a.wrapping_add(b)
    } else {
        a.wrapping_sub(b)
    }
}

/// Rows `y..y + K` of `image`, each cut to its first `w` pixels; `None`
/// when any of them is missing or shorter.
fn rows_from<'a, const K: usize>(
    image: &ImageView<'a>,
    y: usize,
    w: usize,
) -> Option<[&'a [u8]; K]> {
    let mut rows: [&[u8]; K] = [&[]; K];
    for (i, row) in rows.iter_mut().enumerate() {
        *row = image.row(y + i)?.get(..w)?;
    }
    Some(rows)
}

/// One window's column sums over the rows the window covers now, kept as
/// prefix sums along the row: entry `x` of a quantity holds its sum over
/// the columns before `x`. `rows` are the image rows summed for the first
/// four quantities; [`DY`] sums the pairs `(y, y + 1)` with `y` in `pairs`
/// (the window's rows but its last).
struct WindowTable {
    prefix: [[u32; MAX_ROW_WIDTH + 1]; QUANTITIES],
    rows: (usize, usize),
    pairs: (usize, usize),
}

impl WindowTable {
    const EMPTY: WindowTable = WindowTable {
        prefix: [[0; MAX_ROW_WIDTH + 1]; QUANTITIES],
        rows: (0, 0),
        pairs: (0, 0),
    };

    /// Slides the window down to rows `y0..y1` of `image` (both ends never
    /// move up from one map row to the next): rows and pairs that enter are
    /// added, those that leave are taken out, each once. Away from the top
    /// and bottom borders a map row moves both ends by two rows, and the two
    /// rows in and the two out go in one pass over the table.
    fn slide(&mut self, image: &ImageView<'_>, y0: usize, y1: usize) {
        let w = image.width().min(MAX_ROW_WIDTH);
        let (r0, r1) = self.rows;
        if (y0, y1) == (r0 + 2, r1 + 2)
            && let (Some(enter), Some(leave)) = (rows_from(image, r1, w), rows_from(image, r0, w))
        {
            self.shift_rows(enter, leave);
            self.rows = (y0, y1);
        }
        while self.rows.1 < y1 {
            self.apply_row::<true>(image.row(self.rows.1), w);
            self.rows.1 += 1;
        }
        while self.rows.0 < y0 {
            self.apply_row::<false>(image.row(self.rows.0), w);
            self.rows.0 += 1;
        }
        let p1 = y1.saturating_sub(1).max(y0);
        let (q0, q1) = self.pairs;
        if (y0, p1) == (q0 + 2, q1 + 2)
            && let (Some(enter), Some(leave)) = (rows_from(image, q1, w), rows_from(image, q0, w))
        {
            self.shift_pairs(enter, leave);
            self.pairs = (y0, p1);
        }
        while self.pairs.1 < p1 {
            let y = self.pairs.1;
            self.apply_pair::<true>(image.row(y), image.row(y + 1), w);
            self.pairs.1 += 1;
        }
        while self.pairs.0 < y0.min(self.pairs.1) {
            let y = self.pairs.0;
            self.apply_pair::<false>(image.row(y), image.row(y + 1), w);
            self.pairs.0 += 1;
        }
    }

    /// The entries `1..` of the four quantities a row adds (pixel, square,
    /// first and second horizontal differences), column by column.
    fn row_tables(&mut self) -> impl Iterator<Item = (((&mut u32, &mut u32), &mut u32), &mut u32)> {
        let [sum, sum_sq, dx, dx2, _] = &mut self.prefix;
        sum.iter_mut()
            .skip(1)
            .zip(sum_sq.iter_mut().skip(1))
            .zip(dx.iter_mut().skip(1))
            .zip(dx2.iter_mut().skip(1))
    }

    /// Adds rows `enter` and takes out rows `leave` (pixel, square and
    /// horizontal differences) in one pass: the same table as two
    /// [`WindowTable::apply_row`] calls of each kind.
    fn shift_rows(&mut self, enter: [&[u8]; 2], leave: [&[u8]; 2]) {
        let tables = self.row_tables();
        let [a, b] = enter;
        let [c, d] = leave;
        let pixels = a.iter().zip(b).zip(c.iter().zip(d));
        let mut run = [0u32; 4];
        let (mut prev, mut prev2) = ([0u32; 4], [0u32; 4]);
        for (x, ((((s, q), g), g2), ((&pa, &pb), (&pc, &pd)))) in tables.zip(pixels).enumerate() {
            let p = [pa, pb, pc, pd].map(u32::from);
            // In minus out, modulo 2^32: the running sums and the table
            // entries they update stay the true (non-negative) sums.
            let net = |v: [u32; 4]| {
                v[0].wrapping_add(v[1])
                    .wrapping_sub(v[2])
                    .wrapping_sub(v[3])
            };
            run[0] = run[0].wrapping_add(net(p));
            run[1] = run[1].wrapping_add(net(p.map(|v| v * v)));
            let diff = |q: [u32; 4]| {
                let ([a, b, c, d], [qa, qb, qc, qd]) = (p, q);
                [
                    a.abs_diff(qa),
                    b.abs_diff(qb),
                    c.abs_diff(qc),
                    d.abs_diff(qd),
                ]
            };
            if x >= 1 {
                run[2] = run[2].wrapping_add(net(diff(prev)));
            }
            if x >= 2 {
                run[3] = run[3].wrapping_add(net(diff(prev2)));
            }
            prev2 = prev;
            prev = p;
            *s = s.wrapping_add(run[0]);
            *q = q.wrapping_add(run[1]);
            *g = g.wrapping_add(run[2]);
            *g2 = g2.wrapping_add(run[3]);
        }
    }

    /// Adds the pairs `(y, y + 1)`, `(y + 1, y + 2)` of rows `enter`
    /// (`y..y + 3`) and takes out those of rows `leave`, in one pass.
    fn shift_pairs(&mut self, enter: [&[u8]; 3], leave: [&[u8]; 3]) {
        let [a, b, c] = enter;
        let [d, e, f] = leave;
        let pixels = a.iter().zip(b).zip(c).zip(d.iter().zip(e).zip(f));
        let mut run = 0u32;
        for (g, (((&pa, &pb), &pc), ((&pd, &pe), &pf))) in
            self.prefix[DY].iter_mut().skip(1).zip(pixels)
        {
            let entering = u32::from(pa.abs_diff(pb)) + u32::from(pb.abs_diff(pc));
            let leaving = u32::from(pd.abs_diff(pe)) + u32::from(pe.abs_diff(pf));
            run = run.wrapping_add(entering).wrapping_sub(leaving);
            *g = g.wrapping_add(run);
        }
    }

    /// Adds (`ADD`) or takes out one row's pixel, square and horizontal
    /// differences.
    fn apply_row<const ADD: bool>(&mut self, row: Option<&[u8]>, w: usize) {
        let Some(row) = row.and_then(|r| r.get(..w)) else {
            return;
        };
        let mut run = [0u32; 4];
        let (mut prev, mut prev2) = (0u32, 0u32);
        // Entry x + 1 gains the running sum over columns 0..=x.
        let tables = self.row_tables();
        for (x, ((((s, q), d), d2), &p)) in tables.zip(row).enumerate() {
            let p = u32::from(p);
            run[0] += p;
            run[1] += p * p;
            if x >= 1 {
                run[2] += p.abs_diff(prev);
            }
            if x >= 2 {
                run[3] += p.abs_diff(prev2);
            }
            prev2 = prev;
            prev = p;
            *s = apply::<ADD>(*s, run[0]);
            *q = apply::<ADD>(*q, run[1]);
            *d = apply::<ADD>(*d, run[2]);
            *d2 = apply::<ADD>(*d2, run[3]);
        }
    }

    /// Adds (`ADD`) or takes out the vertical differences of rows `y` and
    /// `y + 1`.
    fn apply_pair<const ADD: bool>(&mut self, row: Option<&[u8]>, below: Option<&[u8]>, w: usize) {
        let (Some(row), Some(below)) =
            (row.and_then(|r| r.get(..w)), below.and_then(|r| r.get(..w)))
        else {
            return;
        };
        let mut run = 0u32;
        for ((d, &p), &b) in self.prefix[DY].iter_mut().skip(1).zip(row).zip(below) {
            run += u32::from(p.abs_diff(b));
            *d = apply::<ADD>(*d, run);
        }
    }

    /// Sum of quantity `q` over columns `a..b` (0 when empty).
    fn span(&self, q: usize, a: usize, b: usize) -> u32 {
        let table = self.prefix.get(q);
        match (table.and_then(|t| t.get(a)), table.and_then(|t| t.get(b))) {
            (Some(&lo), Some(&hi)) if b > a => hi.wrapping_sub(lo),
            _ => 0,
        }
    }

    /// The sums over the window's rows and columns `x0..x1`.
    fn sums(&self, x0: usize, x1: usize) -> WindowSums {
        let rows = self.rows.1.saturating_sub(self.rows.0) as u32;
        let len = x1.saturating_sub(x0) as u32;
        WindowSums {
            n: len * rows,
            sum: self.span(SUM, x0, x1),
            sum_sq: self.span(SUM_SQ, x0, x1),
            n_dx: len.saturating_sub(1) * rows,
            sum_dx: self.span(DX, x0 + 1, x1),
            n_dy: len * rows.saturating_sub(1),
            sum_dy: self.span(DY, x0, x1),
            n_dx2: len.saturating_sub(2) * rows,
            sum_dx2: self.span(DX2, x0 + 2, x1),
        }
    }
}

/// The features of every cell of an image from running sums: per window a
/// table of column sums over the window's rows, kept as prefix sums along
/// the row and slid down the image (each image row enters and leaves each
/// window once), so each cell's window sums come from two entries per
/// quantity. The same integer sums as [`cell_features`], so the same
/// features bit for bit, at a fraction of the cost (Cortex-M4:
/// `segment.floor_model` in `firmware/README.md`). Fixed memory, about
/// 9.7 KB: three tables for an image at most [`MAX_ROW_WIDTH`] wide.
pub struct RowFeatures {
    tables: [WindowTable; WINDOWS.len()],
}

impl RowFeatures {
    /// Empty tables.
    pub const fn new() -> Self {
        RowFeatures {
            tables: [WindowTable::EMPTY; WINDOWS.len()],
        }
    }

    /// Calls `f(cx, cy, features)` for every cell of `image`
    /// (`image.width() / CELL` by `image.height() / CELL` of them), row by
    /// row; `false` (and no call) when the image is wider than
    /// [`MAX_ROW_WIDTH`].
    pub fn each_cell(
        &mut self,
        image: &ImageView<'_>,
        mut f: impl FnMut(usize, usize, [f32; FEATURES]),
    ) -> bool {
        let (w, h) = (image.width(), image.height());
        if w > MAX_ROW_WIDTH {
            return false;
        }
        *self = RowFeatures::new();
        for cy in 0..h / CELL {
            let py = cy * CELL + CELL / 2;
            for (table, &half) in self.tables.iter_mut().zip(&WINDOWS) {
                table.slide(image, py.saturating_sub(half), (py + half).min(h));
            }
            for cx in 0..w / CELL {
                let px = cx * CELL + CELL / 2;
                let [a, b, c] = &self.tables;
                let sums = [(a, WINDOWS[0]), (b, WINDOWS[1]), (c, WINDOWS[2])]
                    .map(|(t, half)| t.sums(px.saturating_sub(half), (px + half).min(w)));
                f(cx, cy, features_from(&sums, cy, h));
            }
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
            let mut seen = 0;
            assert!(rows.each_cell(&view, |cx, cy, f| {
                assert_eq!((cx, cy), (seen % (w / CELL), seen / (w / CELL)));
                let direct = cell_features(&view, cx, cy);
                assert_eq!(
                    f.map(f32::to_bits),
                    direct.map(f32::to_bits),
                    "{w}x{h} cell ({cx}, {cy})"
                );
                seen += 1;
            }));
            assert_eq!(seen, (w / CELL) * (h / CELL));
        }
    }

    #[test]
    fn row_features_refuse_wider_images() {
        let w = MAX_ROW_WIDTH + 2;
        let px = [0u8; (MAX_ROW_WIDTH + 2) * 4];
        let view = ImageView::new(&px, w, 4, w).unwrap();
        let mut calls = 0;
        assert!(!RowFeatures::new().each_cell(&view, |_, _, _| calls += 1));
        assert_eq!(calls, 0);
    }
}
