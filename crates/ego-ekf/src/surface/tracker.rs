//! Keeps the floor between segmentation maps.
//!
//! Segmentation runs at a few hertz, the filter at 250 Hz. The tracker holds
//! the last surface mix and when it was seen, so the filter can ask at any
//! time what floor it is on:
//!
//! - a map with ground replaces the floor underfoot by its present mix
//!   ([`GroundView::present_mix`]: the kinds in the near band) and its
//!   anticipation of a floor ahead; a map without ground ([`NoSurface`]) keeps
//!   the last floor, counted;
//! - a forward camera cannot see under the robot: once an announced floor (or
//!   any other new floor, beyond it) is the nearest one in view but the
//!   announced arrival time has not come, the floor underfoot and the
//!   announced arrival are kept; an announced floor that
//!   leaves the view before its arrival (a narrow strip passing below the
//!   camera's nearest floor) stays announced until it arrives, unless a new
//!   floor is announced;
//! - the answer carries the age of the mix; beyond `stale_after` it blends
//!   linearly, over `fallback_ramp`, towards a conservative default;
//! - an anticipated floor ahead takes over around its arrival time
//!   (see [`Anticipation::weight_at`]);
//! - a change of the dominant floor between maps, and an anticipated arrival
//!   that has passed, are remembered as boundary crossings (threshold strips
//!   sit on them, see [`crate::events`]).

use core::fmt;

use vslam_core::{Reject, SampleCounts, Timestamp};

use super::anticipation::{Anticipation, GroundCamera};
use super::classes::SurfaceKind;
use super::mix::SurfaceMix;
use super::segmentation::{GroundView, NoSurface};

/// Why a tracker configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrackerConfigError {
    /// The minimum speed must be finite and positive.
    MinSpeed,
}

impl fmt::Display for TrackerConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("minimum speed must be finite and positive")
    }
}

impl core::error::Error for TrackerConfigError {}

/// Timing of the tracker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackerConfig {
    stale_after_ns: u64,
    fallback_ramp_ns: u64,
    transition_ns: u64,
    min_speed: f32,
    anticipation_horizon_ns: u64,
}

impl Default for TrackerConfig {
    /// Stale after 1.5 s (several missed maps), fully conservative 2 s later,
    /// a 0.3 s transition onto an anticipated floor, no arrival time below
    /// 2 cm/s or beyond 10 s.
    fn default() -> Self {
        TrackerConfig {
            stale_after_ns: 1_500_000_000,
            fallback_ramp_ns: 2_000_000_000,
            transition_ns: 300_000_000,
            min_speed: 0.02,
            anticipation_horizon_ns: 10_000_000_000,
        }
    }
}

impl TrackerConfig {
    /// Checks and builds the timing (all durations in nanoseconds).
    ///
    /// - `stale_after_ns`: age beyond which the mix is stale;
    /// - `fallback_ramp_ns`: how long the blend to the conservative default takes;
    /// - `transition_ns`: width of the blend onto an anticipated floor;
    /// - `min_speed`: forward speed, m/s, below which no arrival is predicted;
    /// - `anticipation_horizon_ns`: arrivals further away are not predicted.
    pub fn new(
        stale_after_ns: u64,
        fallback_ramp_ns: u64,
        transition_ns: u64,
        min_speed: f32,
        anticipation_horizon_ns: u64,
    ) -> Result<Self, TrackerConfigError> {
        if !(min_speed.is_finite() && min_speed > 0.0) {
            return Err(TrackerConfigError::MinSpeed);
        }
        Ok(TrackerConfig {
            stale_after_ns,
            fallback_ramp_ns,
            transition_ns,
            min_speed,
            anticipation_horizon_ns,
        })
    }

