//! Flow sensor on demand: the downward optical-flow sensor is powered only
//! while slip is detected or predicted, and released after a quiet period
//! (seed 000, [0128]: the flow sensor "may be turned on when slip is
//! detected or predicted").
//!
//! [`FlowDemand`] is a two-state machine (off, on). Each call of
//! [`FlowDemand::update`] gets the slip cues at one time ([`SlipCues`]):
//!
//! - low grip under the wheels: the surface model's grip at `t` (only from a
//!   fresh floor, never from the stale fallback) below
//!   [`FlowDemandConfig::low_grip`];
//! - low grip ahead: the floor the surface model anticipates, arriving within
//!   [`FlowDemandConfig::lookahead_s`], has a grip below `low_grip`;
//! - a floor change ahead: the surface model anticipates another floor (or a
//!   threshold strip, a room's edge) arriving within the look-ahead,
//!   whatever its grip: the wheels' radii and expected slip were learned on
//!   the floor they leave, and the segmentation's 2 Hz maps and blend reach
//!   the new floor's grip only after the wheels are on it;
//! - a remembered slippery place: the adverse-event memory holds at least
//!   [`FlowDemandConfig::remembered_events`] (decayed) wheel events at the
//!   robot's position and time slot;
//! - wheels disagreeing with the IMU: the EKF's forward wheel innovation (the
//!   wheels' speed against the IMU-propagated state) was gated, or exceeded
//!   [`FlowDemandConfig::innovation_sigmas`] standard deviations.
//!
//! Any cue turns the sensor on ([`Command::Wake`]) and restarts the quiet
//! period; [`FlowDemandConfig::quiet_s`] seconds without a cue turn it off
//! ([`Command::Shutdown`]). The caller carries the command out (the
//! `flow-sensor` driver's `wake` / `shutdown`) and feeds the estimator flow
//! reports only while the sensor is on. [`FlowDemand::observe`] gathers the
//! cues from an [`Estimator`] after each processed sample.

use crate::estimator::{Estimator, Processed};
use ego_ekf::WheelInnovation;
use vslam_core::Timestamp;
use vslam_core::adverse::SensorKind;
use vslam_core::geometry::Vec2;

/// What turns the sensor on and what lets it go.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowDemandConfig {
    /// Grip (0, 1] below which a floor is slippery. Default 0.75: below
    /// wood, tile and concrete for every wheel type of the default grip table
    /// (`ego_ekf::surface::grip_table::DEFAULT_GRIP`), above carpet.
    pub low_grip: f32,
    /// How far ahead in time an anticipated floor counts, s. Default 1.0.
    pub lookahead_s: f32,
    /// Decayed wheel events at a place that make it a remembered slippery
    /// place. Default 2.0: the memory itself treats one event as chance
    /// (`vslam_core::adverse`: the weight drops from the second event).
    pub remembered_events: f32,
    /// Normalised forward wheel innovation `|nu| / sqrt(S)` above which the
    /// wheels disagree with the IMU. Default 3.0.
    pub innovation_sigmas: f32,
    /// Seconds without a cue before the sensor is released. Default 3.0:
    /// longer than the slip episodes' gaps the sensor should bridge, short
    /// against a run.
    pub quiet_s: f32,
}

impl Default for FlowDemandConfig {
    fn default() -> Self {
        FlowDemandConfig {
            low_grip: 0.75,
            lookahead_s: 1.0,
            remembered_events: 2.0,
            innovation_sigmas: 3.0,
            quiet_s: 3.0,
        }
    }
}

/// Why a [`FlowDemandConfig`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlowDemandConfigError {
    /// `low_grip` is not in (0, 1].
    LowGrip,
    /// A duration, event count or sigma count is not finite and non-negative
    /// (`innovation_sigmas`: positive).
    Threshold,
}

impl core::fmt::Display for FlowDemandConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FlowDemandConfigError::LowGrip => "flow demand: low_grip must lie in (0, 1]",
            FlowDemandConfigError::Threshold => {
                "flow demand: durations, event counts and sigmas must be finite and non-negative"
            }
        })
    }
}

impl core::error::Error for FlowDemandConfigError {}

impl FlowDemandConfig {
    /// Checks the values.
    pub fn check(&self) -> Result<(), FlowDemandConfigError> {
        if !(self.low_grip > 0.0 && self.low_grip <= 1.0) {
            return Err(FlowDemandConfigError::LowGrip);
        }
        let nonneg = |v: f32| v.is_finite() && v >= 0.0;
        let valid = nonneg(self.lookahead_s)
            && nonneg(self.remembered_events)
            && nonneg(self.quiet_s)
            && self.innovation_sigmas.is_finite()
            && self.innovation_sigmas > 0.0;
        if !valid {
            return Err(FlowDemandConfigError::Threshold);
        }
        Ok(())
    }
}

