//! Optical flow from a flow sensor's raw frames: corners in the previous
//! 35x35 frame, pyramidal Lucas-Kanade into the next one, one
//! [`FeatureMotion`] per tracked corner.
//!
//! The frames are the PixArt PMW3901MB / PAA5100JE raw-data grab (35 x 35
//! pixels, one byte each; PMW3901MB-TXQT datasheet, "Frame Capture"), the
//! optics a 42 degree field of view across the 35 pixels (the datasheet's
//! FOV), so the angular pixel pitch at the centre is
//! `1 / f` with `f = 17.5 / tan(21 deg)` = 45.6 px ([`RADIANS_PER_PIXEL`]).
//! The method is the seed's (corners, Lucas-Kanade between frames, each
//! feature's speed and direction, a robust displacement): J. Shi and C.
//! Tomasi, "Good Features to Track", CVPR 1994, and J.-Y. Bouguet,
//! "Pyramidal Implementation of the Lucas Kanade Feature Tracker", 2000
//! ([`crate::corners`], [`crate::lk`]). The robust combination into metres
//! is [`crate::scale::raw_flow`].
//!
//! Tuned for the small frame ([`FrameFlowConfig::default`]):
//! 1. each frame loses its 11x11 local mean ([`high_pass`]): the LED's
//!    fall-off and the exposure stay where they are while the floor moves,
//!    and would pull the tracker towards zero;
//! 2. the whole frame's integer shift by block matching (least mean
//!    absolute difference over shifts up to [`MAX_SHIFT`] px, ties towards
//!    the previous pair's motion; [`global_shift`]), as the sensor chip
//!    itself correlates frames: it seeds every point, so motions of 14 px a
//!    frame (0.9 m/s at 100 frames a second) converge; a match no more
//!    distinct than [`MIN_DISTINCTNESS`] ([`ShiftMatch`]: glazed tile,
//!    frames of noise) makes the pair `textureless`, with no features;
//! 3. Shi-Tomasi corners 3 px apart at least 5 px inside the frame;
//! 4. Lucas-Kanade with a 7x7 window over two pyramid levels (35 and 18 px;
//!    a third level of 9 px averages the floor's fine texture away and
//!    drags good seeds to wrong minima), no forward-backward check (its
//!    backward pass starts without the seed).
//!
//! No heap, no panic: the previous frame is kept by value (1,225 bytes), the
//! pyramids are built on the stack per pair.

use core::fmt;

use crate::corners::{Corner, CornerConfig, CornerError, border_for_window, detect_corners};
use crate::geometry::Vec2;
use crate::image::ImageView;
use crate::lk::{Illumination, LkConfig, LkConfigError, TrackResult, Tracker};
use crate::pyramid::{Pyramid, storage_bytes};
use crate::scale::raw_flow::{FeatureMotion, MAX_FEATURES, RawFlowOptics, combine};
use crate::sensors::{FLOW_FRAME_LEN, FLOW_FRAME_SIDE, FlowOptics};
use crate::time::Timestamp;

/// Field of view across the raw frame, radians (42 degrees, PMW3901MB datasheet).
pub const FIELD_OF_VIEW: f32 = 42.0 * core::f32::consts::PI / 180.0;

/// Focal length of the raw frame in pixels: `17.5 / tan(21 deg)`.
pub const FOCAL_PX: f32 = 45.588;

/// Angular pixel pitch at the frame's centre, radians per pixel (`1 / FOCAL_PX`).
pub const RADIANS_PER_PIXEL: f32 = 1.0 / FOCAL_PX;

/// Least distinctness of the whole-frame block match ([`ShiftMatch`]) for
/// a pair to be tracked (the default of
/// [`FrameFlowConfig::min_distinctness`]).
pub const MIN_DISTINCTNESS: f32 = 0.28;

/// Fewest tracked features a frame pair needs to give a displacement.
pub const MIN_FEATURES: u8 = 3;

