//! Shi-Tomasi corners: features worth tracking.
//!
//! J. Shi and C. Tomasi, "Good Features to Track", CVPR 1994: a window can be
//! tracked when both eigenvalues of its gradient structure tensor
//! `G = sum [gx² gx·gy; gx·gy gy²]` are large, so the response is the smaller
//! eigenvalue `λmin = (gxx + gyy)/2 - sqrt(((gxx - gyy)/2)² + gxy²)`. This is
//! the criterion the Lucas-Kanade tracker itself needs (its `G` must be well
//! conditioned), and what OpenCV's `goodFeaturesToTrack` computes.
//!
//! Gradients are 3x3 Sobel divided by 8 (intensity levels per pixel), the
//! tensor is the mean over a `block_size x block_size` block, so responses are
//! in (levels/pixel)² whatever the block size. Selection:
//! 1. keep 3x3 local maxima at least `border` pixels inside the image whose
//!    response reaches `quality_level` times the strongest response (and the
//!    absolute floor `min_response`, so a textureless image yields nothing);
//! 2. visit them in raster order and keep a list sorted strongest first: a
//!    candidate closer than `min_distance` to a kept corner at least as strong
//!    is dropped, weaker kept corners within `min_distance` of it are evicted,
//!    and when the list is full the weakest falls off.
//!
//! The result: corners at least `min_distance` apart, strongest first, ties in
//! raster order, deterministic. It approximates OpenCV's global greedy pass
//! (which sorts every candidate) without a candidate buffer.
//!
//! No heap: the caller lends a scratch `f32` buffer of
//! [`scratch_len`]`(width, height, block_size)` elements (the response image
//! plus a few rows of gradient products).

use core::fmt;

use crate::geometry::Vec2;
use crate::image::ImageView;

/// One detected corner, at integer pixel coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Corner {
    /// Column.
    pub x: usize,
    /// Row.
    pub y: usize,
    /// Shi-Tomasi response `λmin`, (levels/pixel)².
    pub response: f32,
}

impl Corner {
    /// The position as a point for the tracker (`x` right, `y` down).
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x as f32, self.y as f32)
    }
}

/// How corners are picked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerConfig {
    /// Keep responses of at least this fraction of the strongest, in `(0, 1]`.
    pub quality_level: f32,
    /// Minimum Euclidean distance between kept corners, pixels, `>= 0`.
    pub min_distance: f32,
    /// Side of the block the structure tensor is averaged over: 3, 5 or 7.
    pub block_size: usize,
    /// Corners keep at least this many pixels from every edge.
    pub border: usize,
    /// Absolute response floor, (levels/pixel)², `>= 0`.
    pub min_response: f32,
}

/// The border that lets the tracker read its whole level-0 window around a
/// corner: half the window, one pixel for the template's Scharr gradients and
/// one for the right/bottom bilinear neighbour.
pub const fn border_for_window(window: usize) -> usize {
    window / 2 + 2
}

impl Default for CornerConfig {
    /// OpenCV's usual choice: quality 0.01, 10 px apart, 3x3 blocks; a
    /// border of [`border_for_window`] of the default tracker window (12 px
    /// for 21x21, so every corner can be tracked), response floor 1 (level/px)².
    fn default() -> Self {
        CornerConfig {
            quality_level: 0.01,
            min_distance: 10.0,
            block_size: 3,
            border: border_for_window(LK_DEFAULT_WINDOW),
            min_response: 1.0,
        }
    }
}

/// The window of [`crate::lk::LkConfig::default`].
const LK_DEFAULT_WINDOW: usize = 21;

/// Why corners could not be detected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CornerError {
    /// `quality_level` is not in `(0, 1]`.
    QualityLevel,
    /// `min_distance` is negative or not finite.
    MinDistance,
    /// `block_size` is not 3, 5 or 7.
    BlockSize,
    /// `min_response` is negative or not finite.
    MinResponse,
    /// The scratch buffer is shorter than [`scratch_len`].
    ScratchTooSmall {
        /// Elements needed.
        needed: usize,
        /// Elements given.
        got: usize,
    },
}

impl fmt::Display for CornerError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CornerError::QualityLevel => f.write_str("corner quality level must be in (0, 1]"),
            CornerError::MinDistance => {
                f.write_str("corner minimum distance must be finite and non-negative")
            }
            CornerError::BlockSize => f.write_str("corner block size must be 3, 5 or 7"),
            CornerError::MinResponse => {
                f.write_str("corner response floor must be finite and non-negative")
            }
            CornerError::ScratchTooSmall { needed, got } => write!(
                f,
                "corner scratch holds {got} values, the image needs {needed}"
            ),
        }
    }
}

