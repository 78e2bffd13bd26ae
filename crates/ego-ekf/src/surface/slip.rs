//! Online learning of each floor's expected slip from the forward wheel
//! innovation (seed 004 claim 5: the robot's velocity derived from the
//! grip).
//!
//! The wheel update expects the robot at `(1 - s)` times the wheels'
//! rolling speed `u` on a floor with expected slip `s`
//! ([`crate::grip::GripParams::slip`]), so its forward innovation is
//! `nu = (1 - s) u - v_hat`, and `d nu / d s = -u`. A floor whose true slip
//! exceeds `s` leaves `nu / u > 0` on average. Per floor the learner
//! integrates that ratio (a normalised least-mean-squares step, Haykin,
//! *Adaptive Filter Theory*, 5th ed., 2014, ch. 7):
//!
//! `s_k += rate * f_k * clamp(nu / u, -ratio_cap, ratio_cap)`
//!
//! with `f_k` the floor's fraction of the ground under the wheels (the
//! gradient of the blended slip with respect to the floor's own). The
//! integrator settles where the mean innovation is zero, however much of
//! each innovation the filter's velocity absorbs. `s_k` starts at the grip
//! table's prior ([`super::grip_table::GripModel::slip_gain`]) and stays
//! within `[0, MAX_SLIP]`; the learner keeps the offset from the prior.
//!
//! Only floors on which the wheel radii are held learn (the low-grip ones,
//! [`super::grip_table::GripTable::holds_radius`]): on the others the
//! radius states take the same innovation, and a slip learned there would
//! trade against the radius along a direction nothing observes. Gated
//! samples (a slip episode, not the floor's steady slip) and samples below
//! the minimum wheel speed (the ratio is undefined at rest) are refused
//! and counted.
//!
//! What a robot learned is exported as a fixed 52-byte record of its own
//! (magic `TSLP`, version, wheel type, per floor the offset and the sample
//! count, CRC-32), next to the noise learner's ([`super::learning`]), and
//! restored after a restart; corrupt records are refused. A record of its
//! own: each learner's record restores without the other's, and the noise
//! record's version 1 stays readable as it is.

use core::fmt;

use vslam_core::{Reject, SampleCounts};

use super::classes::SurfaceKind;
use super::grip_table::WheelType;
use super::learning::RecordError;
use super::mix::SurfaceMix;
use crate::grip::MAX_SLIP;

/// Length of the exported slip record, bytes.
pub const SLIP_RECORD_LEN: usize = 8 + 8 * SurfaceKind::COUNT + 4;
/// First bytes of every slip record.
pub const SLIP_RECORD_MAGIC: [u8; 4] = *b"TSLP";
/// Slip record format version written by this code.
pub const SLIP_RECORD_VERSION: u8 = 1;

/// Why a slip-learning configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlipConfigError {
    /// The rate must be finite and in `[0, 1]`.
    Rate,
    /// Minimum speed, ratio cap and minimum fraction must be finite and
    /// positive (the fraction at most 1).
    Limits,
}

impl fmt::Display for SlipConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SlipConfigError::Rate => "slip learning rate must lie in [0, 1]",
            SlipConfigError::Limits => {
                "minimum speed, ratio cap and minimum fraction must be positive"
            }
        })
    }
}

impl core::error::Error for SlipConfigError {}

/// How fast the expected slip is learned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlipConfig {
    rate: f32,
    min_speed: f32,
    ratio_cap: f32,
    min_fraction: f32,
}

impl Default for SlipConfig {
    /// Rate 1e-2, wheels at least 0.05 m/s, one sample's ratio capped at
    /// 0.5, a floor learns where it covers at least 20 % of the ground.
    /// The filter's velocity follows the wheels in part, so only a part of
    /// the slip not yet expected shows in the innovation (about a fifth in
    /// the simulated office, where the camera and the flow hold the
    /// velocity): the time constant is about `1 / (rate * that part)`
    /// samples, some 500 (10 s of 50 Hz wheels) there.
    fn default() -> Self {
        SlipConfig {
            rate: 6e-2,
            min_speed: 0.05,
            ratio_cap: 0.5,
            min_fraction: 0.2,
        }
    }
}

