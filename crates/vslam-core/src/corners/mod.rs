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
//! The image is streamed row by row (module `response`): running column sums of
//! the gradient products give one response row at a time, three response rows
//! feed the 3x3 maximum test, and the maxima go straight to the output list
//! (module `select`). The quality threshold needs the strongest response of the
//! whole image, known only at the end: candidates are offered against the
//! threshold of the strongest response seen so far (never above the final
//! one), and the list is cut at the final threshold. A candidate only ever
//! displaces weaker ones, so this keeps exactly the corners a pass over a
//! whole response image would.
//!
//! No heap: the caller lends a scratch `f32` buffer of
//! [`scratch_len`]`(width, height, block_size)` elements, `(3 * block_size +
//! 6) * width` (2,400 values, 9,600 bytes, for 160-pixel rows and 3x3
//! blocks), independent of the height; the output slice is the candidate list.

use core::fmt;

mod response;
mod select;
#[cfg(test)]
mod tests;

use response::{ResponseRows, window_len};
use select::RasterList;

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

/// Scratch `f32` elements [`detect_corners`] needs for `width`-pixel rows:
/// `block_size` rows of three gradient products, their column sums and three
/// response rows. The height does not matter (it is a parameter so callers
/// size a frame without knowing the layout).
pub const fn scratch_len(width: usize, height: usize, block_size: usize) -> usize {
    let _ = height;
    window_len(width, block_size).saturating_add(width.saturating_mul(3))
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
    let border = config.border.max(1);
    if out.is_empty() || w <= 2 * border || h <= 2 * border {
        return Ok(0);
    }
    let (window, response) = scratch.split_at_mut(window_len(w, config.block_size));
    let mut rows = ResponseRows::new(image, config.block_size, window);
    let (first, rest) = response.split_at_mut(w);
    let (second, third) = rest.split_at_mut(w);
    // Response rows y - 2, y - 1 and y, oldest first.
    let mut recent = [first, second, third];
    let min_dist_sq = config.min_distance * config.min_distance;
    // Never above the final threshold: the strongest response can only grow.
    let provisional = |strongest: f32| (config.quality_level * strongest).max(config.min_response);
    let mut strongest = 0.0f32;
    let mut list = RasterList::new(out, min_dist_sq);
    for y in 0..h {
        recent.rotate_left(1);
        let [above, row, below] = &mut recent;
        strongest = strongest.max(rows.next(y, below));
        // Row y - 1 now has both neighbours.
        let Some(centre) = y.checked_sub(1) else {
            continue;
        };
        if centre < border || centre >= h - border {
            continue;
        }
        let threshold = provisional(strongest);
        for x in border..w - border {
            let Some(response) = local_maximum(above, row, below, x, threshold) else {
                continue;
            };
            let c = Corner {
                x,
                y: centre,
                response,
            };
            list.offer(c);
        }
    }
    let kept = list.finish();
    let textured = strongest >= config.min_response && strongest > 0.0;
    if !textured {
        return Ok(0);
    }
    let threshold = (config.quality_level * strongest).max(config.min_response);
    Ok(out
        .get(..kept)
        .map_or(0, |list| list.partition_point(|c| c.response >= threshold)))
}

/// The response at column `x` of `row` if it reaches `threshold` and no
/// 3x3 neighbour's (in `above`, `row`, `below`) is higher.
fn local_maximum(
    above: &[f32],
    row: &[f32],
    below: &[f32],
    x: usize,
    threshold: f32,
) -> Option<f32> {
    let v = *row.get(x)?;
    if v < threshold {
        return None;
    }
    let columns = x.checked_sub(1)?..x + 2;
    let (a, r, b) = (
        above.get(columns.clone())?,
        row.get(columns.clone())?,
        below.get(columns)?,
    );
    let mut neighbours = a.iter().chain(r).chain(b);
    neighbours.all(|&n| v >= n).then_some(v)
}
