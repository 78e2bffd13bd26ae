//! The Shi-Tomasi response, one row at a time, from a rolling window of
//! gradient products.
//!
//! The structure tensor of a pixel sums the Sobel gradient products over the
//! `block x block` block around it, separably: each column keeps the sum of
//! its products over the last `block` rows, updated as one row enters and
//! the row `block` above leaves (a ring of `block` rows remembers its
//! products), so the vertical cost per pixel does not depend on the block;
//! each response row then adds `block` neighbouring column sums. Every pass
//! runs over whole rows of one quantity, which the compiler vectorises.
//!
//! Values: products are integers below `1020² < 2²⁰` and column sums of at
//! most 7 rows stay below `2²⁴`, so both are exact in `f32` (adding and
//! removing rows never drifts). The row sums add the column sums left to
//! right, as a direct summation over the block does.
//!
//! Most pixels are far from being a corner: a pixel whose cheap upper bound
//! of `λmin` (see [`upper_bound`]) is below a caller's `cut` keeps that bound
//! instead of the exact value, which saves the square root. The caller picks
//! a cut below which a value can neither be a corner, nor stop a neighbour
//! from being one, nor be the strongest response.
//!
//! Memory: `(3 * block + 6) * width` values whatever the height.

use crate::image::ImageView;

/// The rolling window of gradient products over an image, borrowed from the
/// detector's scratch.
pub(super) struct ResponseRows<'i, 's> {
    image: &'i ImageView<'i>,
    block: usize,
    /// Products of the last `block` rows, row `p` in slot `p % block`; a
    /// slot holds three planes of `width` values: `gx²`, `gx·gy`, `gy²`.
    ring: &'s mut [f32],
    /// Per column, the sums of the ring's products, three planes.
    column_sums: &'s mut [f32],
    /// The block sums of one row, three planes.
    boxes: &'s mut [f32],
    /// The next product row to enter the window.
    next_row: usize,
    /// `1 / (64 * block²)`: Sobel's `1/8` squared and the block mean.
    norm: f32,
}

/// Scratch values [`ResponseRows`] needs for `width` columns.
pub(super) const fn window_len(width: usize, block: usize) -> usize {
    width
        .saturating_mul(3)
        .saturating_mul(block.saturating_add(2))
}

impl<'i, 's> ResponseRows<'i, 's> {
    /// A window over `image` in `scratch` (at least [`window_len`] values;
    /// `block` is odd).
    pub(super) fn new(image: &'i ImageView<'i>, block: usize, scratch: &'s mut [f32]) -> Self {
        let plane = image.width();
        let (ring, rest) = split(scratch, 3 * plane * block);
        let (column_sums, rest) = split(rest, 3 * plane);
        let (boxes, _) = split(rest, 3 * plane);
        ring.fill(0.0);
        column_sums.fill(0.0);
        ResponseRows {
            image,
            block,
            ring,
            column_sums,
            boxes,
            // Row 0 has no Sobel gradient: its products are the ring's zeros.
            next_row: 1,
            norm: 1.0 / (64.0 * (block * block) as f32),
        }
    }

    /// Writes response row `y` (`width` values) into `out` and returns the
    /// largest exact value written. Rows must be asked for in increasing
    /// order. The response is `λmin ≥ 0` where the whole block has Sobel
    /// gradients (columns and rows `r + 1 ..= size - r - 2` for
    /// `r = block / 2`) and zero elsewhere; where an upper bound of it is
    /// below `cut`, the bound is written instead.
    pub(super) fn next(&mut self, y: usize, out: &mut [f32], cut: f32) -> f32 {
        let (w, h) = (self.image.width(), self.image.height());
        let r = self.block / 2;
        out.fill(0.0);
        let valid_row = y > r && y + r + 2 <= h;
        if !valid_row || w < self.block + 2 {
            return 0.0;
        }
        while self.next_row <= y + r {
            self.push_row(self.next_row);
            self.next_row += 1;
        }
        self.response_row(out, cut)
    }

    /// Enters the products of image row `p`: they replace those of row
    /// `p - block` in the ring and in the column sums.
    fn push_row(&mut self, p: usize) {
        let w = self.image.width();
        if w == 0 {
            return;
        }
        let Some(slot) = self.ring.chunks_exact_mut(3 * w).nth(p % self.block) else {
            return;
        };
        // The leaving row.
        for (s, old) in self.column_sums.iter_mut().zip(slot.iter()) {
            *s -= *old;
        }
        let (xx, rest) = slot.split_at_mut(w);
        let (xy, yy) = rest.split_at_mut(w);
        xx.fill(0.0);
        xy.fill(0.0);
        yy.fill(0.0);
        let rows = (
            p.checked_sub(1).and_then(|y| self.image.row(y)),
            self.image.row(p),
            self.image.row(p + 1),
        );
        if let (Some(a), Some(b), Some(c)) = rows {
            // gx into the xy plane, gy into the yy plane, at columns
            // 1 ..= w - 2 (the outer columns have no gradient).
            let inner = 1..w.saturating_sub(1);
            if let Some(gx) = xy.get_mut(inner.clone()) {
                sobel_x(a, b, c, gx);
            }
            if let Some(gy) = yy.get_mut(inner) {
                sobel_y(a, c, gy);
            }
            for ((xx, xy), yy) in xx.iter_mut().zip(xy.iter_mut()).zip(yy.iter_mut()) {
                let (gx, gy) = (*xy, *yy);
                *xx = gx * gx;
                *xy = gx * gy;
                *yy = gy * gy;
            }
        }
        // The entering row (zeros where it has no gradient).
        for (s, new) in self.column_sums.iter_mut().zip(slot.iter()) {
            *s += *new;
        }
    }