impl SlipConfig {
    /// Checks and builds a configuration: `rate` in `[0, 1]` (0 switches
    /// the learning off, the priors stay), `min_speed` (m/s), `ratio_cap`
    /// and `min_fraction` (at most 1) finite and positive.
    pub fn new(
        rate: f32,
        min_speed: f32,
        ratio_cap: f32,
        min_fraction: f32,
    ) -> Result<Self, SlipConfigError> {
        if !(0.0..=1.0).contains(&rate) {
            return Err(SlipConfigError::Rate);
        }
        let pos = |v: f32| v.is_finite() && v > 0.0;
        if !(pos(min_speed) && pos(ratio_cap) && pos(min_fraction) && min_fraction <= 1.0) {
            return Err(SlipConfigError::Limits);
        }
        Ok(SlipConfig {
            rate,
            min_speed,
            ratio_cap,
            min_fraction,
        })
    }

    /// The defaults with learning off (rate 0): the floors keep their
    /// priors.
    pub fn off() -> Self {
        SlipConfig {
            rate: 0.0,
            ..SlipConfig::default()
        }
    }

    /// Learning rate.
    pub fn rate(&self) -> f32 {
        self.rate
    }
    /// Slowest wheel speed a sample may have, m/s.
    pub fn min_speed(&self) -> f32 {
        self.min_speed
    }
    /// Largest `|nu / u|` one sample contributes.
    pub fn ratio_cap(&self) -> f32 {
        self.ratio_cap
    }
    /// Smallest fraction of the ground for a sample to count for a floor.
    pub fn min_fraction(&self) -> f32 {
        self.min_fraction
    }
}

/// What the slip learner knows about one floor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlipStats {
    /// Learned slip minus the grip table's prior.
    pub offset: f32,
    /// Fraction-weighted samples seen (saturates at `f32::MAX`).
    pub samples: f32,
}

/// Learns, per low-grip floor, the expected slip that zeroes the mean
/// forward wheel innovation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlipLearner {
    config: SlipConfig,
    floors: [SlipStats; SurfaceKind::COUNT],
    counts: SampleCounts,
}

