//! The Shi-Tomasi response, one row at a time, from a rolling window of
//! gradient products.
//!
//! The structure tensor of a pixel sums the Sobel gradient products over the
//! `block x block` block around it, separably: each column keeps the sum of
//! its products over the last `block` rows, updated as one row enters and
//! the row `block` above leaves (a ring of `block` rows remembers its
//! products), so the vertical cost per pixel does not depend on the block;
//! each response then adds `block` neighbouring column sums. One pass per
//! row for each of the two steps keeps the memory traffic low, which is what
//! a Cortex-M4 (no vector unit) pays for.
//!
//! Values: products are integers below `1020² < 2²⁰` and column sums of at
//! most 7 rows stay below `2²⁴`, so both are exact in `f32` (adding and
//! removing rows never drifts). The column sums are added left to right, as
//! a direct summation over the block does.
//!
//! Memory: `(3 * block + 3) * width` values whatever the height.

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
    /// The next product row to enter the window.
    next_row: usize,
    /// `1 / (64 * block²)`: Sobel's `1/8` squared and the block mean.
    norm: f32,
}

/// Scratch values [`ResponseRows`] needs for `width` columns.
pub(super) const fn window_len(width: usize, block: usize) -> usize {
    width
        .saturating_mul(3)
        .saturating_mul(block.saturating_add(1))
}

impl<'i, 's> ResponseRows<'i, 's> {
    /// A window over `image` in `scratch` (at least [`window_len`] values;
    /// `block` is odd).
    pub(super) fn new(image: &'i ImageView<'i>, block: usize, scratch: &'s mut [f32]) -> Self {
        let plane = image.width();
        let (ring, rest) = split(scratch, 3 * plane * block);
        let (column_sums, _) = split(rest, 3 * plane);
        ring.fill(0.0);
        column_sums.fill(0.0);
        ResponseRows {
            image,
            block,
            ring,
            column_sums,
            // Row 0 has no Sobel gradient: its products are the ring's zeros.
            next_row: 1,
            norm: 1.0 / (64.0 * (block * block) as f32),
        }
    }

    /// Writes response row `y` (`width` values) into `out` and returns its
    /// largest value. Rows must be asked for in increasing order. The
    /// response is `λmin ≥ 0` where the whole block has Sobel gradients
    /// (columns and rows `r + 1 ..= size - r - 2` for `r = block / 2`) and
    /// zero elsewhere.
    pub(super) fn next(&mut self, y: usize, out: &mut [f32]) -> f32 {
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
        self.response_row(out)
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
        let (xx, rest) = slot.split_at_mut(w);
        let (xy, yy) = rest.split_at_mut(w);
        let (sxx, rest) = split(self.column_sums, w);
        let (sxy, syy) = split(rest, w);
        let rows = (
            p.checked_sub(1).and_then(|y| self.image.row(y)),
            self.image.row(p),
            self.image.row(p + 1),
        );
        let (Some(a), Some(b), Some(c)) = rows else {
            // No gradient on the last row: its products are zero.
            for (s, old) in self.column_sums.iter_mut().zip(slot.iter_mut()) {
                *s -= *old;
                *old = 0.0;
            }
            return;
        };
        // Columns 1 ..= w - 2; the outer columns have no gradient, their
        // zeros never change.
        let (Some(xx), Some(xy), Some(yy)) = (xx.get_mut(1..), xy.get_mut(1..), yy.get_mut(1..))
        else {
            return;
        };
        let (Some(sxx), Some(sxy), Some(syy)) =
            (sxx.get_mut(1..), sxy.get_mut(1..), syy.get_mut(1..))
        else {
            return;
        };
        let taps = a.windows(3).zip(b.windows(3)).zip(c.windows(3));
        let old = xx.iter_mut().zip(xy.iter_mut()).zip(yy.iter_mut());
        let sums = sxx.iter_mut().zip(sxy.iter_mut()).zip(syy.iter_mut());
        for (((a, b), c), (((oxx, oxy), oyy), ((sxx, sxy), syy))) in taps.zip(old.zip(sums)) {
            let (&[a0, a1, a2], &[b0, _, b2], &[c0, c1, c2]) = (a, b, c) else {
                continue;
            };
            let [a0, a1, a2, b0, b2, c0, c1, c2] = [a0, a1, a2, b0, b2, c0, c1, c2].map(i32::from);
            let gx = ((a2 - a0) + 2 * (b2 - b0) + (c2 - c0)) as f32;
            let gy = ((c0 + 2 * c1 + c2) - (a0 + 2 * a1 + a2)) as f32;
            let (nxx, nxy, nyy) = (gx * gx, gx * gy, gy * gy);
            *sxx = *sxx - *oxx + nxx;
            *sxy = *sxy - *oxy + nxy;
            *syy = *syy - *oyy + nyy;
            (*oxx, *oxy, *oyy) = (nxx, nxy, nyy);
        }
    }

    /// The block sums of the column sums and `λmin`, one pass.
    fn response_row(&self, out: &mut [f32]) -> f32 {
        let block = self.block;
        let w = self.image.width();
        // The box of column x spans x - r ..= x + r; column 0 has no
        // gradient, so boxes start at column 1 and are centred on r + 1; the
        // last ends at column w - 2.
        let count = w.saturating_sub(block + 1);
        let (xx, rest) = self.column_sums.split_at(w.min(self.column_sums.len()));
        let (xy, yy) = rest.split_at(w.min(rest.len()));
        let centres = block / 2 + 1..block / 2 + 1 + count;
        let (Some(out), Some(xx), Some(xy), Some(yy)) =
            (out.get_mut(centres), xx.get(1..), xy.get(1..), yy.get(1..))
        else {
            return 0.0;
        };
        // The block size as a constant: the sums unroll.
        match block {
            3 => boxes::<3>(xx, xy, yy, out, self.norm),
            5 => boxes::<5>(xx, xy, yy, out, self.norm),
            7 => boxes::<7>(xx, xy, yy, out, self.norm),
            _ => 0.0,
        }
    }
}

/// `out[i]` is `λmin` of the `B` columns from `i` of each plane; returns the
/// largest.
fn boxes<const B: usize>(xx: &[f32], xy: &[f32], yy: &[f32], out: &mut [f32], norm: f32) -> f32 {
    let columns = xx.windows(B).zip(xy.windows(B)).zip(yy.windows(B));
    let mut strongest = 0.0f32;
    for (o, ((xx, xy), yy)) in out.iter_mut().zip(columns) {
        let lambda = min_eigenvalue(
            sum::<B>(xx) * norm,
            sum::<B>(xy) * norm,
            sum::<B>(yy) * norm,
        );
        *o = lambda;
        strongest = strongest.max(lambda);
    }
    strongest
}

/// The first `B` values added left to right.
fn sum<const B: usize>(values: &[f32]) -> f32 {
    <&[f32; B]>::try_from(values).map_or(0.0, |v| v.iter().fold(0.0, |acc, &v| acc + v))
}

/// The smaller eigenvalue of `[xx xy; xy yy]`, at least 0.
pub(super) fn min_eigenvalue(xx: f32, xy: f32, yy: f32) -> f32 {
    let half_diff = 0.5 * (xx - yy);
    let lambda = 0.5 * (xx + yy) - crate::fsqrt::sqrtf(half_diff * half_diff + xy * xy);
    lambda.max(0.0)
}

/// `(s[..at], s[at..])`, or all of `s` and nothing when it is shorter.
fn split(s: &mut [f32], at: usize) -> (&mut [f32], &mut [f32]) {
    let at = at.min(s.len());
    s.split_at_mut(at)
}