/// The raw frames' optics for [`crate::scale::raw_flow`]: the counting
/// optics' height and mounting (the same sensor), the frame's angular pixel
/// pitch, [`MIN_FEATURES`].
pub fn raw_optics(counting: &FlowOptics) -> Option<RawFlowOptics> {
    RawFlowOptics::new(
        RADIANS_PER_PIXEL,
        counting.height(),
        *counting.mount(),
        MIN_FEATURES,
    )
}

/// Pyramid levels used (35 and 18 pixels).
pub const LEVELS: usize = 2;

/// Most corners tracked per frame pair.
pub const MAX_CORNERS: usize = 32;

const SCRATCH: usize = crate::corners::scratch_len(FLOW_FRAME_SIDE, FLOW_FRAME_SIDE, 3);
const PYRAMID_BYTES: usize = storage_bytes(FLOW_FRAME_SIDE, FLOW_FRAME_SIDE, LEVELS);

/// Corner and tracker settings for raw frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameFlowConfig {
    /// Corner selection (block size 3; the scratch is sized for it).
    pub corners: CornerConfig,
    /// The tracker.
    pub lk: LkConfig,
    /// Least block-match distinctness ([`ShiftMatch`]) a pair needs to be
    /// tracked; below it the pair is textureless.
    pub min_distinctness: f32,
}

impl Default for FrameFlowConfig {
    /// The small-frame tuning of the module docs.
    fn default() -> Self {
        let window = 7;
        FrameFlowConfig {
            corners: CornerConfig {
                quality_level: 0.02,
                min_distance: 3.0,
                block_size: 3,
                border: border_for_window(window),
                min_response: 0.25,
            },
            lk: LkConfig {
                window,
                levels: LEVELS,
                max_iterations: 20,
                epsilon: 0.01,
                coarse_epsilon: Some(0.05),
                min_eigenvalue: 0.02,
                max_residual: 24.0,
                affine_refinement: false,
                fb_threshold: None,
                illumination: Illumination::Constant,
            },
            min_distinctness: MIN_DISTINCTNESS,
        }
    }
}

/// Why a frame could not be used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrameFlowError {
    /// The settings are invalid.
    Config(LkConfigError),
    /// The corner settings are invalid.
    Corners(CornerError),
    /// The frame's time is not after the previous frame's.
    OutOfOrder,
}

impl fmt::Display for FrameFlowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameFlowError::Config(e) => write!(f, "raw-frame tracker: {e}"),
            FrameFlowError::Corners(e) => write!(f, "raw-frame corners: {e}"),
            FrameFlowError::OutOfOrder => f.write_str("raw frame not after the previous one"),
        }
    }
}

impl core::error::Error for FrameFlowError {}

/// The motion of one frame pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePairMotion {
    /// The previous frame's time.
    pub t0: Timestamp,
    /// This frame's time.
    pub t1: Timestamp,
    features: [FeatureMotion; MAX_CORNERS],
    tracked: usize,
    /// Corners found in the previous frame.
    pub corners: usize,
    /// The whole-frame block match's distinctness ([`ShiftMatch`]).
    pub distinctness: f32,
    /// Refused for want of texture: the block match was less distinct than
    /// [`FrameFlowConfig::min_distinctness`]; the pair has no features.
    pub textureless: bool,
}

impl FramePairMotion {
    /// The tracked features' image displacements, pixels (the floor's motion
    /// in the image, opposite to the sensor's).
    pub fn features(&self) -> &[FeatureMotion] {
        self.features.get(..self.tracked).unwrap_or(&[])
    }
}

/// The raw-frame tracker: keeps the previous frame.
#[derive(Clone, Debug)]
pub struct FrameFlow {
    tracker: Tracker,
    corners: CornerConfig,
    min_distinctness: f32,
    prev: [u8; FLOW_FRAME_LEN],
    prev_t: Option<Timestamp>,
    /// Median image velocity of the last tracked pair, pixels per second.
    velocity: Vec2,
}

const _: () = assert!(MAX_CORNERS <= MAX_FEATURES);

