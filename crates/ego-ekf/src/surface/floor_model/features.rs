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

/// The features of map cell `(cx, cy)` (cell `CELL` px square) of `image`.
pub fn cell_features(image: &ImageView<'_>, cx: usize, cy: usize) -> [f32; FEATURES] {
    let mut f = [0.0f32; FEATURES];
    let mut means = [0.0f32; WINDOWS.len()];
    for (k, &half) in WINDOWS.iter().enumerate() {
        let s = window_sums(image, cx, cy, half);
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
    f[FEATURES - 1] = (cy * CELL + CELL / 2) as f32 / image.height() as f32;
    f
}