    /// Age beyond which the mix is stale, ns.
    pub fn stale_after_ns(&self) -> u64 {
        self.stale_after_ns
    }
    /// Duration of the blend towards the conservative default, ns.
    pub fn fallback_ramp_ns(&self) -> u64 {
        self.fallback_ramp_ns
    }
    /// Width of the blend onto an anticipated floor, ns.
    pub fn transition_ns(&self) -> u64 {
        self.transition_ns
    }
}

/// What the tracker says about the floor at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceState {
    /// The floor mix in effect (the last map's, blended onto an anticipated
    /// floor around its arrival); `None` before the first map with ground.
    pub mix: Option<SurfaceMix>,
    /// Seconds since the map the mix comes from.
    pub age_s: Option<f32>,
    /// How far to blend towards the conservative default, `[0, 1]`: 0 while
    /// fresh, 1 when fully stale or before any map.
    pub fallback_weight: f32,
    /// The anticipated floor ahead, if any.
    pub anticipation: Option<Anticipation>,
    /// How far the anticipated floor has taken over, `[0, 1]`.
    pub anticipation_weight: f32,
}

impl SurfaceState {
    /// The dominant floor of the mix in effect.
    pub fn dominant(&self) -> Option<SurfaceKind> {
        self.mix.map(|m| m.dominant())
    }

    /// Whether the mix is older than the staleness limit (or missing).
    pub fn is_stale(&self) -> bool {
        self.fallback_weight > 0.0
    }
}

/// The last floor seen and how old it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceTracker {
    config: TrackerConfig,
    camera: GroundCamera,
    last_map: Option<Timestamp>,
    mix: Option<SurfaceMix>,
    kind: Option<SurfaceKind>,
    anticipation: Option<Anticipation>,
    last_crossing: Option<Timestamp>,
    maps: SampleCounts,
    last_no_surface: Option<NoSurface>,
}

impl SurfaceTracker {
    /// A tracker that has seen no map yet.
    pub fn new(config: TrackerConfig, camera: GroundCamera) -> Self {
        SurfaceTracker {
            config,
            camera,
            last_map: None,
            mix: None,
            kind: None,
            anticipation: None,
            last_crossing: None,
            maps: SampleCounts::new(),
            last_no_surface: None,
        }
    }

    /// The timing configuration.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// The camera geometry.
    pub fn camera(&self) -> &GroundCamera {
        &self.camera
    }

    /// Maps used (fused) and refused: out of order or duplicate
    /// ([`Reject::OutOfOrder`], [`Reject::Duplicate`]) and without surface
    /// information ([`Reject::LowQuality`]).
    pub fn counts(&self) -> &SampleCounts {
        &self.maps
    }

    /// Why the last map without surface information had none.
    pub fn last_no_surface(&self) -> Option<NoSurface> {
        self.last_no_surface
    }

    /// When the last map with ground was taken.
    pub fn last_map_time(&self) -> Option<Timestamp> {
        self.last_map
    }

    /// The last crossing of a floor boundary at or before `t`: an observed
    /// change of the dominant floor, or an anticipated arrival that has passed.
    pub fn last_crossing(&self, t: Timestamp) -> Option<Timestamp> {
        let anticipated = self
            .anticipation
            .and_then(|a| a.arrival)
            .filter(|a| *a <= t);
        let observed = self.last_crossing.filter(|c| *c <= t);
        anticipated.max(observed)
    }

    /// The next anticipated crossing after `t`, if any.
    pub fn next_crossing(&self, t: Timestamp) -> Option<Timestamp> {
        self.anticipation.and_then(|a| a.arrival).filter(|a| *a > t)
    }

    /// Takes one segmentation result, taken at `t`, while the robot moved
    /// forward at `forward_speed` m/s. A map older than the last one is
    /// refused; a map without surface keeps the last floor (both counted).
    pub fn on_map(
        &mut self,
        t: Timestamp,
        view: Result<&GroundView, NoSurface>,
        forward_speed: f32,
    ) -> Result<(), Reject> {
        let outcome = self.on_map_inner(t, view, forward_speed);
        self.maps.record(outcome);
        outcome
    }