impl FrameFlow {
    /// A tracker with `config` (checked here).
    pub fn new(config: FrameFlowConfig) -> Result<Self, FrameFlowError> {
        config.corners.validate().map_err(FrameFlowError::Corners)?;
        if config.corners.block_size != 3 {
            return Err(FrameFlowError::Corners(CornerError::BlockSize));
        }
        let lk = LkConfig {
            levels: config.lk.levels.min(LEVELS),
            ..config.lk
        };
        Ok(FrameFlow {
            tracker: Tracker::new(lk).map_err(FrameFlowError::Config)?,
            corners: config.corners,
            min_distinctness: config.min_distinctness,
            prev: [0; FLOW_FRAME_LEN],
            prev_t: None,
            velocity: Vec2::zeros(),
        })
    }

    /// Forgets the previous frame (after a gap, a wake, a lift).
    pub fn reset(&mut self) {
        self.prev_t = None;
        self.velocity = Vec2::zeros();
    }

    /// Takes the frame grabbed at `t`: the motion since the previous frame,
    /// or `None` for the first. A frame not after the previous one is
    /// refused and not kept.
    pub fn push(
        &mut self,
        t: Timestamp,
        frame: &[u8; FLOW_FRAME_LEN],
    ) -> Result<Option<FramePairMotion>, FrameFlowError> {
        let Some(t0) = self.prev_t else {
            high_pass(frame, &mut self.prev);
            self.prev_t = Some(t);
            return Ok(None);
        };
        let Some(dt) = t.seconds_since(t0).filter(|dt| *dt > 0.0) else {
            return Err(FrameFlowError::OutOfOrder);
        };
        let mut current = [0u8; FLOW_FRAME_LEN];
        high_pass(frame, &mut current);
        let motion = self.track(t0, t, dt, &current);
        self.prev = current;
        self.prev_t = Some(t);
        Ok(Some(motion))
    }

    fn track(
        &mut self,
        t0: Timestamp,
        t1: Timestamp,
        dt: f32,
        frame: &[u8; FLOW_FRAME_LEN],
    ) -> FramePairMotion {
        let mut out = FramePairMotion {
            t0,
            t1,
            features: [FeatureMotion::default(); MAX_CORNERS],
            tracked: 0,
            corners: 0,
            distinctness: 0.0,
            textureless: false,
        };
        let (Ok(prev), Ok(next)) = (
            ImageView::packed(&self.prev, FLOW_FRAME_SIDE, FLOW_FRAME_SIDE),
            ImageView::packed(frame, FLOW_FRAME_SIDE, FLOW_FRAME_SIDE),
        ) else {
            return out;
        };
        let mut scratch = [0f32; SCRATCH];
        let mut corners = [Corner::default(); MAX_CORNERS];
        let found = detect_corners(&prev, &self.corners, &mut scratch, &mut corners).unwrap_or(0);
        out.corners = found;
        let levels = self.tracker.config().levels;
        let (mut sa, mut sb) = ([0u8; PYRAMID_BYTES], [0u8; PYRAMID_BYTES]);
        let (Ok(pa), Ok(pb)) = (
            Pyramid::build_in(&prev, levels, &mut sa),
            Pyramid::build_in(&next, levels, &mut sb),
        ) else {
            return out;
        };
        // The whole frame's shift by block matching seeds every point; the
        // previous pair's velocity breaks near-ties.
        let matched = global_match(&prev, &next, self.velocity * dt);
        out.distinctness = matched.distinctness;
        if matched.distinctness.is_nan() || matched.distinctness < self.min_distinctness {
            // No texture the match can hold on to: no features, and the
            // pair says so.
            out.textureless = true;
            self.velocity = Vec2::zeros();
            return out;
        }
        let shift = matched.shift;
        let mut points = [Vec2::zeros(); MAX_CORNERS];
        let mut guesses = [Vec2::zeros(); MAX_CORNERS];
        for ((c, p), g) in corners
            .iter()
            .take(found)
            .zip(points.iter_mut())
            .zip(guesses.iter_mut())
        {
            *p = c.position();
            *g = *p + shift;
        }
        let mut results = [TrackResult::EMPTY; MAX_CORNERS];
        let (Some(pts), Some(gs)) = (points.get(..found), guesses.get(..found)) else {
            return out;
        };
        if self
            .tracker
            .track_with_guesses(&pa, &pb, pts, gs, &mut results)
            .is_err()
        {
            return out;
        }
        let mut n = 0;
        for (r, p) in results.iter().zip(pts) {
            let d = r.position - *p;
            if !r.status.is_tracked() || !d.x.is_finite() || !d.y.is_finite() {
                continue;
            }
            if let Some(slot) = out.features.get_mut(n) {
                *slot = FeatureMotion { dx: d.x, dy: d.y };
                n += 1;
            }
        }
        out.tracked = n;
        self.velocity = match combine(out.features()) {
            Some(e) => e.median_px / dt,
            None => Vec2::zeros(),
        };
        out
    }
}

