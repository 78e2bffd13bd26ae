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

/// A window's pixel and difference counts as `f32` (exact: every count is
/// below 2^24).
#[derive(Clone, Copy, Debug)]
struct Counts {
    n: f32,
    n_dx: f32,
    n_dy: f32,
    n_dx2: f32,
}

impl Counts {
    fn of(s: &WindowSums) -> Self {
        Counts {
            n: s.n as f32,
            n_dx: s.n_dx as f32,
            n_dy: s.n_dy as f32,
            n_dx2: s.n_dx2 as f32,
        }
    }

    /// The counts of a window `len` columns wide and `rows` rows high.
    fn window(len: u32, rows: u32) -> Self {
        Counts::of(&WindowSums {
            n: len * rows,
            n_dx: len.saturating_sub(1) * rows,
            n_dy: len * rows.saturating_sub(1),
            n_dx2: len.saturating_sub(2) * rows,
            ..WindowSums::default()
        })
    }

    fn all_above_zero(&self) -> bool {
        self.n > 0.0 && self.n_dx > 0.0 && self.n_dy > 0.0 && self.n_dx2 > 0.0
    }
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
    features_with::<false>(sums, &sums.each_ref().map(Counts::of), cy, height)
}

/// [`features_from`] with the windows' counts given; with `ABOVE_ZERO`
/// every count is known to be above zero, else a ratio over a zero count
/// is zero.
#[inline(always)]
fn features_with<const ABOVE_ZERO: bool>(
    sums: &[WindowSums; WINDOWS.len()],
    counts: &[Counts; WINDOWS.len()],
    cy: usize,
    height: usize,
) -> [f32; FEATURES] {
    let per = |sum: u32, n: f32| {
        if !ABOVE_ZERO && n == 0.0 {
            0.0
        } else {
            sum as f32 / n
        }
    };
    let mut f = [0.0f32; FEATURES];
    let mut means = [0.0f32; WINDOWS.len()];
    for (k, (s, c)) in sums.iter().zip(counts).enumerate() {
        let m = per(s.sum, c.n);
        // Clamped by a compare: `f32::max` calls the software `fmaxf` on
        // a Cortex-M4 (the difference is never -0.0, so the bits agree).
        let v = per(s.sum_sq, c.n) - m * m;
        let var = if v > 0.0 { v } else { 0.0 };
        let norm = 1.0 / (m + 16.0);
        let out = [
            per(s.sum_dx2, c.n_dx2) * norm,
            vslam_core::fsqrt::sqrtf(var) * norm,
            per(s.sum_dx, c.n_dx) * norm,
            per(s.sum_dy, c.n_dy) * norm,
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

/// Entries of a table: the prefix before each column and one past the last.
const COLS: usize = MAX_ROW_WIDTH + 1;

/// The largest window's half-width, px.
#[allow(clippy::indexing_slicing)] // i < WINDOWS.len(), at compile time
const MAX_HALF: usize = {
    let mut m = 0;
    let mut i = 0;
    while i < WINDOWS.len() {
        if WINDOWS[i] > m {
            m = WINDOWS[i];
        }
        i += 1;
    }
    m
};

// Every window is a whole number of row pairs only for 2 px cells and even
// half-widths; and 16-bit sums hold the largest window's (its pixels, and
// its differences, of at most 255 each).
#[allow(clippy::indexing_slicing)] // i < WINDOWS.len(), at compile time
const _: () = {
    assert!(CELL == 2);
    let mut i = 0;
    while i < WINDOWS.len() {
        assert!(WINDOWS[i] > 0 && WINDOWS[i].is_multiple_of(2));
        i += 1;
    }
    assert!(4 * MAX_HALF * MAX_HALF * 255 < 1 << 16);
};

/// Row pairs whose tables are kept: the largest window's `MAX_HALF` pairs
/// and the one before them.
const RING: usize = MAX_HALF + 1;

/// One entry of a [`RowFeatures`] table: each quantity summed over every row
/// pair up to the table's own and over the columns before this entry's.
/// Pair `r` is the image rows `2r - 1` and `2r` (pair 0 is row 0 alone).
/// The 16-bit sums wrap: a window's sum is a difference of entries, exact
/// modulo 2^16, and below 2^16.
#[derive(Clone, Copy, Debug)]
struct Column {
    /// The pixels.
    sum: u16,
    /// `|p(x) - p(x - 1)|` of each row (counted from column 1).
    dx: u16,
    /// `|p(x) - p(x - 2)|` of each row (counted from column 2).
    dx2: u16,
    /// `|p(2r - 1, x) - p(2r, x)|`: the vertical differences inside a pair.
    dy_in: u16,
    /// `|p(2r - 2, x) - p(2r - 1, x)|`: the vertical differences into a
    /// pair from the one before.
    dy_link: u16,
    /// The squared pixels.
    sum_sq: u32,
}

impl Column {
    const ZERO: Column = Column {
        sum: 0,
        dx: 0,
        dx2: 0,
        dy_in: 0,
        dy_link: 0,
        sum_sq: 0,
    };
}

/// The table of one row pair.
type PairTable = [Column; COLS];

/// Where the table of pair `r` (`r` may be below 0: an empty pair) is in
/// the ring.
fn slot(r: isize) -> usize {
    r.rem_euclid(RING as isize) as usize
}

/// Running sums of one row pair's quantities along the row.
#[derive(Clone, Copy, Default)]
struct Run {
    sum: u32,
    sum_sq: u32,
    dx: u32,
    dx2: u32,
    dy_in: u32,
    dy_link: u32,
}

impl Run {
    /// `prev` (the table of the pair before) plus these sums.
    #[inline(always)]
    fn on(&self, prev: &Column) -> Column {
        Column {
            sum: prev.sum.wrapping_add(self.sum as u16),
            dx: prev.dx.wrapping_add(self.dx as u16),
            dx2: prev.dx2.wrapping_add(self.dx2 as u16),
            dy_in: prev.dy_in.wrapping_add(self.dy_in as u16),
            dy_link: prev.dy_link.wrapping_add(self.dy_link as u16),
            sum_sq: prev.sum_sq.wrapping_add(self.sum_sq),
        }
    }

    /// One row's pixel `p` with its left neighbours `p1` and `p2` (then
    /// shifted along).
    #[inline(always)]
    fn pixel(&mut self, p: u32, p1: &mut u32, p2: &mut u32) {
        self.sum = self.sum.wrapping_add(p);
        self.sum_sq = self.sum_sq.wrapping_add(p * p);
        self.dx = self.dx.wrapping_add(p.abs_diff(*p1));
        self.dx2 = self.dx2.wrapping_add(p.abs_diff(*p2));
        *p2 = *p1;
        *p1 = p;
    }
}

/// `next` = `prev` plus a pair whose three rows (`above` = `2r - 2`, `upper`
/// = `2r - 1`, `lower` = `2r`) are all in the image. Columns 0 and 1 add
/// differences with a zero neighbour: no window's sum reads them.
fn full_pair(prev: &PairTable, next: &mut PairTable, above: &[u8], upper: &[u8], lower: &[u8]) {
    // Two passes, each with few enough running sums for the registers:
    // the pixels, squares and vertical differences, then the horizontal
    // differences.
    let (mut sum, mut sum_sq, mut dy_in, mut dy_link) = (0u32, 0u32, 0u32, 0u32);
    let pixels = above.iter().zip(upper).zip(lower);
    for ((n, p), ((&c, &a), &b)) in next.iter_mut().skip(1).zip(prev.iter().skip(1)).zip(pixels) {
        let (a, b, c) = (u32::from(a), u32::from(b), u32::from(c));
        sum = sum.wrapping_add(a + b);
        sum_sq = sum_sq.wrapping_add(a * a + b * b);
        dy_in = dy_in.wrapping_add(a.abs_diff(b));
        dy_link = dy_link.wrapping_add(c.abs_diff(a));
        n.sum = p.sum.wrapping_add(sum as u16);
        n.sum_sq = p.sum_sq.wrapping_add(sum_sq);
        n.dy_in = p.dy_in.wrapping_add(dy_in as u16);
        n.dy_link = p.dy_link.wrapping_add(dy_link as u16);
    }
    let (mut dx, mut dx2) = (0u32, 0u32);
    let (mut u1, mut u2, mut l1, mut l2) = (0u32, 0u32, 0u32, 0u32);
    for ((n, p), (&a, &b)) in next
        .iter_mut()
        .skip(1)
        .zip(prev.iter().skip(1))
        .zip(upper.iter().zip(lower))
    {
        let (a, b) = (u32::from(a), u32::from(b));
        dx = dx.wrapping_add(a.abs_diff(u1) + b.abs_diff(l1));
        dx2 = dx2.wrapping_add(a.abs_diff(u2) + b.abs_diff(l2));
        (u2, u1, l2, l1) = (u1, a, l1, b);
        n.dx = p.dx.wrapping_add(dx as u16);
        n.dx2 = p.dx2.wrapping_add(dx2 as u16);
    }
}

/// [`full_pair`] for a pair at the image's top or bottom, some of whose
/// rows are missing (`None`): a missing row adds nothing, and no
/// difference with it.
fn edge_pair(
    prev: &PairTable,
    next: &mut PairTable,
    above: Option<&[u8]>,
    upper: Option<&[u8]>,
    lower: Option<&[u8]>,
    w: usize,
) {
    let px = |row: Option<&[u8]>, x: usize| row.and_then(|r| r.get(x)).map(|&p| u32::from(p));
    let mut run = Run::default();
    let (mut u1, mut u2, mut l1, mut l2) = (0, 0, 0, 0);
    for x in 0..w {
        let (c, a, b) = (px(above, x), px(upper, x), px(lower, x));
        if let Some(a) = a {
            run.pixel(a, &mut u1, &mut u2);
        }
        if let Some(b) = b {
            run.pixel(b, &mut l1, &mut l2);
        }
        if let (Some(a), Some(b)) = (a, b) {
            run.dy_in = run.dy_in.wrapping_add(a.abs_diff(b));
        }
        if let (Some(c), Some(a)) = (c, a) {
            run.dy_link = run.dy_link.wrapping_add(c.abs_diff(a));
        }
        if let (Some(n), Some(p)) = (next.get_mut(x + 1), prev.get(x + 1)) {
            *n = run.on(p);
        }
    }
}

/// Where one window's sums come from at one map row: the tables of its
/// last pair (`hi`), of the pair before its first (`lo`) and of its first
/// (`first`, for the links into its pairs), and its number of rows.
struct WindowRows<'a> {
    hi: &'a PairTable,
    lo: &'a PairTable,
    first: &'a PairTable,
    rows: u32,
}

/// The entries a window's sums read from one table: at its first three
/// columns (the pixels start at the first, the first differences at the
/// second, the second differences at the third) and one past its last.
type Ends = (Column, Column, Column, Column);

impl<'a> WindowRows<'a> {
    /// The sums over the window's rows and columns `px - HALF..px + HALF`,
    /// clipped to `0..w` (`px < w <= MAX_ROW_WIDTH`, `HALF >= 2`).
    #[inline(always)]
    fn sums<const HALF: usize>(&self, px: usize, w: usize) -> WindowSums {
        let (x0, x1) = (px.saturating_sub(HALF), (px + HALF).min(w));
        let at = |t: &PairTable| {
            let (Some(&[a0, a1, a2]), Some(&b)) = (t.get(x0..x0 + 3), t.get(x1)) else {
                return None;
            };
            Some((a0, a1, a2, b))
        };
        match (at(self.hi), at(self.lo), at(self.first)) {
            (Some(hi), Some(lo), Some(first)) => {
                self.sums_of(x1.saturating_sub(x0) as u32, hi, lo, first)
            }
            _ => WindowSums::default(),
        }
    }

    /// [`WindowRows::sums`] of the cells at `px`, `px + CELL`, ... while
    /// their windows are inside the tables (the caller stops at the row's
    /// right border): each table read at fixed offsets from one pointer.
    #[inline(always)]
    fn inside<const HALF: usize>(&self, px: usize) -> impl Iterator<Item = WindowSums> + '_ {
        let x0 = px.saturating_sub(HALF);
        let from = |t: &'a PairTable| {
            t.get(x0..)
                .unwrap_or(&[])
                .windows(2 * HALF + 1)
                .step_by(CELL)
        };
        let ends = |s: &[Column]| {
            let (&[a0, a1, a2], _) = s.split_first_chunk::<3>()?;
            Some((a0, a1, a2, *s.last()?))
        };
        from(self.hi)
            .zip(from(self.lo))
            .zip(from(self.first))
            .map(move |((h, l), f)| match (ends(h), ends(l), ends(f)) {
                (Some(h), Some(l), Some(f)) => self.sums_of(2 * HALF as u32, h, l, f),
                _ => WindowSums::default(),
            })
    }

    /// The sums of a window `len` columns wide from its tables' entries.
    #[inline(always)]
    fn sums_of(&self, len: u32, hi: Ends, lo: Ends, first: Ends) -> WindowSums {
        let rows = self.rows;
        let ((h0, h1, h2, hb), (l0, l1, l2, lb), (f0, _, _, fb)) = (hi, lo, first);
        let d = |hi: u16, ha: u16, lo: u16, la: u16| {
            u32::from(hi.wrapping_sub(ha).wrapping_sub(lo.wrapping_sub(la)))
        };
        WindowSums {
            n: len * rows,
            sum: d(hb.sum, h0.sum, lb.sum, l0.sum),
            sum_sq: hb
                .sum_sq
                .wrapping_sub(h0.sum_sq)
                .wrapping_sub(lb.sum_sq.wrapping_sub(l0.sum_sq)),
            n_dx: len.saturating_sub(1) * rows,
            sum_dx: d(hb.dx, h1.dx, lb.dx, l1.dx),
            n_dy: len * rows.saturating_sub(1),
            sum_dy: d(hb.dy_in, h0.dy_in, lb.dy_in, l0.dy_in)
                + d(hb.dy_link, h0.dy_link, fb.dy_link, f0.dy_link),
            n_dx2: len.saturating_sub(2) * rows,
            sum_dx2: d(hb.dx2, h2.dx2, lb.dx2, l2.dx2),
        }
    }
}