impl core::error::Error for CornerError {}

impl CornerConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), CornerError> {
        if !(self.quality_level > 0.0 && self.quality_level <= 1.0) {
            return Err(CornerError::QualityLevel);
        }
        if !(self.min_distance.is_finite() && self.min_distance >= 0.0) {
            return Err(CornerError::MinDistance);
        }
        if !matches!(self.block_size, 3 | 5 | 7) {
            return Err(CornerError::BlockSize);
        }
        if !(self.min_response.is_finite() && self.min_response >= 0.0) {
            return Err(CornerError::MinResponse);
        }
        Ok(())
    }
}

/// Scratch `f32` elements [`detect_corners`] needs: the response image plus
/// `block_size + 1` rows of three gradient products.
pub const fn scratch_len(width: usize, height: usize, block_size: usize) -> usize {
    width.saturating_mul(height).saturating_add(
        width
            .saturating_mul(3)
            .saturating_mul(block_size.saturating_add(1)),
    )
}

/// Detects up to `out.len()` corners in `image`, writes them strongest first
/// into `out` and returns how many were written.
pub fn detect_corners(
    image: &ImageView<'_>,
    config: &CornerConfig,
    scratch: &mut [f32],
    out: &mut [Corner],
) -> Result<usize, CornerError> {
    config.validate()?;
    let (w, h) = (image.width(), image.height());
    let needed = scratch_len(w, h, config.block_size);
    let got = scratch.len();
    let scratch = scratch
        .get_mut(..needed)
        .ok_or(CornerError::ScratchTooSmall { needed, got })?;
    let (response, products) = scratch
        .split_at_mut_checked(w * h)
        .ok_or(CornerError::ScratchTooSmall { needed, got })?;
    let strongest = min_eigenvalue_image(image, config.block_size, response, products);
    let textured = strongest >= config.min_response && strongest > 0.0;
    if !textured || out.is_empty() {
        return Ok(0);
    }
    let threshold = (config.quality_level * strongest).max(config.min_response);
    let min_dist_sq = config.min_distance * config.min_distance;
    let border = config.border.max(1);
    let mut kept = 0usize;
    if w <= 2 * border || h <= 2 * border {
        return Ok(0);
    }
    for y in border..h - border {
        let rows = (
            response.get((y - 1) * w..y * w),
            response.get(y * w..(y + 1) * w),
            response.get((y + 1) * w..(y + 2) * w),
        );
        let (Some(above), Some(row), Some(below)) = rows else {
            continue;
        };
        let triples = above
            .windows(3)
            .zip(row.windows(3))
            .zip(below.windows(3))
            .enumerate()
            .skip(border - 1)
            .take(w - 2 * border);
        for (x0, ((a, r), b)) in triples {
            let (&[a0, a1, a2], &[r0, v, r2], &[b0, b1, b2]) = (a, r, b) else {
                continue;
            };
            if v < threshold {
                continue;
            }
            let is_max = [a0, a1, a2, r0, r2, b0, b1, b2].iter().all(|&n| v >= n);
            if is_max {
                let c = Corner {
                    x: x0 + 1,
                    y,
                    response: v,
                };
                kept = offer(out, kept, c, min_dist_sq);
            }
        }
    }
    Ok(kept)
}

fn dist_sq(a: &Corner, b: &Corner) -> f32 {
    let dx = a.x as f32 - b.x as f32;
    let dy = a.y as f32 - b.y as f32;
    dx * dx + dy * dy
}

/// Offers `c` to the sorted list `out[..kept]`; returns the new length.
fn offer(out: &mut [Corner], kept: usize, c: Corner, min_dist_sq: f32) -> usize {
    let cap = out.len();
    let Some(list) = out.get_mut(..kept) else {
        return kept;
    };
    if kept == cap
        && list
            .last()
            .is_some_and(|weakest| weakest.response >= c.response)
    {
        return kept;
    }
    let blocked = list
        .iter()
        .any(|k| k.response >= c.response && dist_sq(k, &c) < min_dist_sq);
    if blocked {
        return kept;
    }
    // Evict weaker corners within reach, keeping the order.
    let mut n = 0;
    for i in 0..kept {
        let Some(&k) = list.get(i) else { break };
        if !(k.response < c.response && dist_sq(&k, &c) < min_dist_sq) {
            if let Some(slot) = list.get_mut(n) {
                *slot = k;
            }
            n += 1;
        }
    }
    // Insert after every corner at least as strong.
    let at = list
        .get(..n)
        .map_or(0, |l| l.partition_point(|k| k.response >= c.response));
    let new_len = (n + 1).min(cap);
    if let Some(tail) = out.get_mut(at..new_len) {
        tail.rotate_right(1);
        if let Some(first) = tail.first_mut() {
            *first = c;
        }
    }
    new_len
}

