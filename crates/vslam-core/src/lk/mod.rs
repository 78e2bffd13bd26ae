//! Pyramidal Lucas-Kanade feature tracking.
//!
//! J.-Y. Bouguet, "Pyramidal Implementation of the Lucas Kanade Feature
//! Tracker: Description of the Algorithm", Intel Corporation, 2000. For each
//! point, from the coarsest pyramid level down to level 0:
//!
//! 1. the template window `T` around the point in the previous image and its
//!    gradients (Scharr) are sampled once per level (bilinear, subpixel), with
//!    the spatial gradient matrix `G = sum [gx² gx·gy; gx·gy gy²]`;
//! 2. the displacement is refined iteratively: `b = sum (T - J(x + d)) [gx gy]`,
//!    `d += G⁻¹ b`, until the step is below `epsilon` or `max_iterations`
//!    (a step that undoes the previous one is halved and ends the loop, as in
//!    OpenCV's `calcOpticalFlowPyrLK`);
//! 3. the result, doubled, is the guess for the next finer level.
//!
//! Each point gets a [`TrackStatus`] (tracked, or lost with a [`LostReason`])
//! and the residual: the mean absolute intensity difference between the
//! template and the tracked window at level 0. An optional forward-backward
//! check (Kalal, Mikolajczyk, Matas, "Forward-Backward Error", ICPR 2010)
//! tracks the result back into the previous image and rejects the point when
//! it does not come home within a threshold.
//!
//! With [`LkConfig::affine_refinement`] the level-0 result is refined further
//! with a 6-parameter affine warp of the window (Baker and Matthews 2004,
//! inverse compositional), which removes the bias the translational model
//! has under rotation and scale (see `affine`).
//!
//! With [`LkConfig::illumination`] set to [`Illumination::GainBias`] the
//! moving window is rescaled to the template's mean and standard deviation
//! at every iteration, so that a gain and a bias between the frames (lamps,
//! exposure) do not bias or break the track, and the track is judged by the
//! normalised residual `sqrt(2 (1 - ZNCC))` (Jin, Favaro, Soatto, ICCV 2001;
//! see `gain`). The default, [`Illumination::Constant`], is Bouguet's model.
//!
//! Borders: at level 0 the whole window (plus the bilinear neighbour) must lie
//! inside the image, else the point is [`LostReason::OutOfBounds`]; at coarser
//! levels a window may hang over the border with the edge pixels repeated (as
//! OpenCV's padded pyramids allow), so points near the edge still profit from
//! the pyramid. A coarse level whose window is degenerate passes its guess on.
//!
//! Speed: every window row shares one subpixel fraction, so a source row is
//! interpolated horizontally once and blended vertically; rows are processed
//! in fixed chunks of eight lanes (padded columns carry zero gradients), so
//! the inner loops compile to SIMD; windows inside the image read the image
//! rows directly, windows over a coarse level's border read edge-replicated
//! copies of their rows through the same kernel (`window`; on AVX2, a copy
//! of the whole level, `borders`). The template and its Scharr
//! gradients are built once per point and level (the patch streams through
//! three rows); only the moving window is resampled per iteration.
//!
//! No heap and no panic: one template buffer lives on the stack per call,
//! its rows sized for the configured window (the smallest of 7, 11, 21 and
//! [`MAX_WINDOW`] rows that holds it: about 3.6 KiB with the patch and row
//! scratch for a 7x7 window, 12.6 KiB for [`MAX_WINDOW`]), results go into
//! caller slices, any input point (NaN, infinite, far outside) yields a
//! status. (With `std` on x86-64, the AVX2 kernels also keep edge-replicated
//! copies of the coarse levels windows hang over on the heap during a call,
//! `borders`; without `std` nothing is allocated.)
//!
//! - [`sample`]: bilinear window sampling (single windows and pixels),
//! - `window`: the row machinery of the tracker's inner loops,
//! - `columns`: the same sums walked a column at a time, for windows of at
//!   most seven columns on Arm cores without NEON (Cortex-M), bit for bit,
//! - `gain`: the gain-bias model's moments, kernel and normalised residual,
//! - `isa`: the row kernels compiled twice on x86-64 with `std` (baseline
//!   and AVX2, picked at run time; the same bits),
//! - `avx2`: on x86-64 with `std` and a CPU with AVX2, the template fill
//!   and the constant-brightness sweep written with AVX2 intrinsics, a
//!   whole window per call (the same bits as the row kernels),
//! - `borders`: for `avx2`, edge-replicated copies (on the heap, for one
//!   tracking call) of the coarse levels that windows hang over,
//! - [`track`]: the per-level iteration and the [`Tracker`].