/// The slip evidence at one time; `None` / `0.0` / `false` where unknown.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlipCues {
    /// Grip of the floor under the wheels (fresh floor only).
    pub grip_under: Option<f32>,
    /// Grip of the floor anticipated within the look-ahead.
    pub grip_ahead: Option<f32>,
    /// Another floor (or a threshold strip) is anticipated within the
    /// look-ahead.
    pub floor_change_ahead: bool,
    /// Decayed wheel events the adverse memory holds here and now.
    pub remembered_wheel_events: f32,
    /// The last wheel innovation, if one came with this update.
    pub wheel: Option<WheelCue>,
}

/// The part of a wheel innovation the policy reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelCue {
    /// Forward innovation, m/s.
    pub forward: f32,
    /// Its variance, (m/s)^2.
    pub forward_var: f32,
    /// Whether the filter gated it.
    pub gated: bool,
}

impl From<&WheelInnovation> for WheelCue {
    fn from(i: &WheelInnovation) -> Self {
        WheelCue {
            forward: i.forward,
            forward_var: i.forward_var,
            gated: i.gated,
        }
    }
}

/// Which cue asked for the sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Cue {
    /// Low grip under the wheels.
    GripUnder = 0,
    /// Low grip ahead.
    GripAhead = 1,
    /// A remembered slippery place.
    Remembered = 2,
    /// Wheels disagreeing with the IMU.
    WheelsVsImu = 3,
    /// Another floor ahead.
    FloorChangeAhead = 4,
}

impl Cue {
    /// How many cues.
    pub const COUNT: usize = 5;
    /// Every cue, in index order.
    pub const ALL: [Cue; 5] = [
        Cue::GripUnder,
        Cue::GripAhead,
        Cue::Remembered,
        Cue::WheelsVsImu,
        Cue::FloorChangeAhead,
    ];
    /// Short name (reports).
    pub const fn name(self) -> &'static str {
        match self {
            Cue::GripUnder => "grip_under",
            Cue::GripAhead => "grip_ahead",
            Cue::Remembered => "remembered",
            Cue::WheelsVsImu => "wheels_vs_imu",
            Cue::FloorChangeAhead => "floor_change_ahead",
        }
    }
}

/// What the caller should do with the sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// Wake it (it was off).
    Wake(Cue),
    /// Shut it down (the quiet period passed).
    Shutdown,
}

/// The on-demand state machine (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowDemand {
    config: FlowDemandConfig,
    on_since: Option<Timestamp>,
    last_cue: Option<Timestamp>,
    last_t: Option<Timestamp>,
    on_ns: u64,
    wakes: u32,
    cues: [u32; Cue::COUNT],
}

impl FlowDemand {
    /// A policy with the sensor off.
    pub fn new(config: FlowDemandConfig) -> Result<Self, FlowDemandConfigError> {
        config.check()?;
        Ok(FlowDemand {
            config,
            on_since: None,
            last_cue: None,
            last_t: None,
            on_ns: 0,
            wakes: 0,
            cues: [0; Cue::COUNT],
        })
    }

    /// The configuration.
    pub fn config(&self) -> &FlowDemandConfig {
        &self.config
    }

    /// The first cue `cues` shows, in [`Cue`] order.
    pub fn cue(&self, cues: &SlipCues) -> Option<Cue> {
        let c = &self.config;
        let low = |g: Option<f32>| g.is_some_and(|g| g < c.low_grip);
        if low(cues.grip_under) {
            return Some(Cue::GripUnder);
        }
        if low(cues.grip_ahead) {
            return Some(Cue::GripAhead);
        }
        if cues.floor_change_ahead {
            return Some(Cue::FloorChangeAhead);
        }
        if cues.remembered_wheel_events >= c.remembered_events && c.remembered_events > 0.0 {
            return Some(Cue::Remembered);
        }
        if let Some(w) = cues.wheel {
            let k = c.innovation_sigmas;
            let far = w.forward_var > 0.0 && w.forward * w.forward > k * k * w.forward_var;
            if w.gated || far {
                return Some(Cue::WheelsVsImu);
            }
        }
        None
    }

