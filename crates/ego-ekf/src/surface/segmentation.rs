//! Label map -> which floors are in view, in what proportions, and whether a
//! different floor lies just ahead.
//!
//! A forward-looking camera sees the floor in the lower part of its image: the
//! bottom rows are the ground just ahead of the robot, rows further up are
//! further away, and above the horizon there is no floor at all. So:
//!
//! - rows above `horizon_fraction * height` are ignored;
//! - in the ground region below, each row is weighted `1 + bottom_gain * t`,
//!   `t` growing from 0 at the horizon row to 1 at the bottom row, so nearer
//!   ground counts more;
//! - only pixels whose class is a ground class ([`ClassConfig`]) give surface
//!   fractions; unknown and non-ground pixels only lower the coverage;
//! - the ground region is split into a *near* band (the bottom) and an *ahead*
//!   band (the one above it): a ground kind in the ahead band that differs from
//!   the near band's floor, and whose share grows from the near to the ahead
//!   band by at least `min_change_fraction` (`min_strip_fraction` for a narrow
//!   threshold strip), announces an upcoming surface change (the nearest one
//!   if several), and the row
//!   where it starts tells (through the camera geometry, see
//!   [`super::anticipation`]) how far away the boundary is.
//!
//! A map without enough ground gives [`NoSurface`]: the caller keeps the last
//! surface. No division is done by a total that can be zero.

use core::fmt;

use vslam_core::image::LabelView;

use super::classes::{ClassConfig, ClassRole, SurfaceKind};
use super::mix::SurfaceMix;

/// Why a segmentation configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentationConfigError {
    /// The horizon fraction must lie in `[0, 1)`.
    Horizon,
    /// The bottom gain must be finite and non-negative.
    BottomGain,
    /// Band fractions must be in `(0, 1]` and together at most 1.
    Bands,
    /// Minimum coverage and change fractions must lie in `[0, 1]`.
    Fraction,
}

impl fmt::Display for SegmentationConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SegmentationConfigError::Horizon => "horizon fraction must lie in [0, 1)",
            SegmentationConfigError::BottomGain => "bottom gain must be finite and non-negative",
            SegmentationConfigError::Bands => {
                "band fractions must lie in (0, 1] and sum to at most 1"
            }
            SegmentationConfigError::Fraction => "coverage and change fractions must lie in [0, 1]",
        })
    }
}

impl core::error::Error for SegmentationConfigError {}

/// Where the floor is in the image and how rows are weighted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentationConfig {
    horizon_fraction: f32,
    bottom_gain: f32,
    near_band: f32,
    ahead_band: f32,
    min_coverage: f32,
    min_change_fraction: f32,
    min_strip_fraction: f32,
}

impl Default for SegmentationConfig {
    /// Horizon at 40 % of the height, bottom row weighted 4x the horizon row,
    /// near band the bottom third of the ground region, ahead band the middle
    /// third, at least 2 % ground to say anything, 25 % of the ahead band to
    /// announce a change.
    fn default() -> Self {
        SegmentationConfig {
            horizon_fraction: 0.4,
            bottom_gain: 3.0,
            near_band: 1.0 / 3.0,
            ahead_band: 1.0 / 3.0,
            min_coverage: 0.02,
            min_change_fraction: 0.25,
            min_strip_fraction: 0.05,
        }
    }
}

impl SegmentationConfig {
    /// Checks and builds the configuration.
    ///
    /// - `horizon_fraction`: rows above `horizon_fraction * height` are ignored, `[0, 1)`;
    /// - `bottom_gain`: the bottom row weighs `1 + bottom_gain` times the horizon row, `>= 0`;
    /// - `near_band`, `ahead_band`: fractions of the ground region (from the
    ///   bottom) of the near band and the ahead band above it; each in `(0, 1]`,
    ///   sum at most 1;
    /// - `min_coverage`: weighted ground fraction of the region below which the
    ///   map says nothing about the floor, `[0, 1]`;
    /// - `min_change_fraction`: fraction of the ahead band's ground a different
    ///   kind must cover to announce a change, `[0, 1]`.
    pub fn new(
        horizon_fraction: f32,
        bottom_gain: f32,
        near_band: f32,
        ahead_band: f32,
        min_coverage: f32,
        min_change_fraction: f32,
    ) -> Result<Self, SegmentationConfigError> {
        if !(0.0..1.0).contains(&horizon_fraction) {
            return Err(SegmentationConfigError::Horizon);
        }
        if !(bottom_gain.is_finite() && bottom_gain >= 0.0) {
            return Err(SegmentationConfigError::BottomGain);
        }
        let band_ok = |b: f32| b > 0.0 && b <= 1.0;
        if !(band_ok(near_band) && band_ok(ahead_band) && near_band + ahead_band <= 1.0 + 1e-6) {
            return Err(SegmentationConfigError::Bands);
        }
        if !((0.0..=1.0).contains(&min_coverage) && (0.0..=1.0).contains(&min_change_fraction)) {
            return Err(SegmentationConfigError::Fraction);
        }
        Ok(SegmentationConfig {
            horizon_fraction,
            bottom_gain,
            near_band,
            ahead_band,
            min_coverage,
            min_change_fraction,
            min_strip_fraction: 0.05,
        })
    }

