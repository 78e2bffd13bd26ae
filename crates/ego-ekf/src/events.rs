//! Vertical jolts: suspected obstacle, or just the floor?
//!
//! Per IMU step the filter hands over the vertical specific-force deviation
//! `|a_z - g|` (m/s^2, bias corrected). A robot driving onto an obstacle (a
//! cable, a toy, a door stop) sees a short, sharp vertical jolt; so does a
//! robot crossing a threshold strip, and carpet shakes the body all the time.
//! The detector therefore judges every jolt against what the *current floor*
//! explains ([`GripParams::jolt_threshold`](crate::grip::GripParams::jolt_threshold)):
//!
//! - a short-window peak detector: a jolt starts when the deviation exceeds
//!   the onset level, its peak is taken over `window` (40-80 ms: a wheel
//!   rolling over a 1 cm edge at 0.3 m/s), then a refractory time and a
//!   hysteresis (the deviation must fall below the re-arm level) make one bump
//!   one event;
//! - the peak is [`JoltKind::SurfaceNoise`] if the floor explains it (or
//!   [`JoltKind::ThresholdStrip`] if that floor is a threshold strip: the
//!   robot is on one), [`JoltKind::ThresholdStrip`] if it is larger but
//!   lies within a configured time or distance of a floor-boundary crossing
//!   and below what a threshold strip explains, and
//!   [`JoltKind::SuspectedObstacle`] otherwise; a strip is narrow, so as the
//!   floor in view it explains a jolt only near a crossing (elsewhere the
//!   floor beside it does: a segmenter that takes a floor for a strip cannot
//!   explain a cable away);
//! - every event is counted by kind and kept in a small fixed-size log that
//!   drops (and counts) its oldest entry when full.
//!
//! Bad samples (non-finite, out of order, duplicate) are refused and counted;
//! a gap in the stream closes an open jolt and re-arms only once calm.

use core::fmt;

use heapless::Deque;
use vslam_core::{Reject, SampleClock, SampleCounts, Timestamp};

/// The surface model's answer per IMU step, kept in [`crate::surface`] (the
/// model makes it, this module reads it) and named here too.
pub use crate::surface::JoltContext;
use crate::surface::SurfaceKind;

/// What a jolt was judged to be.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum JoltKind {
    /// Larger than the floor explains: something may be in the way.
    SuspectedObstacle = 0,
    /// Within what the floor explains (carpet pile, tile grout).
    SurfaceNoise = 1,
    /// Larger than the floor explains, but at a floor boundary and within what
    /// a threshold strip explains; or within what the floor explains when
    /// that floor is a threshold strip (the robot on the strip).
    ThresholdStrip = 2,
}

impl JoltKind {
    /// How many kinds there are.
    pub const COUNT: usize = 3;
    /// Every kind, in counter order.
    pub const ALL: [JoltKind; JoltKind::COUNT] = [
        JoltKind::SuspectedObstacle,
        JoltKind::SurfaceNoise,
        JoltKind::ThresholdStrip,
    ];

    /// Whether the robot should react (stop, back off, look).
    pub const fn is_obstacle(self) -> bool {
        matches!(self, JoltKind::SuspectedObstacle)
    }

    /// A short snake_case name, stable for reports.
    pub const fn name(self) -> &'static str {
        match self {
            JoltKind::SuspectedObstacle => "suspected_obstacle",
            JoltKind::SurfaceNoise => "surface_noise",
            JoltKind::ThresholdStrip => "threshold_strip",
        }
    }
}

impl fmt::Display for JoltKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One judged jolt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JoltEvent {
    /// When the deviation first exceeded the onset level.
    pub onset: Timestamp,
    /// When the peak occurred.
    pub t: Timestamp,
    /// The peak vertical deviation, m/s^2.
    pub magnitude: f32,
    /// The jolt the floor explained at the time, m/s^2.
    pub explained: f32,
    /// The dominant floor at the time, if known.
    pub surface: Option<SurfaceKind>,
    /// The judgement.
    pub kind: JoltKind,
}

/// Why a jolt configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JoltConfigError {
    /// The window must be at least 1 ms and the maximum step positive.
    Timing,
    /// Levels and fractions must be finite and positive (fractions at most 1).
    Levels,
    /// The crossing distance must be finite and non-negative.
    Distance,
}