/// Fills `response` (`w*h`) with the Shi-Tomasi response (zero where the
/// block or the Sobel kernel leaves the image) and returns its maximum.
/// `products` holds `block + 1` rows of `3*w`.
fn min_eigenvalue_image(
    image: &ImageView<'_>,
    block: usize,
    response: &mut [f32],
    products: &mut [f32],
) -> f32 {
    let (w, h) = (image.width(), image.height());
    response.fill(0.0);
    products.fill(0.0);
    let r = block / 2;
    let Some((ring, sum)) = products.split_at_mut_checked(3 * w * block) else {
        return 0.0;
    };
    let norm = 1.0 / (64.0 * (block * block) as f32);
    let mut strongest = 0.0f32;
    for yy in 0..h {
        // Gradient products of row yy into ring slot yy % block.
        if let Some(slot) = ring.chunks_exact_mut(3 * w).nth(yy % block) {
            sobel_products(image, yy, slot);
        }
        // Rows yy-block+1 ..= yy are in the ring: response row y = yy - r.
        let Some(y) = yy.checked_sub(r) else { continue };
        if y < r + 1 || y + r + 2 > h {
            continue;
        }
        sum.fill(0.0);
        for slot in ring.chunks_exact(3 * w) {
            for (s, p) in sum.iter_mut().zip(slot) {
                *s += p;
            }
        }
        let Some(out) = response.get_mut(y * w..(y + 1) * w) else {
            continue;
        };
        let boxes = sum.windows(3 * block).step_by(3);
        // Box starting at column x0 is centred on x0 + r; keep Sobel-valid columns.
        for (o, win) in out.iter_mut().skip(r).zip(boxes).skip(1) {
            let (mut gxx, mut gxy, mut gyy) = (0.0f32, 0.0f32, 0.0f32);
            for p in win.chunks_exact(3) {
                if let &[a, b, c] = p {
                    gxx += a;
                    gxy += b;
                    gyy += c;
                }
            }
            let (gxx, gxy, gyy) = (gxx * norm, gxy * norm, gyy * norm);
            let half_diff = 0.5 * (gxx - gyy);
            let lambda = 0.5 * (gxx + gyy) - libm::sqrtf(half_diff * half_diff + gxy * gxy);
            let lambda = lambda.max(0.0);
            *o = lambda;
            strongest = strongest.max(lambda);
        }
        // The last column's box touches the Sobel-invalid border column.
        if let Some(last) = out.get_mut(w.saturating_sub(r + 1)..) {
            last.fill(0.0);
        }
    }
    strongest
}