    /// Fraction of the image height above which rows are ignored.
    pub fn horizon_fraction(&self) -> f32 {
        self.horizon_fraction
    }
    /// Extra weight of the bottom row relative to the horizon row.
    pub fn bottom_gain(&self) -> f32 {
        self.bottom_gain
    }
    /// Fraction of the ground region forming the near band.
    pub fn near_band(&self) -> f32 {
        self.near_band
    }
    /// Fraction of the ground region forming the ahead band.
    pub fn ahead_band(&self) -> f32 {
        self.ahead_band
    }
    /// Minimum weighted ground coverage.
    pub fn min_coverage(&self) -> f32 {
        self.min_coverage
    }
    /// Minimum fraction of a different kind in the ahead band.
    pub fn min_change_fraction(&self) -> f32 {
        self.min_change_fraction
    }
    /// Minimum fraction of a threshold strip in the ahead band (default 0.05).
    pub fn min_strip_fraction(&self) -> f32 {
        self.min_strip_fraction
    }

    /// The same configuration with another minimum threshold-strip fraction
    /// (strips are narrow, so they are announced from a smaller share than
    /// other floors); values outside `[0, 1]` or NaN leave it unchanged.
    pub fn with_min_strip_fraction(mut self, fraction: f32) -> Self {
        if (0.0..=1.0).contains(&fraction) {
            self.min_strip_fraction = fraction;
        }
        self
    }

    /// The announcement share for a kind: the strip fraction for threshold
    /// strips, the change fraction for every other floor.
    pub fn min_fraction_for(&self, kind: SurfaceKind) -> f32 {
        match kind {
            SurfaceKind::Threshold => self.min_strip_fraction,
            _ => self.min_change_fraction,
        }
    }

    /// The rows of a map `height` rows high: `(horizon_row, ahead_start, near_start)`.
    /// The ground region is `horizon_row..height` (never empty for `height >= 1`),
    /// the ahead band `ahead_start..near_start`, the near band `near_start..height`.
    pub fn rows(&self, height: usize) -> (usize, usize, usize) {
        let h = height.max(1);
        let horizon = ((h as f32 * self.horizon_fraction) as usize).min(h - 1);
        let n = (h - horizon) as f32;
        let near_rows = (libm::ceilf(n * self.near_band) as usize).clamp(1, h - horizon);
        let ahead_rows = (libm::ceilf(n * (self.near_band + self.ahead_band)) as usize)
            .clamp(near_rows, h - horizon);
        (horizon, h - ahead_rows, h - near_rows)
    }

    /// The weight of row `y` of a map `height` rows high (0 above the horizon).
    pub fn row_weight(&self, y: usize, height: usize) -> f32 {
        let (horizon, _, _) = self.rows(height);
        if y < horizon || y >= height {
            return 0.0;
        }
        let n = (height - horizon) as f32;
        let t = ((y - horizon) as f32 + 0.5) / n;
        1.0 + self.bottom_gain * t
    }
}

/// Why a label map says nothing about the floor (keep the last surface).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoSurface {
    /// Every pixel of the ground region is of an unknown class.
    OnlyUnknown,
    /// No pixel of the ground region is of a ground class.
    NoGround,
    /// Ground pixels cover less than the configured minimum of the region.
    TooLittleGround,
}