    /// Steps the machine to `t` with the cues seen at `t`. A `t` earlier
    /// than the last one is taken as the last one (time never runs back).
    pub fn update(&mut self, t: Timestamp, cues: &SlipCues) -> Option<Command> {
        let t = match self.last_t {
            Some(last) if t < last => last,
            _ => t,
        };
        self.last_t = Some(t);
        if let Some(cue) = self.cue(cues) {
            self.last_cue = Some(t);
            if let Some(slot) = self.cues.get_mut(cue as usize) {
                *slot = slot.saturating_add(1);
            }
            if self.on_since.is_none() {
                self.on_since = Some(t);
                self.wakes = self.wakes.saturating_add(1);
                return Some(Command::Wake(cue));
            }
            return None;
        }
        let (Some(since), Some(cue_t)) = (self.on_since, self.last_cue) else {
            return None;
        };
        let quiet_ns = seconds_to_nanos(self.config.quiet_s);
        if t.nanos_since(cue_t).unwrap_or(0) >= quiet_ns {
            self.on_ns = self.on_ns.saturating_add(t.nanos_since(since).unwrap_or(0));
            self.on_since = None;
            return Some(Command::Shutdown);
        }
        None
    }

    /// Gathers the cues from `estimator` after it processed `processed`
    /// (module docs) and steps the machine to the sample's time.
    pub fn observe(&mut self, estimator: &Estimator<'_>, processed: &Processed) -> Option<Command> {
        let t = processed.t();
        let wheel = match processed {
            Processed::Wheel { outcome: Ok(i), .. } => Some(WheelCue::from(i)),
            _ => None,
        };
        let cues = SlipCues {
            wheel,
            ..self.context(estimator, t)
        };
        self.update(t, &cues)
    }

    /// The place and floor cues of `estimator` at `t` (no wheel cue).
    pub fn context(&self, estimator: &Estimator<'_>, t: Timestamp) -> SlipCues {
        let mut cues = SlipCues::default();
        if let Some(s) = estimator.surface() {
            let state = s.state_at(t);
            if state.mix.is_some() && !state.is_stale() {
                cues.grip_under = Some(s.grip_params(t).grip());
            }
            let horizon = Timestamp(t.0.saturating_add(seconds_to_nanos(self.config.lookahead_s)));
            let ahead = state
                .anticipation
                .filter(|a| a.arrival.is_some_and(|at| at >= t && at <= horizon));
            cues.grip_ahead = ahead.map(|a| s.table().grip(a.kind, s.wheel()));
            cues.floor_change_ahead = ahead.is_some();
        }
        let scale = estimator.scale();
        let p = scale.body_pose().translation.vector;
        cues.remembered_wheel_events =
            scale
                .memory()
                .events(SensorKind::Wheel, &Vec2::new(p.x, p.y), t);
        cues
    }

    /// Whether the sensor is on.
    pub fn is_on(&self) -> bool {
        self.on_since.is_some()
    }

    /// Seconds the sensor has been on, up to `now` for a current on period.
    pub fn on_seconds(&self, now: Timestamp) -> f64 {
        let current = self.on_since.and_then(|s| now.nanos_since(s)).unwrap_or(0);
        self.on_ns.saturating_add(current) as f64 * 1e-9
    }

    /// How many times the sensor was woken.
    pub fn wakes(&self) -> u32 {
        self.wakes
    }

    /// Updates that showed each cue, indexed by [`Cue`].
    pub fn cue_counts(&self) -> [u32; Cue::COUNT] {
        self.cues
    }
}