impl fmt::Display for JoltConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            JoltConfigError::Timing => "jolt window must be at least 1 ms and the step positive",
            JoltConfigError::Levels => "jolt levels and fractions must be positive",
            JoltConfigError::Distance => "crossing distance must be non-negative",
        })
    }
}

impl core::error::Error for JoltConfigError {}

/// Timing and levels of the jolt detector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JoltConfig {
    window_ns: u64,
    refractory_ns: u64,
    onset_level: f32,
    onset_fraction: f32,
    rearm_fraction: f32,
    crossing_time_ns: u64,
    crossing_distance: f32,
    max_step_ns: u64,
}

impl Default for JoltConfig {
    /// 60 ms window, 150 ms refractory, onset at 1.5 m/s^2 or 60 % of what the
    /// floor explains (the larger), re-arm below half the onset, a jolt within
    /// 0.5 s or 15 cm of a floor boundary may be a threshold strip (the strip,
    /// both edges of the wheel run over it and the error of the predicted
    /// arrival), samples
    /// more than 50 ms apart are a gap.
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl JoltConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = JoltConfig {
        window_ns: 60_000_000,
        refractory_ns: 150_000_000,
        onset_level: 1.5,
        onset_fraction: 0.6,
        rearm_fraction: 0.5,
        crossing_time_ns: 500_000_000,
        crossing_distance: 0.15,
        max_step_ns: 50_000_000,
    };
}

impl JoltConfig {
    /// Checks and builds the configuration.
    ///
    /// - `window_ns`: peak window after the onset (>= 1 ms);
    /// - `refractory_ns`: quiet time after a window;
    /// - `onset_level`: lowest onset level, m/s^2;
    /// - `onset_fraction`: onset at least this fraction of the explained jolt, `(0, 1]`;
    /// - `rearm_fraction`: re-arm below this fraction of the onset level, `(0, 1]`;
    /// - `crossing_time_ns`, `crossing_distance` (m): how near a boundary
    ///   crossing a jolt may be a threshold strip;
    /// - `max_step_ns`: longer steps between samples are gaps (> 0).
    pub fn new(
        window_ns: u64,
        refractory_ns: u64,
        onset_level: f32,
        onset_fraction: f32,
        rearm_fraction: f32,
        crossing_time_ns: u64,
        crossing_distance: f32,
        max_step_ns: u64,
    ) -> Result<Self, JoltConfigError> {
        if window_ns < 1_000_000 || max_step_ns == 0 {
            return Err(JoltConfigError::Timing);
        }
        let frac = |v: f32| v > 0.0 && v <= 1.0;
        if !(onset_level.is_finite()
            && onset_level > 0.0
            && frac(onset_fraction)
            && frac(rearm_fraction))
        {
            return Err(JoltConfigError::Levels);
        }
        if !(crossing_distance.is_finite() && crossing_distance >= 0.0) {
            return Err(JoltConfigError::Distance);
        }
        Ok(JoltConfig {
            window_ns,
            refractory_ns,
            onset_level,
            onset_fraction,
            rearm_fraction,
            crossing_time_ns,
            crossing_distance,
            max_step_ns,
        })
    }

    /// Peak window, ns.
    pub fn window_ns(&self) -> u64 {
        self.window_ns
    }
    /// Refractory time, ns.
    pub fn refractory_ns(&self) -> u64 {
        self.refractory_ns
    }

    /// The onset level for a context, m/s^2.
    pub fn onset(&self, ctx: &JoltContext) -> f32 {
        let scaled = self.onset_fraction * ctx.jolt_threshold;
        if scaled.is_finite() {
            self.onset_level.max(scaled)
        } else {
            self.onset_level
        }
    }

    /// Whether `t` lies within the crossing time or distance of a boundary
    /// crossing of the context.
    pub fn near_crossing(&self, t: Timestamp, ctx: &JoltContext) -> bool {
        [ctx.last_crossing, ctx.next_crossing]
            .iter()
            .flatten()
            .any(|c| {
                let dt_ns = t.as_nanos().abs_diff(c.as_nanos());
                let by_time = dt_ns <= self.crossing_time_ns;
                let v = libm::fabsf(ctx.forward_speed);
                let by_distance = v.is_finite()
                    && v * vslam_core::time::nanos_to_seconds(dt_ns) <= self.crossing_distance;
                by_time || by_distance
            })
    }