mod affine;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod avx2;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod borders;
mod columns;
mod config;
mod gain;
mod isa;
pub mod sample;
mod template;
pub mod track;
mod window;

pub use config::{Illumination, LkConfig, LkConfigError, LkError, MAX_WINDOW};
pub use track::Tracker;

use crate::geometry::Vec2;

/// Why a point was not tracked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum LostReason {
    /// The input point or guess was NaN or infinite.
    InvalidPoint = 0,
    /// The window left the image at level 0.
    OutOfBounds = 1,
    /// The window at level 0 is too uniform: the smaller eigenvalue of `G`
    /// is below `min_eigenvalue` (or `G` is singular).
    LowEigenvalue = 2,
    /// The iteration at level 0 did not settle within `max_iterations`.
    NotConverged = 3,
    /// The residual exceeds `max_residual` (of the illumination model; under
    /// [`Illumination::GainBias`] also a flat window in the next image).
    LargeResidual = 4,
    /// Tracking back did not return within `fb_threshold` of the start.
    ForwardBackward = 5,
}

impl LostReason {
    /// How many reasons there are.
    pub const COUNT: usize = 6;

    /// Every reason, in counter order.
    pub const ALL: [LostReason; LostReason::COUNT] = [
        LostReason::InvalidPoint,
        LostReason::OutOfBounds,
        LostReason::LowEigenvalue,
        LostReason::NotConverged,
        LostReason::LargeResidual,
        LostReason::ForwardBackward,
    ];

    /// A short snake_case name, stable for reports.
    pub const fn name(self) -> &'static str {
        match self {
            LostReason::InvalidPoint => "invalid_point",
            LostReason::OutOfBounds => "out_of_bounds",
            LostReason::LowEigenvalue => "low_eigenvalue",
            LostReason::NotConverged => "not_converged",
            LostReason::LargeResidual => "large_residual",
            LostReason::ForwardBackward => "forward_backward",
        }
    }
}

impl core::fmt::Display for LostReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// The outcome for one point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TrackStatus {
    /// Found in the next image.
    Tracked,
    /// Not found, and why.
    Lost(LostReason),
}

impl TrackStatus {
    /// `true` for [`TrackStatus::Tracked`].
    pub fn is_tracked(&self) -> bool {
        matches!(self, TrackStatus::Tracked)
    }
}

/// One point's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackResult {
    /// Position in the next image (level-0 pixels). For lost points the last
    /// estimate, which may be far off (or non-finite for an invalid input).
    pub position: Vec2,
    /// Tracked or lost.
    pub status: TrackStatus,
    /// Mean absolute intensity difference (levels, 0..=255) between the
    /// template and the tracked window at level 0 (measured at the last
    /// iterate, within `epsilon` of `position`); under
    /// [`Illumination::GainBias`] the normalised residual
    /// `sqrt(2 (1 - ZNCC))` (0..=2) instead; `f32::INFINITY` when the
    /// point was lost before it could be measured (or its window was flat).
    pub residual: f32,
    /// Forward-backward distance in pixels, when the check ran.
    pub fb_error: Option<f32>,
    /// Iterations spent at level 0 (forward pass).
    pub iterations: u32,
}

impl TrackResult {
    /// A placeholder for sizing output arrays: lost as an invalid point.
    pub const EMPTY: TrackResult = TrackResult {
        position: Vec2::new(0.0, 0.0),
        status: TrackStatus::Lost(LostReason::InvalidPoint),
        residual: f32::INFINITY,
        fb_error: None,
        iterations: 0,
    };

    /// `true` when the point was tracked.
    pub fn is_tracked(&self) -> bool {
        self.status.is_tracked()
    }
}

impl Default for TrackResult {
    fn default() -> Self {
        TrackResult::EMPTY
    }
}

/// How many points of one call were tracked and lost, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TrackCounts {
    /// Points tracked.
    pub tracked: usize,
    /// Points lost, indexed by `LostReason as usize`.
    pub lost: [usize; LostReason::COUNT],
}

impl TrackCounts {
    /// Points lost for `reason`.
    pub fn lost_for(&self, reason: LostReason) -> usize {
        self.lost.get(reason as usize).copied().unwrap_or(0)
    }

    /// Points lost for any reason.
    pub fn lost_total(&self) -> usize {
        self.lost.iter().sum()
    }

    /// Counts one status.
    pub fn record(&mut self, status: TrackStatus) {
        match status {
            TrackStatus::Tracked => self.tracked += 1,
            TrackStatus::Lost(r) => {
                if let Some(c) = self.lost.get_mut(r as usize) {
                    *c += 1;
                }
            }
        }
    }
}
