//! Tracker settings and errors.

use core::fmt;

use crate::pyramid::MAX_LEVELS;

/// The largest window side (pixels, odd).
pub const MAX_WINDOW: usize = 31;

/// Lucas-Kanade settings. Checked once by [`crate::lk::Tracker::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LkConfig {
    /// Window side in pixels: odd, `3..=MAX_WINDOW`.
    pub window: usize,
    /// Pyramid levels to use (including level 0), `1..=MAX_LEVELS`; fewer
    /// are used when the pyramids hold fewer.
    pub levels: usize,
    /// Iterations per level, at least 1.
    pub max_iterations: u32,
    /// Stop iterating when a step is shorter than this (level pixels), `> 0`.
    pub epsilon: f32,
    /// The same limit at the coarse pyramid levels (all but level 0), `> 0`
    /// and finite, or `None` for `epsilon` at every level (as OpenCV). A
    /// coarse level only seeds the next finer one, which refines the result,
    /// so a looser limit there saves iterations (about 15 % of the tracking
    /// work at 21x21, 3 levels with 0.04) at a small cost in how close the
    /// level-0 iteration starts; the level-0 limit stays `epsilon`.
    pub coarse_epsilon: Option<f32>,
    /// Smallest accepted eigenvalue of `G / window²`, (levels/pixel)², `>= 0`.
    pub min_eigenvalue: f32,
    /// Largest accepted residual (mean absolute difference, levels), `> 0`;
    /// `f32::INFINITY` disables the check. Used with
    /// [`Illumination::Constant`]; [`Illumination::GainBias`] has its own.
    pub max_residual: f32,
    /// After the translational pass, refine an affine warp of the window at
    /// level 0 (more accurate under rotation and scale, about twice the cost).
    pub affine_refinement: bool,
    /// Forward-backward threshold in pixels (`> 0`, finite), or `None` to skip
    /// the check (it doubles the cost).
    pub fb_threshold: Option<f32>,
    /// How the brightness may change between the two images: not at all
    /// (the default, Bouguet's model) or by a gain and a bias per window.
    pub illumination: Illumination,
}

/// The brightness model between the two images of a track.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Illumination {
    /// The same intensities in both images (Bouguet 2000): the residual is
    /// the mean absolute difference, judged by [`LkConfig::max_residual`].
    #[default]
    Constant,
    /// The window may change by a gain and a bias (exposure, lamps): at
    /// every iteration the moving window is rescaled to the template's mean
    /// and standard deviation before the residual and the update; the track
    /// is judged by the normalised residual `sqrt(2 (1 - ZNCC))` (0 for a
    /// perfect match up to gain and bias, 2 for an inverted one), lost as
    /// [`crate::lk::LostReason::LargeResidual`] above `max_residual`.
    GainBias {
        /// Largest accepted normalised residual, finite and `> 0` (0.5
        /// accepts a zero-mean normalised cross-correlation of 0.875 or
        /// more; 2 or more accepts any).
        max_residual: f32,
    },
}

impl Illumination {
    /// [`Illumination::GainBias`] with a normalised residual limit of 0.5.
    pub const GAIN_BIAS: Illumination = Illumination::GainBias { max_residual: 0.5 };
}

impl Default for LkConfig {
    /// OpenCV's defaults (21x21, 3 levels, 30 iterations, 0.01 px at every
    /// level), a
    /// 0.1 (level/px)² eigenvalue floor, a residual limit of 30 levels, the
    /// translational model only (as OpenCV), no forward-backward check.
    fn default() -> Self {
        LkConfig {
            window: 21,
            levels: 3,
            max_iterations: 30,
            epsilon: 0.01,
            coarse_epsilon: None,
            min_eigenvalue: 0.1,
            max_residual: 30.0,
            affine_refinement: false,
            fb_threshold: None,
            illumination: Illumination::Constant,
        }
    }
}

/// Which setting is invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LkConfigError {
    /// The window is even, smaller than 3 or larger than [`MAX_WINDOW`].
    Window,
    /// Levels are 0 or more than [`MAX_LEVELS`].
    Levels,
    /// `max_iterations` is 0.
    Iterations,
    /// `epsilon` is not a positive finite number.
    Epsilon,
    /// `coarse_epsilon` is not a positive finite number.
    CoarseEpsilon,
    /// `min_eigenvalue` is negative or not finite.
    MinEigenvalue,
    /// `max_residual` is not positive (or NaN).
    MaxResidual,
    /// `fb_threshold` is not a positive finite number.
    FbThreshold,
    /// The gain-bias residual limit is not a positive finite number.
    GainBiasResidual,
}

impl fmt::Display for LkConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LkConfigError::Window => "LK window must be odd, from 3 to 31",
            LkConfigError::Levels => "LK levels must be from 1 to the pyramid maximum",
            LkConfigError::Iterations => "LK needs at least one iteration",
            LkConfigError::Epsilon => "LK epsilon must be positive and finite",
            LkConfigError::CoarseEpsilon => "LK coarse-level epsilon must be positive and finite",
            LkConfigError::MinEigenvalue => "LK eigenvalue floor must be finite and non-negative",
            LkConfigError::MaxResidual => "LK residual limit must be positive",
            LkConfigError::FbThreshold => {
                "LK forward-backward threshold must be positive and finite"
            }
            LkConfigError::GainBiasResidual => {
                "LK gain-bias residual limit must be positive and finite"
            }
        })
    }
}

impl core::error::Error for LkConfigError {}

impl LkConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), LkConfigError> {
        if self.window.is_multiple_of(2) || !(3..=MAX_WINDOW).contains(&self.window) {
            return Err(LkConfigError::Window);
        }
        if !(1..=MAX_LEVELS).contains(&self.levels) {
            return Err(LkConfigError::Levels);
        }
        if self.max_iterations == 0 {
            return Err(LkConfigError::Iterations);
        }
        if !(self.epsilon.is_finite() && self.epsilon > 0.0) {
            return Err(LkConfigError::Epsilon);
        }
        if let Some(e) = self.coarse_epsilon
            && !(e.is_finite() && e > 0.0)
        {
            return Err(LkConfigError::CoarseEpsilon);
        }
        if !(self.min_eigenvalue.is_finite() && self.min_eigenvalue >= 0.0) {
            return Err(LkConfigError::MinEigenvalue);
        }
        let residual_ok = self.max_residual > 0.0;
        if !residual_ok {
            return Err(LkConfigError::MaxResidual);
        }
        if let Some(t) = self.fb_threshold
            && !(t.is_finite() && t > 0.0)
        {
            return Err(LkConfigError::FbThreshold);
        }
        if let Illumination::GainBias { max_residual } = self.illumination
            && !(max_residual.is_finite() && max_residual > 0.0)
        {
            return Err(LkConfigError::GainBiasResidual);
        }
        Ok(())
    }
}

/// Why a tracking call could not run at all (per-point trouble is a status).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LkError {
    /// The output slice is shorter than the point slice.
    OutputTooSmall {
        /// Points given.
        points: usize,
        /// Result slots given.
        results: usize,
    },
    /// The two pyramids' level-0 images differ in size.
    SizeMismatch,
}

impl fmt::Display for LkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LkError::OutputTooSmall { points, results } => write!(
                f,
                "{points} points to track but only {results} result slots"
            ),
            LkError::SizeMismatch => f.write_str("the two pyramids differ in image size"),
        }
    }
}

impl core::error::Error for LkError {}