    fn on_map_inner(
        &mut self,
        t: Timestamp,
        view: Result<&GroundView, NoSurface>,
        forward_speed: f32,
    ) -> Result<(), Reject> {
        if let Some(last) = self.last_map {
            if t < last {
                return Err(Reject::OutOfOrder);
            }
            if t == last {
                return Err(Reject::Duplicate);
            }
        }
        let view = match view {
            Ok(v) => v,
            Err(why) => {
                self.last_no_surface = Some(why);
                return Err(Reject::LowQuality);
            }
        };
        // A passed anticipated arrival is a crossing, kept before it is replaced.
        self.last_crossing = self.last_crossing(t);
        let new_kind = view.current_kind();
        let previous_map = self.last_map.replace(t);
        if let Some(p) = self.anticipation
            && p.arrival.is_some_and(|a| a > t)
            && (p.kind == new_kind || self.kind.is_some_and(|k| k != new_kind))
        {
            // The wheels have not reached the announced boundary yet, and the
            // nearest floor in view is the announced one, or another new floor
            // beyond it (a strip passing below the view, the next room's floor
            // behind it): all of it lies ahead. Keep the floor underfoot and
            // the announced arrival.
            return Ok(());
        }
        // An announced boundary passed since the previous map explains a new
        // floor (the strip's, or the one behind a strip) without a crossing
        // of its own at the map's time.
        let arrived_as_announced = self.anticipation.is_some_and(|p| {
            p.arrival
                .is_some_and(|a| a <= t && previous_map.is_none_or(|m| a > m))
        });
        if self.kind.is_some_and(|old| old != new_kind) && !arrived_as_announced {
            self.last_crossing = Some(t);
        }
        self.kind = Some(new_kind);
        self.mix = Some(view.present_mix());
        let fresh = view.upcoming.and_then(|u| {
            Anticipation::from_upcoming(
                &u,
                &self.camera,
                t,
                forward_speed,
                self.config.min_speed,
                self.config.anticipation_horizon_ns,
            )
        });
        // A floor announced earlier that the view no longer shows has moved
        // between the camera's nearest floor and the wheels (a narrow strip
        // does): it stays announced until its arrival.
        let still_coming = self
            .anticipation
            .is_some_and(|p| p.arrival.is_some_and(|a| a > t));
        if fresh.is_some() || !still_coming {
            self.anticipation = fresh;
        }
        Ok(())
    }

    /// The floor in effect at `t` (see [`SurfaceState`]).
    pub fn state_at(&self, t: Timestamp) -> SurfaceState {
        let (Some(mix), Some(seen)) = (self.mix, self.last_map) else {
            return SurfaceState {
                mix: None,
                age_s: None,
                fallback_weight: 1.0,
                anticipation: None,
                anticipation_weight: 0.0,
            };
        };
        // A query from before the map counts as age zero.
        let age_ns = t.nanos_since(seen).unwrap_or(0);
        let fallback_weight = if age_ns <= self.config.stale_after_ns {
            0.0
        } else if self.config.fallback_ramp_ns == 0 {
            1.0
        } else {
            let over = age_ns - self.config.stale_after_ns;
            (over as f32 / self.config.fallback_ramp_ns as f32).min(1.0)
        };
        let anticipation_weight = self
            .anticipation
            .map(|a| a.weight_at(t, self.config.transition_ns))
            .unwrap_or(0.0);
        let mix = match self.anticipation {
            Some(a) if anticipation_weight > 0.0 => {
                mix.blend(&SurfaceMix::pure(a.kind), anticipation_weight)
            }
            _ => mix,
        };
        SurfaceState {
            mix: Some(mix),
            age_s: Some(vslam_core::time::nanos_to_seconds(age_ns)),
            fallback_weight,
            anticipation: self.anticipation,
            anticipation_weight,
        }
    }
}