    /// Judges a peak at `t` in a context. A threshold strip is narrow: as
    /// the floor in view it explains a jolt only at a floor boundary, and
    /// away from one the floor beside it does ([`JoltContext::floor_jolt_threshold`]:
    /// a segmenter that takes a whole floor for a strip cannot explain a
    /// cable away). A jolt explained while the floor in view is a strip is
    /// the strip's.
    pub fn classify(&self, t: Timestamp, magnitude: f32, ctx: &JoltContext) -> JoltKind {
        let on_strip = ctx.surface == Some(SurfaceKind::Threshold);
        let near = || self.near_crossing(t, ctx);
        let explained = if on_strip && !near() {
            ctx.floor_jolt_threshold
        } else {
            ctx.jolt_threshold
        };
        if magnitude <= explained {
            if on_strip {
                JoltKind::ThresholdStrip
            } else {
                JoltKind::SurfaceNoise
            }
        } else if magnitude <= ctx.strip_threshold && near() {
            JoltKind::ThresholdStrip
        } else {
            JoltKind::SuspectedObstacle
        }
    }
}

/// Where the detector is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Waiting for a jolt; `armed` once the deviation has been calm.
    Idle { armed: bool },
    /// Inside a jolt's window; `ctx` is the context at the peak.
    Capturing {
        onset: Timestamp,
        peak: f32,
        peak_t: Timestamp,
        ctx: JoltContext,
    },
    /// After a window, until the given time.
    Refractory { until: Timestamp },
}

/// Short-window peak detector with refractory time and hysteresis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JoltDetector {
    config: JoltConfig,
    clock: SampleClock,
    phase: Phase,
    samples: SampleCounts,
}

impl JoltDetector {
    /// A detector, armed.
    pub const fn new(config: JoltConfig) -> Self {
        JoltDetector {
            config,
            clock: SampleClock::new(config.max_step_ns),
            phase: Phase::Idle { armed: true },
            samples: SampleCounts::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &JoltConfig {
        &self.config
    }

    /// Samples used and refused, by reason.
    pub fn samples(&self) -> &SampleCounts {
        &self.samples
    }

    /// Whether a jolt window is open.
    pub fn is_capturing(&self) -> bool {
        matches!(self.phase, Phase::Capturing { .. })
    }

    /// Takes one vertical deviation sample (m/s^2; its absolute value is
    /// used) at `t`, with `ctx` what the floor explains at `t`. Returns the
    /// event of a jolt whose window closed with this sample; the peak is
    /// judged in the context of the peak's time.
    pub fn push(
        &mut self,
        t: Timestamp,
        deviation: f32,
        ctx: &JoltContext,
    ) -> Result<Option<JoltEvent>, Reject> {
        if !deviation.is_finite() {
            self.samples.rejected_one(Reject::NonFinite);
            return Err(Reject::NonFinite);
        }
        let x = libm::fabsf(deviation);
        match self.clock.accept(t) {
            Ok(_) => {}
            Err(Reject::Gap) => {
                // The stream broke: close an open jolt with what was seen,
                // then wait for calm before the next one.
                self.samples.rejected_one(Reject::Gap);
                let ev = self.close();
                self.phase = Phase::Idle { armed: false };
                return Ok(ev);
            }
            Err(r) => {
                self.samples.rejected_one(r);
                return Err(r);
            }
        }
        self.samples.fused_one();
        Ok(self.step(t, x, ctx))
    }

    fn close(&mut self) -> Option<JoltEvent> {
        if let Phase::Capturing {
            onset,
            peak,
            peak_t,
            ctx,
        } = self.phase
        {
            self.phase = Phase::Idle { armed: false };
            Some(self.event(onset, peak_t, peak, &ctx))
        } else {
            None
        }
    }

    fn event(&self, onset: Timestamp, t: Timestamp, peak: f32, ctx: &JoltContext) -> JoltEvent {
        JoltEvent {
            onset,
            t,
            magnitude: peak,
            explained: ctx.jolt_threshold,
            surface: ctx.surface,
            kind: self.config.classify(t, peak, ctx),
        }
    }

    fn step(&mut self, t: Timestamp, x: f32, ctx: &JoltContext) -> Option<JoltEvent> {
        let onset_level = self.config.onset(ctx);
        match self.phase {
            Phase::Idle { armed } => {
                if armed && x >= onset_level {
                    self.phase = Phase::Capturing {
                        onset: t,
                        peak: x,
                        peak_t: t,
                        ctx: *ctx,
                    };
                } else if !armed && x < self.config.rearm_fraction * onset_level {
                    self.phase = Phase::Idle { armed: true };
                }
                None
            }
            Phase::Capturing {
                onset,
                peak,
                peak_t,
                ctx: peak_ctx,
            } => {
                // The peak is judged by what the floor explained at its time.
                let (peak, peak_t, peak_ctx) = if x > peak {
                    (x, t, *ctx)
                } else {
                    (peak, peak_t, peak_ctx)
                };
                let open_ns = t.nanos_since(onset).unwrap_or(0);
                if open_ns < self.config.window_ns {
                    self.phase = Phase::Capturing {
                        onset,
                        peak,
                        peak_t,
                        ctx: peak_ctx,
                    };
                    return None;
                }
                let until = onset
                    .checked_add_nanos(
                        self.config
                            .window_ns
                            .saturating_add(self.config.refractory_ns),
                    )
                    .unwrap_or(Timestamp(u64::MAX));
                self.phase = Phase::Refractory { until };
                Some(self.event(onset, peak_t, peak, &peak_ctx))
            }
            Phase::Refractory { until } => {
                if t >= until {
                    let armed = x < self.config.rearm_fraction * onset_level;
                    self.phase = Phase::Idle { armed };
                }
                None
            }
        }
    }
}

/// Counters of judged jolts, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct JoltCounters {
    counts: [u32; JoltKind::COUNT],
}

impl JoltCounters {
    /// Nothing counted.
    pub const fn new() -> Self {
        JoltCounters {
            counts: [0; JoltKind::COUNT],
        }
    }

