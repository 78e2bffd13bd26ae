//! Online refinement of the forward wheel noise per floor, from the filter's
//! normalised innovation squared (NIS).
//!
//! For a consistent filter the forward wheel-velocity innovation `nu` with
//! predicted variance `S` has `E[nu^2 / S] = 1` (Bar-Shalom, Li, Kirubarajan,
//! *Estimation with Applications to Tracking and Navigation*, 2001, ch. 5.4:
//! the NIS consistency test). Per floor the learner keeps an exponentially
//! forgotten mean of the NIS (forgetting factor `lambda`, i.e. a memory of
//! about `1 / (1 - lambda)` samples; a plain running mean while fewer samples
//! have been seen) and, once a minimum number of samples has been seen,
//! moves the floor's forward-noise multiplier `m` slowly in log space:
//!
//! `ln m += rate * ln(mean NIS) / 2`
//!
//! so a NIS consistently above 1 raises the noise and one below 1 lowers it,
//! until `mean NIS ~ 1`; `m` stays within `[min_multiplier, max_multiplier]`.
//! With `rate * memory ~ 0.25` (the defaults) the loop of the slow mean and the
//! integrator is critically damped. Samples seen under a blend of floors count
//! for each floor with its fraction. Gated samples count too, with their NIS
//! capped, so that frequent slip raises the noise but one outlier does not.
//!
//! What a robot learned is exported as a fixed 72-byte record (magic,
//! version, wheel type, per floor the multiplier, mean NIS and sample count,
//! CRC-32) and restored after a restart; corrupt records are refused.

use core::fmt;

use vslam_core::{Reject, SampleCounts};

use super::classes::SurfaceKind;
use super::grip_table::WheelType;
use super::mix::SurfaceMix;

/// Why a learning configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LearningConfigError {
    /// The forgetting factor must lie in `(0, 1)`.
    Forgetting,
    /// The rate must be finite and in `[0, 1]`.
    Rate,
    /// Multiplier bounds must satisfy `0 < min <= 1 <= max`, finite.
    Bounds,
    /// Minimum samples, NIS cap and minimum fraction must be finite and
    /// positive (the fraction at most 1).
    Limits,
}

impl fmt::Display for LearningConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LearningConfigError::Forgetting => "forgetting factor must lie in (0, 1)",
            LearningConfigError::Rate => "learning rate must lie in [0, 1]",
            LearningConfigError::Bounds => "multiplier bounds must satisfy 0 < min <= 1 <= max",
            LearningConfigError::Limits => {
                "minimum samples, NIS cap and minimum fraction must be positive"
            }
        })
    }
}

impl core::error::Error for LearningConfigError {}

/// How fast and how far the learner may move the noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LearningConfig {
    forgetting: f32,
    rate: f32,
    min_samples: f32,
    min_multiplier: f32,
    max_multiplier: f32,
    nis_cap: f32,
    min_fraction: f32,
}

impl Default for LearningConfig {
    /// Memory of 500 samples, rate 5e-4 (critically damped), acts after 250
    /// samples, multiplier within `[0.5, 4]`, NIS capped at 25 (5 sigma), a
    /// floor learns from samples where it covers at least 20 % of the ground.
    fn default() -> Self {
        LearningConfig {
            forgetting: 0.998,
            rate: 5e-4,
            min_samples: 250.0,
            min_multiplier: 0.5,
            max_multiplier: 4.0,
            nis_cap: 25.0,
            min_fraction: 0.2,
        }
    }
}