/// The features of every cell of an image from running sums: per row pair
/// (image rows `2r - 1` and `2r`) a table of each quantity summed over all
/// pairs so far and along the row, so that any window's sums are the
/// differences of a few entries of two tables. Each image row is read
/// twice (as a pair's row and as the row above the next pair), whatever
/// the number of windows, and a map row adds one pair. The same integer
/// sums as [`cell_features`], so the same features bit for bit, at a
/// fraction of the cost (Cortex-M4: `segment.floor_model` in
/// `firmware/README.md`). Fixed memory, about 23 KB: the tables of the
/// largest window's pairs and one more, for an image at most
/// [`MAX_ROW_WIDTH`] wide.
pub struct RowFeatures {
    ring: [PairTable; RING],
}

impl RowFeatures {
    /// Empty tables.
    pub const fn new() -> Self {
        RowFeatures {
            ring: [[Column::ZERO; COLS]; RING],
        }
    }

    /// The table of pair `r` (`r` may be below 0: an empty pair).
    #[allow(clippy::indexing_slicing)] // slot() < RING, the ring's length
    fn table(&self, r: isize) -> &PairTable {
        &self.ring[slot(r)]
    }

    /// Adds the table of pair `r` (rows `2r - 1`, `2r`) of `image`, cut to
    /// its first `w` columns, on the table of pair `r - 1`.
    fn add_pair(&mut self, image: &ImageView<'_>, r: usize, w: usize) {
        let row = |y: Option<usize>| y.and_then(|y| image.row(y)).and_then(|p| p.get(..w));
        let above = row((2 * r).checked_sub(2));
        let upper = row((2 * r).checked_sub(1));
        let lower = row(Some(2 * r));
        let (p, n) = (slot(r as isize - 1), slot(r as isize));
        let Ok([prev, next]) = self.ring.get_disjoint_mut([p, n]) else {
            return;
        };
        match (above, upper, lower) {
            (Some(c), Some(a), Some(b)) => full_pair(prev, next, c, a, b),
            _ => edge_pair(prev, next, above, upper, lower, w),
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
        // The last pair with a row in the image.
        let last_pair = h / 2;
        let mut added = 0;
        for cy in 0..h / CELL {
            while added <= (cy + MAX_HALF / 2).min(last_pair) {
                self.add_pair(image, added, w);
                added += 1;
            }
            let py = cy * CELL + CELL / 2;
            let windows = WINDOWS.map(|half| {
                let first = cy as isize + 1 - (half / 2) as isize;
                WindowRows {
                    hi: self.table(((cy + half / 2).min(last_pair)) as isize),
                    lo: self.table(first - 1),
                    first: self.table(first),
                    rows: ((py + half).min(h) - py.saturating_sub(half)) as u32,
                }
            });
            let [a, b, c] = &windows;
            // Away from the left and right borders every window is 2 * half
            // columns wide: the same counts in every cell of the row.
            let mut inner = [Counts::window(0, 0); WINDOWS.len()];
            for ((c, half), window) in inner.iter_mut().zip(WINDOWS).zip(&windows) {
                *c = Counts::window(2 * half as u32, window.rows);
            }
            let known = inner.iter().all(Counts::all_above_zero);
            // Cells `inner_start..inner_end` have all their windows inside
            // the row.
            let cells = w / CELL;
            let inner_start = (MAX_HALF / CELL).min(cells);
            let inner_end = if known {
                ((w.saturating_sub(CELL / 2 + MAX_HALF)) / CELL + 1).clamp(inner_start, cells)
            } else {
                inner_start
            };
            let border = |cx: usize| {
                let px = cx * CELL + CELL / 2;
                let sums = [
                    a.sums::<{ WINDOWS[0] }>(px, w),
                    b.sums::<{ WINDOWS[1] }>(px, w),
                    c.sums::<{ WINDOWS[2] }>(px, w),
                ];
                features_from(&sums, cy, h)
            };
            for cx in 0..inner_start {
                f(cx, cy, border(cx));
            }
            let px = inner_start * CELL + CELL / 2;
            let inside = a
                .inside::<{ WINDOWS[0] }>(px)
                .zip(b.inside::<{ WINDOWS[1] }>(px))
                .zip(c.inside::<{ WINDOWS[2] }>(px));
            let mut cx = inner_start;
            for ((sa, sb), sc) in inside.take(inner_end - inner_start) {
                f(cx, cy, features_with::<true>(&[sa, sb, sc], &inner, cy, h));
                cx += 1;
            }
            for cx in cx..cells {
                f(cx, cy, border(cx));
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
            assert_rows_equal_cells(&view);
        }
    }

    /// [`RowFeatures::each_cell`] visits every cell of `view` once, in row
    /// order, with [`cell_features`]' features bit for bit.
    fn assert_rows_equal_cells(view: &ImageView<'_>) {
        let (w, h) = (view.width(), view.height());
        let mut seen = 0;
        assert!(RowFeatures::new().each_cell(view, |cx, cy, f| {
            assert_eq!((cx, cy), (seen % (w / CELL), seen / (w / CELL)));
            let direct = cell_features(view, cx, cy);
            assert_eq!(
                f.map(f32::to_bits),
                direct.map(f32::to_bits),
                "{w}x{h} cell ({cx}, {cy})"
            );
            seen += 1;
        }));
        assert_eq!(seen, (w / CELL) * (h / CELL));
    }

    #[test]
    fn row_features_hold_the_largest_sums() {
        // All 255 (the largest pixel sums) and a 0/255 checkerboard (the
        // largest differences, every one 255) fill the 16-bit sums of the
        // largest window to within 1 % of 2^16.
        let (w, h) = (MAX_ROW_WIDTH, 40);
        let flat = [255u8; MAX_ROW_WIDTH * 40];
        let checker: [u8; MAX_ROW_WIDTH * 40] =
            core::array::from_fn(|i| if (i % w + i / w) % 2 == 0 { 0 } else { 255 });
        for px in [&flat, &checker] {
            let view = ImageView::new(&px[..], w, h, w).unwrap();
            let largest = window_sums(&view, 40, 10, WINDOWS[2]);
            assert!(
                largest.sum >= 65_000 || largest.sum_dy >= 61_000,
                "{largest:?}"
            );
            assert_rows_equal_cells(&view);
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