fn seconds_to_nanos(s: f32) -> u64 {
    // Checked configs are finite and non-negative; `as` saturates.
    (f64::from(s) * 1e9) as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Timestamp {
        Timestamp::from_nanos(v * 1_000_000)
    }

    fn quiet() -> SlipCues {
        SlipCues::default()
    }

    fn demand() -> FlowDemand {
        FlowDemand::new(FlowDemandConfig::default()).unwrap()
    }

    fn wheel(forward: f32, forward_var: f32, gated: bool) -> SlipCues {
        SlipCues {
            wheel: Some(WheelCue {
                forward,
                forward_var,
                gated,
            }),
            ..SlipCues::default()
        }
    }

    #[test]
    fn starts_off_and_stays_off_without_cues() {
        let mut d = demand();
        for k in 0..1000 {
            assert_eq!(d.update(ms(k * 20), &quiet()), None);
        }
        assert!(!d.is_on());
        assert_eq!(d.on_seconds(ms(20_000)), 0.0);
        assert_eq!(d.wakes(), 0);
    }

    #[test]
    fn each_cue_wakes_it() {
        let cases = [
            (
                SlipCues {
                    grip_under: Some(0.6),
                    ..quiet()
                },
                Cue::GripUnder,
            ),
            (
                SlipCues {
                    grip_ahead: Some(0.45),
                    ..quiet()
                },
                Cue::GripAhead,
            ),
            (
                SlipCues {
                    remembered_wheel_events: 2.5,
                    ..quiet()
                },
                Cue::Remembered,
            ),
            (wheel(0.0, 1e-4, true), Cue::WheelsVsImu),
            (wheel(0.031, 1e-4, false), Cue::WheelsVsImu),
            (
                SlipCues {
                    floor_change_ahead: true,
                    ..quiet()
                },
                Cue::FloorChangeAhead,
            ),
        ];
        for (cues, cue) in cases {
            let mut d = demand();
            assert_eq!(
                d.update(ms(100), &cues),
                Some(Command::Wake(cue)),
                "{cue:?}"
            );
            assert!(d.is_on());
            assert_eq!(d.cue_counts()[cue as usize], 1);
        }
    }

    #[test]
    fn below_threshold_cues_do_not_wake_it() {
        let mut d = demand();
        let near = [
            SlipCues {
                grip_under: Some(0.9),
                grip_ahead: Some(0.75),
                floor_change_ahead: false,
                remembered_wheel_events: 1.9,
                wheel: Some(WheelCue {
                    forward: 0.029,
                    forward_var: 1e-4,
                    gated: false,
                }),
            },
            // A zero variance cannot make a disagreement.
            wheel(5.0, 0.0, false),
        ];
        for (k, c) in near.iter().enumerate() {
            assert_eq!(d.update(ms(k as u64), c), None, "{c:?}");
        }
        assert!(!d.is_on());
    }

    #[test]
    fn released_after_the_quiet_period_and_the_time_on_adds_up() {
        let mut d = demand();
        assert_eq!(
            d.update(ms(1_000), &wheel(0.0, 1.0, true)),
            Some(Command::Wake(Cue::WheelsVsImu))
        );
        // A second cue at 2 s restarts the quiet period.
        assert_eq!(d.update(ms(2_000), &wheel(0.0, 1.0, true)), None);
        assert_eq!(d.update(ms(4_999), &quiet()), None);
        assert!(d.is_on());
        assert!((d.on_seconds(ms(4_000)) - 3.0).abs() < 1e-9);
        assert_eq!(d.update(ms(5_000), &quiet()), Some(Command::Shutdown));
        assert!(!d.is_on());
        assert!((d.on_seconds(ms(9_000)) - 4.0).abs() < 1e-9);
        // A second episode adds to the total and counts a second wake.
        assert_eq!(
            d.update(
                ms(10_000),
                &SlipCues {
                    grip_under: Some(0.5),
                    ..quiet()
                }
            ),
            Some(Command::Wake(Cue::GripUnder))
        );
        assert_eq!(d.update(ms(13_000), &quiet()), Some(Command::Shutdown));
        assert!((d.on_seconds(ms(20_000)) - 7.0).abs() < 1e-9);
        assert_eq!(d.wakes(), 2);
    }

    #[test]
    fn quiet_period_is_the_configured_one() {
        let mut d = FlowDemand::new(FlowDemandConfig {
            quiet_s: 0.5,
            ..FlowDemandConfig::default()
        })
        .unwrap();
        d.update(ms(0), &wheel(0.0, 1.0, true));
        assert_eq!(d.update(ms(499), &quiet()), None);
        assert_eq!(d.update(ms(500), &quiet()), Some(Command::Shutdown));
    }

    #[test]
    fn time_running_back_does_not_release_or_extend() {
        let mut d = demand();
        d.update(ms(5_000), &wheel(0.0, 1.0, true));
        assert_eq!(d.update(ms(1_000), &quiet()), None);
        assert!(d.is_on());
        assert_eq!(d.update(ms(8_000), &quiet()), Some(Command::Shutdown));
        assert!((d.on_seconds(ms(8_000)) - 3.0).abs() < 1e-9);
    }

    #[test]
    fn bad_configs_are_refused() {
        let base = FlowDemandConfig::default();
        for (cfg, err) in [
            (
                FlowDemandConfig {
                    low_grip: 0.0,
                    ..base
                },
                FlowDemandConfigError::LowGrip,
            ),
            (
                FlowDemandConfig {
                    low_grip: f32::NAN,
                    ..base
                },
                FlowDemandConfigError::LowGrip,
            ),
            (
                FlowDemandConfig {
                    quiet_s: -1.0,
                    ..base
                },
                FlowDemandConfigError::Threshold,
            ),
            (
                FlowDemandConfig {
                    lookahead_s: f32::INFINITY,
                    ..base
                },
                FlowDemandConfigError::Threshold,
            ),
            (
                FlowDemandConfig {
                    innovation_sigmas: 0.0,
                    ..base
                },
                FlowDemandConfigError::Threshold,
            ),
        ] {
            assert_eq!(FlowDemand::new(cfg).map(|_| ()), Err(err));
        }
    }
}