impl LearningConfig {
    /// Checks and builds a configuration.
    ///
    /// - `forgetting`: factor `lambda` of the NIS mean, `(0, 1)`;
    /// - `rate`: step of `ln m` per sample per unit of `ln(NIS)/2`, `[0, 1]`;
    /// - `min_samples`: (fraction-weighted) samples a floor needs before its
    ///   multiplier moves, `> 0`;
    /// - `min_multiplier <= 1 <= max_multiplier`: bounds of the multiplier;
    /// - `nis_cap`: largest NIS a single sample contributes, `> 0`;
    /// - `min_fraction`: smallest fraction of the ground a floor must cover for
    ///   a sample to count for it, `(0, 1]`.
    pub fn new(
        forgetting: f32,
        rate: f32,
        min_samples: f32,
        min_multiplier: f32,
        max_multiplier: f32,
        nis_cap: f32,
        min_fraction: f32,
    ) -> Result<Self, LearningConfigError> {
        if !(forgetting > 0.0 && forgetting < 1.0) {
            return Err(LearningConfigError::Forgetting);
        }
        if !(0.0..=1.0).contains(&rate) {
            return Err(LearningConfigError::Rate);
        }
        if !(min_multiplier > 0.0
            && min_multiplier <= 1.0
            && max_multiplier >= 1.0
            && max_multiplier.is_finite())
        {
            return Err(LearningConfigError::Bounds);
        }
        let pos = |v: f32| v.is_finite() && v > 0.0;
        if !(pos(min_samples) && pos(nis_cap) && pos(min_fraction) && min_fraction <= 1.0) {
            return Err(LearningConfigError::Limits);
        }
        Ok(LearningConfig {
            forgetting,
            rate,
            min_samples,
            min_multiplier,
            max_multiplier,
            nis_cap,
            min_fraction,
        })
    }

    /// Forgetting factor of the NIS mean.
    pub fn forgetting(&self) -> f32 {
        self.forgetting
    }
    /// Learning rate.
    pub fn rate(&self) -> f32 {
        self.rate
    }
    /// Samples needed before the multiplier moves.
    pub fn min_samples(&self) -> f32 {
        self.min_samples
    }
    /// Lower bound of the multiplier.
    pub fn min_multiplier(&self) -> f32 {
        self.min_multiplier
    }
    /// Upper bound of the multiplier.
    pub fn max_multiplier(&self) -> f32 {
        self.max_multiplier
    }
    /// Largest NIS one sample contributes.
    pub fn nis_cap(&self) -> f32 {
        self.nis_cap
    }
    /// Smallest fraction of the ground for a sample to count for a floor.
    pub fn min_fraction(&self) -> f32 {
        self.min_fraction
    }
}

/// What the learner knows about one floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloorStats {
    /// Forgotten mean of the NIS.
    pub nis_mean: f32,
    /// Fraction-weighted samples seen (saturates at `f32::MAX`).
    pub samples: f32,
    /// Forward-noise multiplier.
    pub multiplier: f32,
}

impl Default for FloorStats {
    fn default() -> Self {
        FloorStats {
            nis_mean: 1.0,
            samples: 0.0,
            multiplier: 1.0,
        }
    }
}

/// Why a learned record was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RecordError {
    /// The record is not [`LEARNED_RECORD_LEN`] bytes long.
    Length,
    /// The magic bytes are wrong: not a learned-grip record.
    Magic,
    /// The record was written by an unknown format version.
    Version,
    /// The CRC-32 does not match: the record is corrupt.
    Checksum,
    /// The record was learned with another wheel type.
    WheelMismatch,
    /// The record holds a non-finite or impossible value.
    Value,
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RecordError::Length => "learned record has the wrong length",
            RecordError::Magic => "not a learned grip record",
            RecordError::Version => "unknown learned record version",
            RecordError::Checksum => "learned record checksum mismatch",
            RecordError::WheelMismatch => "learned record belongs to another wheel type",
            RecordError::Value => "learned record holds an impossible value",
        })
    }
}

impl core::error::Error for RecordError {}

/// Length of the exported record, bytes.
pub const LEARNED_RECORD_LEN: usize = 8 + 12 * SurfaceKind::COUNT + 4;
/// First bytes of every record.
pub const LEARNED_RECORD_MAGIC: [u8; 4] = *b"TGRL";
/// Format version written by this code.
pub const LEARNED_RECORD_VERSION: u8 = 1;