/// Largest shift [`global_shift`] tries, pixels (0.9 m/s at 100 frames a
/// second and 30 mm).
pub const MAX_SHIFT: i32 = 14;

/// Levels of mean absolute difference a shift pays per squared pixel away
/// from the prior: breaks near-ties of periodic floors (tile
/// joints) towards the previous motion.
const PRIOR_WEIGHT: f32 = 0.003;

/// The integer shift of `b` against `a` (pixels of these images) with the
/// least mean absolute difference over the overlap, plus
/// [`PRIOR_WEIGHT`] per squared pixel from `prior`, among shifts up to
/// [`MAX_SHIFT`] whose overlap keeps at least a third of the image;
/// ties keep the shift nearest `prior`. Images of different sizes give
/// `prior`.
pub fn global_shift(a: &ImageView<'_>, b: &ImageView<'_>, prior: Vec2) -> Vec2 {
    global_match(a, b, prior).shift
}

/// The block match of [`global_shift`]: the shift and how distinct it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShiftMatch {
    /// The shift, pixels.
    pub shift: Vec2,
    /// `1 - best / mean` of the mean absolute differences over every shift
    /// tried: near 0 when every shift matches about as well (a floor
    /// without texture the sensor resolves, or blurred away), towards 1
    /// for one sharp match.
    pub distinctness: f32,
}

/// [`global_shift`] with the match's distinctness ([`ShiftMatch`]); images
/// of different sizes give `prior` with distinctness 0.
pub fn global_match(a: &ImageView<'_>, b: &ImageView<'_>, prior: Vec2) -> ShiftMatch {
    let none = ShiftMatch {
        shift: prior,
        distinctness: 0.0,
    };
    let (w, h) = (a.width(), a.height());
    if (w, h) != (b.width(), b.height()) || w == 0 || h == 0 {
        return none;
    }
    let (wi, hi) = (w as i32, h as i32);
    let min_overlap = (w * h / 3) as i32;
    let mut best = (f32::INFINITY, f32::INFINITY, prior, 0f32);
    let (mut mad_sum, mut tried) = (0f32, 0u32);
    for dy in -MAX_SHIFT..=MAX_SHIFT {
        for dx in -MAX_SHIFT..=MAX_SHIFT {
            let (ow, oh) = (wi - dx.abs(), hi - dy.abs());
            if ow * oh < min_overlap {
                continue;
            }
            let mut sad = 0u32;
            for y in dy.max(0)..(hi + dy).min(hi) {
                let (Some(ra), Some(rb)) = (a.row((y - dy) as usize), b.row(y as usize)) else {
                    continue;
                };
                let (xa, xb) = ((-dx).max(0) as usize, dx.max(0) as usize);
                let n = ow as usize;
                if let (Some(sa), Some(sb)) = (ra.get(xa..xa + n), rb.get(xb..xb + n)) {
                    sad += crate::sad::sad(sa, sb);
                }
            }
            let d = Vec2::new(dx as f32, dy as f32);
            let from_prior = (d - prior).norm_squared();
            let mad = sad as f32 / (ow * oh) as f32;
            mad_sum += mad;
            tried += 1;
            let cost = mad + PRIOR_WEIGHT * from_prior;
            if cost < best.0 || (cost == best.0 && from_prior < best.1) {
                best = (cost, from_prior, d, mad);
            }
        }
    }
    let mean = mad_sum / tried.max(1) as f32;
    if tried == 0 || mean.is_nan() || mean <= 0.0 {
        return none;
    }
    ShiftMatch {
        shift: best.2,
        distinctness: 1.0 - best.3 / mean,
    }
}