    /// Counts one event.
    pub fn count(&mut self, kind: JoltKind) {
        if let Some(c) = self.counts.get_mut(kind as usize) {
            *c = c.saturating_add(1);
        }
    }
    /// Events of one kind.
    pub fn get(&self, kind: JoltKind) -> u32 {
        self.counts.get(kind as usize).copied().unwrap_or(0)
    }
    /// Events of every kind.
    pub fn total(&self) -> u32 {
        self.counts.iter().fold(0u32, |a, b| a.saturating_add(*b))
    }
}

/// Detector, counters and a log of the last `N` events.
#[derive(Clone, Debug)]
pub struct JoltMonitor<const N: usize> {
    detector: JoltDetector,
    counters: JoltCounters,
    log: Deque<JoltEvent, N>,
    dropped: u32,
}

impl<const N: usize> JoltMonitor<N> {
    /// A monitor with an empty log.
    pub const fn new(config: JoltConfig) -> Self {
        JoltMonitor {
            detector: JoltDetector::new(config),
            counters: JoltCounters::new(),
            log: Deque::new(),
            dropped: 0,
        }
    }

    /// Takes one vertical deviation sample; see [`JoltDetector::push`]. An
    /// event is counted and logged (the oldest entry makes room when full).
    pub fn push(
        &mut self,
        t: Timestamp,
        deviation: f32,
        ctx: &JoltContext,
    ) -> Result<Option<JoltEvent>, Reject> {
        let ev = self.detector.push(t, deviation, ctx)?;
        if let Some(e) = ev {
            self.record(e);
        }
        Ok(ev)
    }

    fn record(&mut self, e: JoltEvent) {
        self.counters.count(e.kind);
        if self.log.is_full() {
            // The oldest entry makes room (with N == 0 the new one is the loss).
            let _ = self.log.pop_front();
            self.dropped = self.dropped.saturating_add(1);
        }
        let _ = self.log.push_back(e);
    }

    /// The detector.
    pub fn detector(&self) -> &JoltDetector {
        &self.detector
    }
    /// Events counted by kind.
    pub fn counters(&self) -> &JoltCounters {
        &self.counters
    }
    /// The logged events, oldest first.
    pub fn events(&self) -> impl Iterator<Item = &JoltEvent> {
        self.log.iter()
    }
    /// Events dropped from the full log.
    pub fn dropped(&self) -> u32 {
        self.dropped
    }
    /// Empties the log (counters and dropped count are kept).
    pub fn clear_log(&mut self) {
        self.log.clear();
    }
}