/// Sobel products `(gx², gx·gy, gy²)` (unnormalised) of row `y`, zero where
/// the 3x3 kernel leaves the image.
fn sobel_products(image: &ImageView<'_>, y: usize, out: &mut [f32]) {
    out.fill(0.0);
    let rows = (
        y.checked_sub(1).and_then(|y| image.row(y)),
        image.row(y),
        image.row(y + 1),
    );
    let (Some(a), Some(b), Some(c)) = rows else {
        return;
    };
    let taps = a.windows(3).zip(b.windows(3)).zip(c.windows(3));
    for (o, ((a, b), c)) in out.chunks_exact_mut(3).skip(1).zip(taps) {
        let (&[a0, a1, a2], &[b0, _, b2], &[c0, c1, c2]) = (a, b, c) else {
            continue;
        };
        let [a0, a1, a2, b0, b2, c0, c1, c2] = [a0, a1, a2, b0, b2, c0, c1, c2].map(i32::from);
        let gx = (a2 - a0) + 2 * (b2 - b0) + (c2 - c0);
        let gy = (c0 + 2 * c1 + c2) - (a0 + 2 * a1 + a2);
        let (gx, gy) = (gx as f32, gy as f32);
        if let [xx, xy, yy] = o {
            *xx = gx * gx;
            *xy = gx * gy;
            *yy = gy * gy;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn detect(img: &ImageView<'_>, cfg: &CornerConfig, out: &mut [Corner]) -> usize {
        let mut scratch = [0f32; 4096];
        detect_corners(img, cfg, &mut scratch, out).unwrap()
    }

    #[test]
    fn finds_the_corners_of_a_bright_square_strongest_first() {
        let mut buf = [20u8; 40 * 40];
        for y in 12..28 {
            for x in 10..30 {
                buf[y * 40 + x] = 200;
            }
        }
        let img = ImageView::packed(&buf, 40, 40).unwrap();
        let cfg = CornerConfig {
            min_distance: 5.0,
            border: 3,
            ..CornerConfig::default()
        };
        let mut out = [Corner::default(); 8];
        let n = detect(&img, &cfg, &mut out);
        assert_eq!(n, 4, "{:?}", &out[..n]);
        for c in &out[..n] {
            let near = |a: usize, b: usize| a.abs_diff(b) <= 1;
            assert!(near(c.x, 10) || near(c.x, 29), "{c:?}");
            assert!(near(c.y, 12) || near(c.y, 27), "{c:?}");
        }
        assert!(out[..n].windows(2).all(|p| p[0].response >= p[1].response));
        // Capacity 2 keeps the two strongest.
        let mut two = [Corner::default(); 2];
        assert_eq!(detect(&img, &cfg, &mut two), 2);
        assert_eq!(&two[..], &out[..2]);
    }

    #[test]
    fn uniform_image_and_bad_config() {
        let buf = [90u8; 30 * 30];
        let img = ImageView::packed(&buf, 30, 30).unwrap();
        let mut out = [Corner::default(); 8];
        assert_eq!(detect(&img, &CornerConfig::default(), &mut out), 0);
        let mut scratch = [0f32; 10];
        assert_eq!(
            detect_corners(&img, &CornerConfig::default(), &mut scratch, &mut out),
            Err(CornerError::ScratchTooSmall {
                needed: scratch_len(30, 30, 3),
                got: 10
            })
        );
        let bad = CornerConfig {
            block_size: 4,
            ..CornerConfig::default()
        };
        assert_eq!(
            detect_corners(&img, &bad, &mut scratch, &mut out),
            Err(CornerError::BlockSize)
        );
    }

    #[test]
    fn default_border_matches_the_default_tracker_window() {
        use crate::lk::{LkConfig, LostReason, TrackResult, TrackStatus, Tracker};
        use crate::pyramid::{Pyramid, PyramidStorage};
        assert_eq!(LK_DEFAULT_WINDOW, LkConfig::default().window);
        // A texture with corners everywhere, up to the edges.
        const W: usize = 64;
        const H: usize = 48;
        let mut img = [0u8; W * H];
        let mut seed = 7u32;
        for y in 0..H {
            for x in 0..W {
                seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
                let checker = if (x / 5 + y / 4) % 2 == 0 { 60 } else { 190 };
                img[y * W + x] = (checker + (seed >> 28) as i32) as u8;
            }
        }
        let view = ImageView::packed(&img, W, H).unwrap();
        let cfg = CornerConfig::default();
        let mut out = [Corner::default(); 64];
        let n = detect(&view, &cfg, &mut out);
        assert!(n > 4, "{n}");
        let near_edge = out[..n]
            .iter()
            .map(|c| c.x.min(c.y).min(W - 1 - c.x).min(H - 1 - c.y))
            .min()
            .unwrap();
        assert_eq!(near_edge, cfg.border, "the border is reached");
        // Every corner can be tracked at level 0 (no OutOfBounds).
        let mut st = PyramidStorage::<0>::new();
        let pyr = Pyramid::build(&view, 1, &mut st).unwrap();
        let tracker = Tracker::new(LkConfig {
            levels: 1,
            ..LkConfig::default()
        })
        .unwrap();
        let mut points = [crate::geometry::Vec2::zeros(); 64];
        for (p, c) in points.iter_mut().zip(&out[..n]) {
            *p = c.position();
        }
        let mut results = [TrackResult::EMPTY; 64];
        tracker
            .track(&pyr, &pyr, &points[..n], &mut results[..n])
            .unwrap();
        for (c, r) in out[..n].iter().zip(&results[..n]) {
            assert_ne!(
                r.status,
                TrackStatus::Lost(LostReason::OutOfBounds),
                "{c:?}"
            );
        }
    }

    #[test]
    fn eviction_keeps_distance_and_order() {
        let mut out = [Corner::default(); 3];
        let mut n = 0;
        let c = |x, y, r| Corner { x, y, response: r };
        n = offer(&mut out, n, c(0, 0, 1.0), 25.0);
        n = offer(&mut out, n, c(20, 0, 2.0), 25.0);
        n = offer(&mut out, n, c(3, 0, 5.0), 25.0); // evicts (0,0)
        assert_eq!(&out[..n], &[c(3, 0, 5.0), c(20, 0, 2.0)]);
        n = offer(&mut out, n, c(22, 0, 1.0), 25.0); // blocked by (20,0)
        n = offer(&mut out, n, c(40, 0, 3.0), 25.0);
        n = offer(&mut out, n, c(60, 0, 0.5), 25.0); // full, too weak
        assert_eq!(&out[..n], &[c(3, 0, 5.0), c(40, 0, 3.0), c(20, 0, 2.0)]);
    }
}