/// Learns, per floor, the forward wheel-noise multiplier that makes the NIS ~ 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseLearner {
    config: LearningConfig,
    wheel: WheelType,
    floors: [FloorStats; SurfaceKind::COUNT],
    counts: SampleCounts,
    gated_used: u32,
}

impl NoiseLearner {
    /// A learner that knows nothing yet (all multipliers 1).
    pub fn new(config: LearningConfig, wheel: WheelType) -> Self {
        NoiseLearner {
            config,
            wheel,
            floors: [FloorStats::default(); SurfaceKind::COUNT],
            counts: SampleCounts::new(),
            gated_used: 0,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &LearningConfig {
        &self.config
    }

    /// The wheel type the learner learns for.
    pub fn wheel(&self) -> WheelType {
        self.wheel
    }

    /// Forgets everything learned.
    pub fn reset(&mut self) {
        *self = NoiseLearner::new(self.config, self.wheel);
    }

    /// What is known about one floor.
    pub fn stats(&self, kind: SurfaceKind) -> FloorStats {
        self.floors.get(kind.index()).copied().unwrap_or_default()
    }

    /// The forward-noise multiplier of one floor.
    pub fn multiplier(&self, kind: SurfaceKind) -> f32 {
        self.stats(kind).multiplier
    }

    /// The multipliers of every floor ([`SurfaceKind`] order).
    pub fn multipliers(&self) -> [f32; SurfaceKind::COUNT] {
        let mut m = [1.0f32; SurfaceKind::COUNT];
        for (o, s) in m.iter_mut().zip(self.floors.iter()) {
            *o = s.multiplier;
        }
        m
    }

    /// Samples used (fused) and refused, by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Used samples that the filter had gated (their NIS capped).
    pub fn gated_used(&self) -> u32 {
        self.gated_used
    }

    /// Learns from one forward wheel-velocity innovation `forward` (m/s) with
    /// predicted variance `forward_var` (m^2/s^2), seen while the floor was
    /// `mix`; `gated` says whether the filter's gate refused it.
    ///
    /// Refuses (and counts) non-finite values ([`Reject::NonFinite`]), a
    /// variance that is not positive ([`Reject::Degenerate`]), and a mix in
    /// which no floor covers the minimum fraction ([`Reject::LowQuality`]).
    pub fn observe(
        &mut self,
        mix: &SurfaceMix,
        forward: f32,
        forward_var: f32,
        gated: bool,
    ) -> Result<(), Reject> {
        let outcome = self.observe_inner(mix, forward, forward_var, gated);
        self.counts.record(outcome);
        outcome
    }

    fn observe_inner(
        &mut self,
        mix: &SurfaceMix,
        forward: f32,
        forward_var: f32,
        gated: bool,
    ) -> Result<(), Reject> {
        if !(forward.is_finite() && forward_var.is_finite()) {
            return Err(Reject::NonFinite);
        }
        if forward_var <= 0.0 {
            return Err(Reject::Degenerate);
        }
        let cap = self.config.nis_cap;
        let nis = (forward * forward / forward_var).min(cap);
        if !nis.is_finite() {
            return Err(Reject::NonFinite);
        }
        let c = self.config;
        let mut used = false;
        for (floor, f) in self.floors.iter_mut().zip(mix.fractions().iter()) {
            if *f < c.min_fraction {
                continue;
            }
            used = true;
            learn(floor, &c, nis, *f);
        }
        if !used {
            return Err(Reject::LowQuality);
        }
        if gated {
            self.gated_used = self.gated_used.saturating_add(1);
        }
        Ok(())
    }

    /// The learned state as a fixed-size record (see the module docs).
    pub fn to_bytes(&self) -> [u8; LEARNED_RECORD_LEN] {
        let mut out = [0u8; LEARNED_RECORD_LEN];
        let (payload, crc_out) = out.split_at_mut(LEARNED_RECORD_LEN - 4);
        let (head, body) = payload.split_at_mut(8);
        head.copy_from_slice(&[
            LEARNED_RECORD_MAGIC[0],
            LEARNED_RECORD_MAGIC[1],
            LEARNED_RECORD_MAGIC[2],
            LEARNED_RECORD_MAGIC[3],
            LEARNED_RECORD_VERSION,
            self.wheel as u8,
            SurfaceKind::COUNT as u8,
            0,
        ]);
        for (chunk, s) in body.chunks_exact_mut(12).zip(self.floors.iter()) {
            for (dst, v) in chunk
                .chunks_exact_mut(4)
                .zip([s.multiplier, s.nis_mean, s.samples])
            {
                dst.copy_from_slice(&v.to_le_bytes());
            }
        }
        let crc = crc32fast::hash(payload);
        crc_out.copy_from_slice(&crc.to_le_bytes());
        out
    }

    /// Restores a record written by [`NoiseLearner::to_bytes`]. On error the
    /// learner is unchanged. Multipliers outside this learner's bounds are
    /// clamped into them (the bounds may have been reconfigured).
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), RecordError> {
        if bytes.len() != LEARNED_RECORD_LEN {
            return Err(RecordError::Length);
        }
        let (payload, crc_in) = bytes.split_at(LEARNED_RECORD_LEN - 4);
        let (head, body) = payload.split_at(8);
        if head.get(..4) != Some(&LEARNED_RECORD_MAGIC[..]) {
            return Err(RecordError::Magic);
        }
        let crc_stored = u32::from_le_bytes(to4(crc_in));
        if crc32fast::hash(payload) != crc_stored {
            return Err(RecordError::Checksum);
        }
        if head.get(4) != Some(&LEARNED_RECORD_VERSION) {
            return Err(RecordError::Version);
        }
        if head.get(6) != Some(&(SurfaceKind::COUNT as u8)) {
            return Err(RecordError::Version);
        }
        if head.get(5) != Some(&(self.wheel as u8)) {
            return Err(RecordError::WheelMismatch);
        }
        let mut floors = [FloorStats::default(); SurfaceKind::COUNT];
        for (chunk, s) in body.chunks_exact(12).zip(floors.iter_mut()) {
            let mut v = [0.0f32; 3];
            for (o, b) in v.iter_mut().zip(chunk.chunks_exact(4)) {
                *o = f32::from_le_bytes(to4(b));
            }
            let [multiplier, nis_mean, samples] = v;
            let pos = |x: f32| x.is_finite() && x > 0.0;
            if !(pos(multiplier) && pos(nis_mean) && samples.is_finite() && samples >= 0.0) {
                return Err(RecordError::Value);
            }
            *s = FloorStats {
                nis_mean,
                samples,
                multiplier: multiplier
                    .clamp(self.config.min_multiplier, self.config.max_multiplier),
            };
        }
        self.floors = floors;
        Ok(())
    }
}

/// Four bytes of a slice (zeros where it is short).
fn to4(b: &[u8]) -> [u8; 4] {
    let mut out = [0u8; 4];
    for (o, v) in out.iter_mut().zip(b.iter()) {
        *o = *v;
    }
    out
}

/// One sample's update of one floor, weighted by its fraction `w` in `(0, 1]`.
fn learn(floor: &mut FloorStats, c: &LearningConfig, nis: f32, w: f32) {
    // Plain running mean until the memory is full, forgotten mean after.
    let running = 1.0 / (floor.samples + 1.0);
    let alpha = (w * running.max(1.0 - c.forgetting)).clamp(0.0, 1.0);
    floor.nis_mean += alpha * (nis - floor.nis_mean);
    floor.samples = (floor.samples + w).min(f32::MAX);
    if floor.samples < c.min_samples || floor.nis_mean.is_nan() || floor.nis_mean <= 0.0 {
        return;
    }
    let step = c.rate * w * 0.5 * libm::logf(floor.nis_mean);
    let m = floor.multiplier * libm::expf(step);
    if m.is_finite() {
        floor.multiplier = m.clamp(c.min_multiplier, c.max_multiplier);
    }
}