impl fmt::Display for NoSurface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NoSurface::OnlyUnknown => "label map holds only unknown classes",
            NoSurface::NoGround => "label map holds no ground class",
            NoSurface::TooLittleGround => "too little ground in the label map",
        })
    }
}

impl core::error::Error for NoSurface {}

/// A different floor seen in the ahead band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpcomingSurface {
    /// The kind of the floor ahead.
    pub kind: SurfaceKind,
    /// Its fraction of the ahead band's ground.
    pub fraction: f32,
    /// Where its nearest edge lies: the lower edge of the nearest row (near or
    /// ahead band) where it covers at least the change fraction of the row's
    /// ground, as a fraction of the map height (0 top, 1 bottom).
    pub row_fraction: f32,
}

/// What a label map tells about the floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundView {
    /// Weighted fractions of the ground kinds in the whole ground region.
    pub mix: SurfaceMix,
    /// Weighted fraction of the region that is ground, `(0, 1]`.
    pub coverage: f32,
    /// Fractions in the near band, if it holds ground.
    pub near: Option<SurfaceMix>,
    /// Fractions in the ahead band, if it holds ground.
    pub ahead: Option<SurfaceMix>,
    /// A different floor in the ahead band, if any.
    pub upcoming: Option<UpcomingSurface>,
}

impl GroundView {
    /// Smallest near-band fraction for a kind to count as present underfoot.
    pub const PRESENT_MIN: f32 = 0.05;

    /// The floor the robot is on now: the near band's dominant kind, or the
    /// whole region's if the near band holds no ground.
    pub fn current_kind(&self) -> SurfaceKind {
        self.near.unwrap_or(self.mix).dominant()
    }

    /// The floor the robot is on now, as fractions: the weighted [`Self::mix`]
    /// restricted to the kinds present in the near band (at least
    /// [`Self::PRESENT_MIN`] of it), without an announced upcoming kind. Kinds
    /// seen only further up, or announced, are ahead of the robot, not under
    /// it (see [`Self::upcoming`]). Without near-band ground, the whole mix.
    pub fn present_mix(&self) -> SurfaceMix {
        let Some(near) = self.near else {
            return self.mix;
        };
        let ahead = self.upcoming.map(|u| u.kind);
        let mut w = [0.0f32; SurfaceKind::COUNT];
        for (((o, m), n), k) in w
            .iter_mut()
            .zip(self.mix.fractions().iter())
            .zip(near.fractions().iter())
            .zip(SurfaceKind::ALL.iter())
        {
            if *n >= Self::PRESENT_MIN && ahead != Some(*k) {
                *o = *m;
            }
        }
        SurfaceMix::from_weights(&w).unwrap_or(near)
    }
}

/// Per-kind pixel counts of one row, plus unknown and non-ground counts.
#[derive(Clone, Copy, Debug, Default)]
struct RowCounts {
    kinds: [u64; SurfaceKind::COUNT],
    unknown: u64,
    not_ground: u64,
}

impl RowCounts {
    fn of(classes: &ClassConfig, row: &[u8]) -> Self {
        let mut c = RowCounts::default();
        for id in row {
            match classes.role(*id) {
                ClassRole::Unknown => c.unknown += 1,
                ClassRole::NotGround => c.not_ground += 1,
                ClassRole::Ground(k) => {
                    if let Some(n) = c.kinds.get_mut(k.index()) {
                        *n += 1;
                    }
                }
            }
        }
        c
    }

    fn ground(&self) -> u64 {
        self.kinds.iter().sum()
    }
}

/// Accumulated weights of one band.
#[derive(Clone, Copy, Debug, Default)]
struct BandSums {
    kinds: [f32; SurfaceKind::COUNT],
    unknown: f32,
    all: f32,
}

impl BandSums {
    fn add(&mut self, c: &RowCounts, w: f32) {
        for (s, n) in self.kinds.iter_mut().zip(c.kinds.iter()) {
            *s += w * *n as f32;
        }
        self.unknown += w * c.unknown as f32;
        self.all += w * (c.ground() + c.unknown + c.not_ground) as f32;
    }

    fn ground(&self) -> f32 {
        self.kinds.iter().sum()
    }
}

/// Turns label maps into [`GroundView`]s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segmenter {
    classes: ClassConfig,
    config: SegmentationConfig,
}