impl SlipLearner {
    /// A learner that knows nothing yet (every floor at its prior).
    pub fn new(config: SlipConfig) -> Self {
        SlipLearner {
            config,
            floors: [SlipStats::default(); SurfaceKind::COUNT],
            counts: SampleCounts::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SlipConfig {
        &self.config
    }

    /// Forgets everything learned.
    pub fn reset(&mut self) {
        *self = SlipLearner::new(self.config);
    }

    /// What is known about one floor.
    pub fn stats(&self, kind: SurfaceKind) -> SlipStats {
        self.floors.get(kind.index()).copied().unwrap_or_default()
    }

    /// The learned offsets from the priors ([`SurfaceKind`] order).
    pub fn offsets(&self) -> [f32; SurfaceKind::COUNT] {
        self.floors.map(|s| s.offset)
    }

    /// Samples used and refused, by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Learns from one forward innovation `forward` (m/s) of a wheel sample
    /// whose wheels rolled at `speed` (m/s), seen while the floor was `mix`
    /// with the priors `prior` and the learnable floors `learnable` (both
    /// in [`SurfaceKind`] order); `gated`: the filter's gate refused it.
    ///
    /// Refuses (and counts) non-finite values ([`Reject::NonFinite`]), a
    /// gated sample ([`Reject::Gated`]), wheels slower than the minimum
    /// speed ([`Reject::Degenerate`]) and a mix in which no learnable floor
    /// covers the minimum fraction ([`Reject::LowQuality`]).
    pub fn observe(
        &mut self,
        mix: &SurfaceMix,
        forward: f32,
        speed: f32,
        gated: bool,
        prior: &[f32; SurfaceKind::COUNT],
        learnable: &[bool; SurfaceKind::COUNT],
    ) -> Result<(), Reject> {
        let outcome = self.observe_inner(mix, forward, speed, gated, prior, learnable);
        self.counts.record(outcome);
        outcome
    }

    fn observe_inner(
        &mut self,
        mix: &SurfaceMix,
        forward: f32,
        speed: f32,
        gated: bool,
        prior: &[f32; SurfaceKind::COUNT],
        learnable: &[bool; SurfaceKind::COUNT],
    ) -> Result<(), Reject> {
        if !(forward.is_finite() && speed.is_finite()) {
            return Err(Reject::NonFinite);
        }
        if gated {
            return Err(Reject::Gated);
        }
        let c = self.config;
        if libm::fabsf(speed) < c.min_speed {
            return Err(Reject::Degenerate);
        }
        let ratio = (forward / speed).clamp(-c.ratio_cap, c.ratio_cap);
        let mut used = false;
        let floors = self.floors.iter_mut().zip(mix.fractions().iter());
        for ((floor, f), (p, l)) in floors.zip(prior.iter().zip(learnable.iter())) {
            if !*l || *f < c.min_fraction {
                continue;
            }
            used = true;
            let slip = (p + floor.offset + c.rate * f * ratio).clamp(0.0, MAX_SLIP);
            let offset = slip - p;
            if offset.is_finite() {
                floor.offset = offset;
            }
            floor.samples = (floor.samples + f).min(f32::MAX);
        }
        if used {
            Ok(())
        } else {
            Err(Reject::LowQuality)
        }
    }

    /// The learned offsets as a fixed-size record for a robot with `wheel`
    /// (see the module docs).
    pub fn to_bytes(&self, wheel: WheelType) -> [u8; SLIP_RECORD_LEN] {
        let mut out = [0u8; SLIP_RECORD_LEN];
        let (payload, crc_out) = out.split_at_mut(SLIP_RECORD_LEN - 4);
        let (head, body) = payload.split_at_mut(8);
        let [m0, m1, m2, m3] = SLIP_RECORD_MAGIC;
        head.copy_from_slice(&[
            m0,
            m1,
            m2,
            m3,
            SLIP_RECORD_VERSION,
            wheel as u8,
            SurfaceKind::COUNT as u8,
            0,
        ]);
        for (chunk, s) in body.chunks_exact_mut(8).zip(self.floors.iter()) {
            for (dst, v) in chunk.chunks_exact_mut(4).zip([s.offset, s.samples]) {
                dst.copy_from_slice(&v.to_le_bytes());
            }
        }
        let crc = crc32fast::hash(payload);
        crc_out.copy_from_slice(&crc.to_le_bytes());
        out
    }

    /// Restores a record written by [`SlipLearner::to_bytes`] for a robot
    /// with `wheel`. On error the learner is unchanged. Offsets are kept
    /// as they were learned (the blend clamps the slip into range).
    pub fn restore(&mut self, bytes: &[u8], wheel: WheelType) -> Result<(), RecordError> {
        if bytes.len() != SLIP_RECORD_LEN {
            return Err(RecordError::Length);
        }
        let (payload, crc_in) = bytes.split_at(SLIP_RECORD_LEN - 4);
        let (head, body) = payload.split_at(8);
        if head.get(..4) != Some(&SLIP_RECORD_MAGIC[..]) {
            return Err(RecordError::Magic);
        }
        let mut crc = [0u8; 4];
        for (o, b) in crc.iter_mut().zip(crc_in) {
            *o = *b;
        }
        if crc32fast::hash(payload) != u32::from_le_bytes(crc) {
            return Err(RecordError::Checksum);
        }
        if head.get(4) != Some(&SLIP_RECORD_VERSION)
            || head.get(6) != Some(&(SurfaceKind::COUNT as u8))
        {
            return Err(RecordError::Version);
        }
        if head.get(5) != Some(&(wheel as u8)) {
            return Err(RecordError::WheelMismatch);
        }
        let mut floors = [SlipStats::default(); SurfaceKind::COUNT];
        for (chunk, s) in body.chunks_exact(8).zip(floors.iter_mut()) {
            let mut v = [0.0f32; 2];
            for (o, b) in v.iter_mut().zip(chunk.chunks_exact(4)) {
                let mut w = [0u8; 4];
                for (d, x) in w.iter_mut().zip(b) {
                    *d = *x;
                }
                *o = f32::from_le_bytes(w);
            }
            let [offset, samples] = v;
            let in_range = offset.is_finite() && libm::fabsf(offset) <= MAX_SLIP;
            if !(in_range && samples.is_finite() && samples >= 0.0) {
                return Err(RecordError::Value);
            }
            *s = SlipStats { offset, samples };
        }
        self.floors = floors;
        Ok(())
    }
}