    /// Block sums of the column sums, then `λmin` (or its bound).
    fn response_row(&mut self, out: &mut [f32], cut: f32) -> f32 {
        let block = self.block;
        let w = self.image.width();
        if w == 0 {
            return 0.0;
        }
        // The box of column x spans x - r ..= x + r; column 0 has no
        // gradient, so boxes start at column 1 and are centred on r + 1; the
        // last ends at column w - 2.
        let count = w.saturating_sub(block + 1);
        let planes = self
            .column_sums
            .chunks_exact(w)
            .zip(self.boxes.chunks_exact_mut(w));
        for (columns, boxes) in planes {
            let (Some(columns), Some(boxes)) = (columns.get(1..), boxes.get_mut(..count)) else {
                continue;
            };
            box_sums(columns, block, boxes);
        }
        let (xx, rest) = split(self.boxes, w);
        let (xy, yy) = split(rest, w);
        let centres = block / 2 + 1..block / 2 + 1 + count;
        let (Some(out), Some(xx), Some(xy), Some(yy)) = (
            out.get_mut(centres),
            xx.get(..count),
            xy.get(..count),
            yy.get(..count),
        ) else {
            return 0.0;
        };
        let norm = self.norm;
        // Bounds first (vectorised), exact values where they may matter.
        for ((o, &xx), &yy) in out.iter_mut().zip(xx).zip(yy) {
            *o = upper_bound(xx * norm, yy * norm);
        }
        let mut strongest = 0.0f32;
        for (o, ((&xx, &xy), &yy)) in out.iter_mut().zip(xx.iter().zip(xy).zip(yy)) {
            if *o < cut {
                continue;
            }
            let lambda = min_eigenvalue(xx * norm, xy * norm, yy * norm);
            *o = lambda;
            strongest = strongest.max(lambda);
        }
        strongest
    }
}

/// `out[i] = columns[i] + ... + columns[i + block - 1]`, added left to right
/// (`columns` holds at least `out.len() + block - 1` values).
fn box_sums(columns: &[f32], block: usize, out: &mut [f32]) {
    let n = out.len();
    if let Some(first) = columns.get(..n) {
        out.copy_from_slice(first);
    }
    for k in 1..block {
        if let Some(next) = columns.get(k..k + n) {
            for (o, &c) in out.iter_mut().zip(next) {
                *o += c;
            }
        }
    }
}

/// Sobel x of the middle row `b` (rows `a` above, `c` below) at columns
/// `1 ..= out.len()`: `(a₂ - a₀) + 2 (b₂ - b₀) + (c₂ - c₀)`.
fn sobel_x(a: &[u8], b: &[u8], c: &[u8], out: &mut [f32]) {
    let (Some((a0, a2)), Some((b0, b2)), Some((c0, c2))) = (taps(a), taps(b), taps(c)) else {
        return;
    };
    let left = a0.iter().zip(b0).zip(c0);
    let right = a2.iter().zip(b2).zip(c2);
    for (o, (((&a0, &b0), &c0), ((&a2, &b2), &c2))) in out.iter_mut().zip(left.zip(right)) {
        let [a0, b0, c0, a2, b2, c2] = [a0, b0, c0, a2, b2, c2].map(i32::from);
        *o = ((a2 - a0) + 2 * (b2 - b0) + (c2 - c0)) as f32;
    }
}

/// Sobel y at columns `1 ..= out.len()` from rows `a` above and `c` below:
/// `(c₀ + 2 c₁ + c₂) - (a₀ + 2 a₁ + a₂)`.
fn sobel_y(a: &[u8], c: &[u8], out: &mut [f32]) {
    let (Some((a0, a2)), Some((c0, c2))) = (taps(a), taps(c)) else {
        return;
    };
    let (Some(a1), Some(c1)) = (a.get(1..), c.get(1..)) else {
        return;
    };
    let above = a0.iter().zip(a1).zip(a2);
    let below = c0.iter().zip(c1).zip(c2);
    for (o, (((&a0, &a1), &a2), ((&c0, &c1), &c2))) in out.iter_mut().zip(above.zip(below)) {
        let [a0, a1, a2, c0, c1, c2] = [a0, a1, a2, c0, c1, c2].map(i32::from);
        *o = ((c0 + 2 * c1 + c2) - (a0 + 2 * a1 + a2)) as f32;
    }
}

/// The left and right neighbours of columns `1 ..= len - 2` of `row`.
fn taps(row: &[u8]) -> Option<(&[u8], &[u8])> {
    let inner = row.len().checked_sub(2)?;
    Some((row.get(..inner)?, row.get(2..)?))
}

/// The smaller eigenvalue of `[xx xy; xy yy]`, at least 0.
pub(super) fn min_eigenvalue(xx: f32, xy: f32, yy: f32) -> f32 {
    let half_diff = 0.5 * (xx - yy);
    let lambda = 0.5 * (xx + yy) - libm::sqrtf(half_diff * half_diff + xy * xy);
    lambda.max(0.0)
}

/// An upper bound of [`min_eigenvalue`]`(xx, xy, yy)` for any `xy`, with
/// `xx, yy ≥ 0`: mathematically `λmin ≤ min(xx, yy)`; the rounding of the
/// computed value (a few units in the last place of `max(xx, yy)`) is
/// covered by a margin of `2⁻¹⁸ max(xx, yy)` (64 units).
pub(super) fn upper_bound(xx: f32, yy: f32) -> f32 {
    xx.min(yy) + xx.max(yy) * (1.0 / 262_144.0)
}

/// `(s[..at], s[at..])`, or all of `s` and nothing when it is shorter.
fn split(s: &mut [f32], at: usize) -> (&mut [f32], &mut [f32]) {
    let at = at.min(s.len());
    s.split_at_mut(at)
}