impl Segmenter {
    /// A segmenter for the given class table and image layout.
    pub fn new(classes: ClassConfig, config: SegmentationConfig) -> Self {
        Segmenter { classes, config }
    }

    /// The class table.
    pub fn classes(&self) -> &ClassConfig {
        &self.classes
    }

    /// The image layout.
    pub fn config(&self) -> &SegmentationConfig {
        &self.config
    }

    /// Reads one label map (any size).
    pub fn analyze(&self, labels: &LabelView<'_>) -> Result<GroundView, NoSurface> {
        let height = labels.height();
        let (horizon, ahead_start, near_start) = self.config.rows(height);
        let mut whole = BandSums::default();
        let mut near = BandSums::default();
        let mut ahead = BandSums::default();
        for y in horizon..height {
            let Some(row) = labels.row(y) else { continue };
            let counts = RowCounts::of(&self.classes, row);
            let w = self.config.row_weight(y, height);
            whole.add(&counts, w);
            if y >= near_start {
                near.add(&counts, 1.0);
            } else if y >= ahead_start {
                ahead.add(&counts, 1.0);
            }
        }
        let ground = whole.ground();
        if ground <= 0.0 {
            return Err(if whole.unknown >= whole.all {
                NoSurface::OnlyUnknown
            } else {
                NoSurface::NoGround
            });
        }
        // `whole.all >= ground > 0`.
        let coverage = (ground / whole.all).min(1.0);
        if coverage < self.config.min_coverage {
            return Err(NoSurface::TooLittleGround);
        }
        let mix = SurfaceMix::from_weights(&whole.kinds).ok_or(NoSurface::NoGround)?;
        let near_mix = SurfaceMix::from_weights(&near.kinds);
        let ahead_mix = SurfaceMix::from_weights(&ahead.kinds);
        let current = near_mix.unwrap_or(mix).dominant();
        let upcoming = ahead_mix
            .and_then(|a| self.upcoming(labels, current, near_mix.as_ref(), &a, ahead_start));
        Ok(GroundView {
            mix,
            coverage,
            near: near_mix,
            ahead: ahead_mix,
            upcoming,
        })
    }

    /// The largest kind in the ahead band other than `current`, if it covers
    /// enough of it, and the nearest row where it starts.
    fn upcoming(
        &self,
        labels: &LabelView<'_>,
        current: SurfaceKind,
        near: Option<&SurfaceMix>,
        ahead: &SurfaceMix,
        ahead_start: usize,
    ) -> Option<UpcomingSurface> {
        // A floor approaches when its share grows from the near band to the
        // ahead band (two floors side by side do not); a threshold strip is
        // narrow by nature and needs a smaller share.
        let growth = |k: SurfaceKind, f: f32| f - near.map_or(0.0, |n| n.fraction(k));
        let mut best: Option<(usize, UpcomingSurface)> = None;
        for (kind, fraction) in ahead.iter() {
            let min = self.config.min_fraction_for(kind).max(f32::MIN_POSITIVE);
            if kind == current || growth(kind, fraction) < min {
                continue;
            }
            let Some(row) = self.nearest_row(labels, kind, min, ahead_start) else {
                continue;
            };
            // The nearest boundary wins; on a tie the larger share.
            let better = match best {
                None => true,
                Some((r, b)) => row > r || (row == r && fraction > b.fraction),
            };
            if better {
                let height = labels.height().max(1);
                best = Some((
                    row,
                    UpcomingSurface {
                        kind,
                        fraction,
                        row_fraction: (row + 1) as f32 / height as f32,
                    },
                ));
            }
        }
        best.map(|(_, u)| u)
    }

    /// The nearest row (scanning from the bottom up through the near band,
    /// where the boundary may already be, and the ahead band) in which `kind`
    /// covers at least `min` of the row's ground.
    fn nearest_row(
        &self,
        labels: &LabelView<'_>,
        kind: SurfaceKind,
        min: f32,
        ahead_start: usize,
    ) -> Option<usize> {
        (ahead_start..labels.height()).rev().find(|y| {
            labels.row(*y).is_some_and(|r| {
                let c = RowCounts::of(&self.classes, r);
                let g = c.ground();
                let n = c.kinds.get(kind.index()).copied().unwrap_or(0);
                n > 0 && n as f32 >= min * g as f32
            })
        })
    }
}