/// Half the side of the box whose mean [`high_pass`] removes (11 x 11).
const BOX_HALF: usize = 5;

/// Removes each pixel's 11x11 neighbourhood mean (edges: the part inside the
/// frame) and doubles the rest around 128: the LED's fall-off towards the
/// frame's corners and the exposure's changes are slow and would otherwise
/// pull the tracker towards zero motion, since they stay where they are
/// while the floor moves.
pub fn high_pass(frame: &[u8; FLOW_FRAME_LEN], out: &mut [u8; FLOW_FRAME_LEN]) {
    const W: usize = FLOW_FRAME_SIDE + 1;
    // Integral image with a zero first row and column.
    let mut sum = [0u32; W * W];
    for y in 0..FLOW_FRAME_SIDE {
        let mut row = 0u32;
        for x in 0..FLOW_FRAME_SIDE {
            row += u32::from(frame.get(y * FLOW_FRAME_SIDE + x).copied().unwrap_or(0));
            let above = sum.get(y * W + x + 1).copied().unwrap_or(0);
            if let Some(s) = sum.get_mut((y + 1) * W + x + 1) {
                *s = above + row;
            }
        }
    }
    let at = |x: usize, y: usize| sum.get(y * W + x).copied().unwrap_or(0);
    for (i, o) in out.iter_mut().enumerate() {
        let (x, y) = (i % FLOW_FRAME_SIDE, i / FLOW_FRAME_SIDE);
        let (x0, y0) = (x.saturating_sub(BOX_HALF), y.saturating_sub(BOX_HALF));
        let (x1, y1) = (
            (x + BOX_HALF + 1).min(FLOW_FRAME_SIDE),
            (y + BOX_HALF + 1).min(FLOW_FRAME_SIDE),
        );
        let total = (at(x1, y1) + at(x0, y0)).saturating_sub(at(x0, y1) + at(x1, y0));
        let n = ((x1 - x0) * (y1 - y0)) as f32;
        let p = f32::from(frame.get(i).copied().unwrap_or(0));
        *o = (128.0 + 2.0 * (p - total as f32 / n)).clamp(0.0, 255.0) as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bilinear value noise on a 3-pixel lattice (a floor-like texture
    /// without periods), shifted by `(sx, sy)` pixels.
    fn pattern(sx: f32, sy: f32) -> [u8; FLOW_FRAME_LEN] {
        let lattice = |i: i32, j: i32| -> f32 {
            let mut z = (i as u32).wrapping_mul(0x9E37_79B9) ^ (j as u32).wrapping_mul(0x85EB_CA6B);
            z = (z ^ (z >> 15)).wrapping_mul(0x2C1B_3C6D);
            z ^= z >> 12;
            (z % 1000) as f32 / 1000.0
        };
        let mut f = [0u8; FLOW_FRAME_LEN];
        for (i, p) in f.iter_mut().enumerate() {
            let x = ((i % FLOW_FRAME_SIDE) as f32 - sx) / 3.0 + 50.0;
            let y = ((i / FLOW_FRAME_SIDE) as f32 - sy) / 3.0 + 50.0;
            let (x0, y0) = (libm::floorf(x), libm::floorf(y));
            let (fx, fy) = (x - x0, y - y0);
            let (xi, yi) = (x0 as i32, y0 as i32);
            let top = lattice(xi, yi) * (1.0 - fx) + lattice(xi + 1, yi) * fx;
            let bottom = lattice(xi, yi + 1) * (1.0 - fx) + lattice(xi + 1, yi + 1) * fx;
            *p = (40.0 + 170.0 * (top * (1.0 - fy) + bottom * fy)) as u8;
        }
        f
    }

    #[test]
    fn a_shift_is_tracked_by_every_feature() {
        let mut ff = FrameFlow::new(FrameFlowConfig::default()).unwrap();
        assert_eq!(ff.push(Timestamp(0), &pattern(0.0, 0.0)), Ok(None));
        let m = ff
            .push(Timestamp(10_000_000), &pattern(2.5, -1.25))
            .unwrap()
            .unwrap();
        assert!(
            m.features().len() >= 8,
            "{} of {}",
            m.features().len(),
            m.corners
        );
        assert!(!m.textureless && m.distinctness > MIN_DISTINCTNESS, "{m:?}");
        let e = combine(m.features()).unwrap();
        assert!((e.median_px - Vec2::new(2.5, -1.25)).norm() < 0.1, "{e:?}");
        // The next pair starts from the previous motion: 6 px more.
        let m = ff
            .push(Timestamp(20_000_000), &pattern(8.5, -1.25))
            .unwrap()
            .unwrap();
        let e = combine(m.features()).unwrap();
        assert!((e.median_px - Vec2::new(6.0, 0.0)).norm() < 0.15, "{e:?}");
    }

    #[test]
    fn large_shifts_are_found_by_the_block_match() {
        for (sx, sy) in [(7.3f32, 0.4f32), (-11.6, 1.0), (12.0, -3.0)] {
            let mut ff = FrameFlow::new(FrameFlowConfig::default()).unwrap();
            ff.push(Timestamp(0), &pattern(0.0, 0.0)).unwrap();
            let m = ff
                .push(Timestamp(10_000_000), &pattern(sx, sy))
                .unwrap()
                .unwrap();
            // Most corners leave the frame; those that stay are found.
            assert!(m.features().len() >= 4, "{sx}, {sy}: {m:?}");
            let e = combine(m.features()).unwrap();
            assert!((e.median_px - Vec2::new(sx, sy)).norm() < 0.1, "{e:?}");
        }
    }

    #[test]
    fn frames_of_noise_alone_are_textureless_and_give_no_features() {
        // Independent noise in each frame (a floor the sensor does not
        // resolve): every shift matches about as well.
        let mut state = 12_345u32;
        let mut noise = || {
            let mut f = [0u8; FLOW_FRAME_LEN];
            for p in f.iter_mut() {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *p = 100 + (state >> 27) as u8;
            }
            f
        };
        let mut ff = FrameFlow::new(FrameFlowConfig::default()).unwrap();
        ff.push(Timestamp(0), &noise()).unwrap();
        for k in 1..5u64 {
            let m = ff
                .push(Timestamp(k * 10_000_000), &noise())
                .unwrap()
                .unwrap();
            assert!(m.textureless && m.distinctness < MIN_DISTINCTNESS, "{m:?}");
            assert!(m.features().is_empty());
        }
    }

    #[test]
    fn blank_frames_and_time_going_back_give_no_features_or_errors() {
        let mut ff = FrameFlow::new(FrameFlowConfig::default()).unwrap();
        ff.push(Timestamp(5), &[40; FLOW_FRAME_LEN]).unwrap();
        let m = ff
            .push(Timestamp(6), &[40; FLOW_FRAME_LEN])
            .unwrap()
            .unwrap();
        assert_eq!((m.corners, m.features().len()), (0, 0));
        assert!(m.textureless);
        assert_eq!(
            ff.push(Timestamp(6), &pattern(0.0, 0.0)),
            Err(FrameFlowError::OutOfOrder)
        );
        assert!((RADIANS_PER_PIXEL * 17.5 - libm::tanf(FIELD_OF_VIEW / 2.0)).abs() < 1e-4);
    }
}
