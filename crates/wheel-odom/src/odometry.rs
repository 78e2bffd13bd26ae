//! Differential-drive odometry from cumulative wheel counts, or from wheel
//! angular rates where a robot reports those instead
//! ([`DiffDriveOdometry::update_rates`]: consecutive rates integrated by the
//! trapezoidal rule; the EKF gets the rates measured at the sample's time).
//!
//! Each accepted [`WheelTicks`] sample after the first gives an
//! [`OdometryStep`]: the body displacement over the step ([`OdometryDelta`],
//! exact arc integration, [`crate::arc`]), the wheel angular rates
//! ([`WheelRates`], what the EKF fuses) and the body velocity. The scale
//! pipeline accumulates the wheel transaction `Tw` from the deltas.
//!
//! Time is validated by `vslam_core::SampleClock`; every sample is counted
//! in [`SampleCounts`] as fused (the first one anchors the stream and counts
//! as fused) or rejected with its reason:
//!
//! - [`Reject::OutOfOrder`], [`Reject::Duplicate`]: dropped, state kept;
//! - [`Reject::Gap`]: longer than `max_step_ns`, nothing can be said about
//!   the motion in between; the stream re-anchors on the sample;
//! - [`Reject::OutOfRange`]: a wheel would have moved faster than
//!   `max_wheel_speed` (an impossible jump, a glitched or reset counter) or
//!   the count difference overflows; dropped, the previous anchor kept, so a
//!   single glitch costs one sample and a persistent offset recovers at the
//!   next gap;
//! - [`Reject::NonFinite`]: cannot happen with checked parameters; kept as a
//!   guard.
//!
//! A failed encoder read ([`DiffDriveOdometry::read_failed`]) may leave the
//! counts discontinuous (a counter extension that refused a jump holds its
//! position), so no step spans it: the first sample after it anchors the
//! stream afresh, like the first sample ([`crate::read_breaks`]). A missed
//! read ([`DiffDriveOdometry::read_missed`]: a bus error, a parity or
//! error-flag answer, which the counter extension never saw) leaves them
//! continuous: the step across it is kept when its motion continues the
//! previous step's (no alias), so a wheel's motion across a few missed
//! reads is not lost.

use crate::arc::integrate_arc;
use crate::read_breaks::ReadBreaks;
use core::fmt;
use vslam_core::geometry::Vec3;
use vslam_core::kinematics::rim;
use vslam_core::robot::{RobotDescription, RobotError};
use vslam_core::sensors::{OdometryDelta, RawWheelRates, WheelRates, WheelTicks};
use vslam_core::{Reject, SampleClock, SampleCounts, Timestamp};

/// Why odometry parameters were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamsError {
    /// Ticks per revolution must be positive.
    BadTicksPerRevolution,
    /// Wheel radii must be finite and positive.
    BadWheelRadius,
    /// The wheel base must be finite and positive.
    BadWheelBase,
    /// The maximum wheel speed must be finite and positive.
    BadMaxWheelSpeed,
    /// The maximum step must be positive.
    BadMaxStep,
}

impl fmt::Display for ParamsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ParamsError::BadTicksPerRevolution => "ticks per revolution must be positive",
            ParamsError::BadWheelRadius => "wheel radii must be finite and positive",
            ParamsError::BadWheelBase => "wheel base must be finite and positive",
            ParamsError::BadMaxWheelSpeed => "max wheel speed must be finite and positive",
            ParamsError::BadMaxStep => "max step must be positive",
        })
    }
}

impl core::error::Error for ParamsError {}

fn positive(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

/// The geometry and limits of a differential drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffDriveParams {
    ticks_per_revolution: u32,
    left_radius: f32,
    right_radius: f32,
    wheel_base: f32,
    max_wheel_speed: f32,
    max_step_ns: u64,
}

impl DiffDriveParams {
    /// Valid placeholder settings (1,000 counts per revolution, 35 mm
    /// wheels 230 mm apart, 2 m/s, 200 ms steps) for odometry that is built
    /// in a `const` context and configured before use.
    pub const PLACEHOLDER: Self = DiffDriveParams {
        ticks_per_revolution: 1000,
        left_radius: 0.035,
        right_radius: 0.035,
        wheel_base: 0.23,
        max_wheel_speed: 2.0,
        max_step_ns: 200_000_000,
    };

    /// Checks and builds the parameters: encoder counts per wheel
    /// revolution, wheel radii and wheel base (metres), the fastest a wheel
    /// rim can move (m/s; faster steps are impossible jumps), and the longest
    /// step integrated (ns; longer ones are gaps).
    pub fn new(
        ticks_per_revolution: u32,
        left_radius: f32,
        right_radius: f32,
        wheel_base: f32,
        max_wheel_speed: f32,
        max_step_ns: u64,
    ) -> Result<Self, ParamsError> {
        if ticks_per_revolution == 0 {
            return Err(ParamsError::BadTicksPerRevolution);
        }
        if !(positive(left_radius) && positive(right_radius)) {
            return Err(ParamsError::BadWheelRadius);
        }
        if !positive(wheel_base) {
            return Err(ParamsError::BadWheelBase);
        }
        if !positive(max_wheel_speed) {
            return Err(ParamsError::BadMaxWheelSpeed);
        }
        if max_step_ns == 0 {
            return Err(ParamsError::BadMaxStep);
        }
        Ok(DiffDriveParams {
            ticks_per_revolution,
            left_radius,
            right_radius,
            wheel_base,
            max_wheel_speed,
            max_step_ns,
        })
    }

    /// Longest step [`DiffDriveParams::from_robot`] integrates, ns.
    pub const MAX_STEP_NS: u64 = 500_000_000;

    /// The odometry of a described robot: its encoders, radii, kinematic
    /// track and fastest rim speed; steps up to [`Self::MAX_STEP_NS`].
    pub fn from_robot(robot: &RobotDescription) -> Result<Self, RobotError> {
        robot.validate()?;
        let w = &robot.wheels;
        DiffDriveParams::new(
            w.counts_per_revolution,
            w.radius_left,
            w.radius_right,
            w.kinematic_track(),
            w.max_rim_speed,
            Self::MAX_STEP_NS,
        )
        .map_err(|e| match e {
            ParamsError::BadTicksPerRevolution => RobotError::BadEncoderResolution,
            ParamsError::BadWheelRadius => RobotError::BadWheelRadius,
            ParamsError::BadWheelBase => RobotError::BadTrack,
            ParamsError::BadMaxWheelSpeed | ParamsError::BadMaxStep => RobotError::BadMaxRimSpeed,
        })
    }

    /// Encoder counts per wheel revolution.
    pub const fn ticks_per_revolution(&self) -> u32 {
        self.ticks_per_revolution
    }
    /// Left wheel radius, metres.
    pub const fn left_radius(&self) -> f32 {
        self.left_radius
    }
    /// Right wheel radius, metres.
    pub const fn right_radius(&self) -> f32 {
        self.right_radius
    }
    /// Distance between the wheels' contact points, metres.
    pub const fn wheel_base(&self) -> f32 {
        self.wheel_base
    }
    /// Fastest possible wheel rim speed, m/s.
    pub const fn max_wheel_speed(&self) -> f32 {
        self.max_wheel_speed
    }
    /// Longest integrated step, ns.
    pub const fn max_step_ns(&self) -> u64 {
        self.max_step_ns
    }

    /// Counts to wheel rotation, radians.
    pub fn ticks_to_radians(&self, ticks: i64) -> f32 {
        ticks as f32 * (core::f32::consts::TAU / self.ticks_per_revolution as f32)
    }
}

/// Body velocity over a step: forward speed of the mid-axle point and yaw rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyVelocity {
    /// End of the step.
    pub t: Timestamp,
    /// Forward speed along the arc, m/s.
    pub forward: f32,
    /// Yaw rate, rad/s, counter-clockwise.
    pub yaw_rate: f32,
}

/// Everything one accepted step yields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryStep {
    /// Body displacement over the step, start body frame.
    pub delta: OdometryDelta,
    /// Mean wheel angular rates over the step.
    pub rates: WheelRates,
    /// Mean body velocity over the step.
    pub velocity: BodyVelocity,
}

/// How far, in wheel revolutions, a step spanning missed reads may turn a
/// wheel beyond what its previous rate predicts
/// ([`DiffDriveOdometry::read_missed`]).
pub const MISSED_READ_TOLERANCE_REV: f32 = 0.25;

/// Differential-drive odometry: validates, integrates and counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffDriveOdometry {
    params: DiffDriveParams,
    clock: SampleClock,
    last: Option<WheelTicks>,
    last_rates: Option<RawWheelRates>,
    /// The wheel rates (left, right), rad/s, of the latest step of counts.
    last_step_rates: Option<(f32, f32)>,
    breaks: ReadBreaks,
    /// Missed reads: the counts continue across them.
    misses: ReadBreaks,
    counts: SampleCounts,
}

impl DiffDriveOdometry {
    /// Odometry for `params`, waiting for its first sample.
    pub const fn new(params: DiffDriveParams) -> Self {
        DiffDriveOdometry {
            params,
            clock: SampleClock::new(params.max_step_ns),
            last: None,
            last_rates: None,
            last_step_rates: None,
            breaks: ReadBreaks::new(),
            misses: ReadBreaks::new(),
            counts: SampleCounts::new(),
        }
    }

    /// The parameters.
    pub const fn params(&self) -> &DiffDriveParams {
        &self.params
    }

    /// Samples fused and rejected by reason.
    pub const fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// The anchor the next sample is compared with.
    pub const fn last(&self) -> Option<WheelTicks> {
        self.last
    }

    /// Forgets the anchor (counts kept): the next sample starts again.
    pub fn reset(&mut self) {
        self.clock.reset();
        self.last = None;
        self.last_rates = None;
        self.last_step_rates = None;
        self.breaks.clear();
        self.misses.clear();
    }

    /// An encoder read at `t` failed (the caller counts it): no step of
    /// counts spans `t`; the first sample after it anchors afresh (module
    /// docs). Wheel rates are not cumulative and do not need it.
    pub fn read_failed(&mut self, t: Timestamp) {
        self.breaks.mark(t);
    }

    /// An encoder read at `t` was missed (the caller counts it): the bus
    /// failed or the answer did not pass its integrity check, so the
    /// counter extension did not see it and the counts continue across it.
    /// The step that spans it is kept when its motion continues the
    /// previous step's: each wheel within a quarter revolution
    /// ([`MISSED_READ_TOLERANCE_REV`]) of what its previous rate
    /// predicts over the step. A counter whose range is at least one
    /// revolution (a wheel-shaft angle sensor such as the AS5047P, a wider
    /// timer) that aliased across the missed reads is off by a whole
    /// revolution; a true change of speed that large over a step of a few
    /// missed reads (0.7 m/s in 80 ms on a 35 mm wheel) is not a ground
    /// robot's. Otherwise, or without a previous step, the sample anchors
    /// afresh as after [`DiffDriveOdometry::read_failed`].
    pub fn read_missed(&mut self, t: Timestamp) {
        self.misses.mark(t);
    }

    /// Whether a step of `left_rad`, `right_rad` over `dt` seconds
    /// continues the previous step's rates (see
    /// [`DiffDriveOdometry::read_missed`]).
    fn continues(&self, left_rad: f32, right_rad: f32, dt: f32) -> bool {
        let Some((left, right)) = self.last_step_rates else {
            return false;
        };
        let tolerance = MISSED_READ_TOLERANCE_REV * core::f32::consts::TAU;
        libm::fabsf(left_rad - left * dt) < tolerance
            && libm::fabsf(right_rad - right * dt) < tolerance
    }

    /// Takes one sample: `Ok(None)` for the first (anchor), `Ok(Some(step))`
    /// for an accepted step, `Err(reason)` for a rejected one (module docs).
    pub fn update(&mut self, ticks: WheelTicks) -> Result<Option<OdometryStep>, Reject> {
        let outcome = self.step(ticks);
        self.counts.record(outcome.map(|_| ()));
        outcome
    }

    fn step(&mut self, ticks: WheelTicks) -> Result<Option<OdometryStep>, Reject> {
        let mut clock = self.clock;
        let accepted = clock.accept(ticks.t);
        let (dt, last) = match (accepted, self.last) {
            (Ok(Some(dt)), Some(last)) => (dt, last),
            (Ok(_), _) => {
                // The first sample (or a clock without anchor ticks): anchor.
                self.anchor(clock, ticks);
                return Ok(None);
            }
            (Err(Reject::Gap), _) => {
                self.anchor(clock, ticks);
                return Err(Reject::Gap);
            }
            (Err(reason), _) => return Err(reason),
        };
        // Missed reads are consumed only when the anchor moves: a step
        // refused below is tried again from the same anchor, still across
        // them.
        let missed = self.misses.spans(last.t, ticks.t);
        if self.breaks.take(last.t, ticks.t) {
            // The counts may not continue across a failed read: anchor afresh.
            self.anchor(clock, ticks);
            return Ok(None);
        }
        let dl = ticks
            .left
            .checked_sub(last.left)
            .ok_or(Reject::OutOfRange)?;
        let dr = ticks
            .right
            .checked_sub(last.right)
            .ok_or(Reject::OutOfRange)?;
        let p = &self.params;
        let left_rad = p.ticks_to_radians(dl);
        let right_rad = p.ticks_to_radians(dr);
        let max_travel = p.max_wheel_speed * dt;
        if !(libm::fabsf(rim(p.left_radius, left_rad)) <= max_travel
            && libm::fabsf(rim(p.right_radius, right_rad)) <= max_travel)
        {
            return Err(Reject::OutOfRange);
        }
        if missed && !self.continues(left_rad, right_rad, dt) {
            // Across missed reads, a motion the previous step does not
            // explain may be an alias: anchor afresh.
            self.anchor(clock, ticks);
            return Ok(None);
        }
        let rates = WheelRates::new(ticks.t, left_rad / dt, right_rad / dt)?;
        let step = self.integrate(last.t, dt, left_rad, right_rad, rates)?;
        self.consume_misses(ticks.t);
        self.clock = clock;
        self.last = Some(ticks);
        self.last_step_rates = Some((rates.left(), rates.right()));
        Ok(Some(step))
    }

    /// Anchors the counts on `ticks` (the clock `clock` has accepted it): no
    /// step ends there, no previous step's rates are kept, and the missed
    /// reads before it are behind the anchor.
    fn anchor(&mut self, clock: SampleClock, ticks: WheelTicks) {
        self.consume_misses(ticks.t);
        self.clock = clock;
        self.last = Some(ticks);
        self.last_step_rates = None;
    }

    /// Forgets the missed reads before `t`, where the anchor moves.
    fn consume_misses(&mut self, t: Timestamp) {
        self.misses.consume(t);
    }

    /// Takes one sample of wheel angular rates (the robot reports rates, not
    /// counts): `Ok(None)` for the first (anchor), `Ok(Some(step))` for an
    /// accepted step whose wheel angles are the trapezoid of this sample's
    /// and the previous sample's rates and whose [`OdometryStep::rates`] are
    /// this sample's; `Err(reason)` as [`DiffDriveOdometry::update`] (a rim
    /// speed above the maximum is [`Reject::OutOfRange`], a non-finite rate
    /// [`Reject::NonFinite`]; both keep the anchor). Feed one odometry
    /// either counts or rates.
    pub fn update_rates(&mut self, s: RawWheelRates) -> Result<Option<OdometryStep>, Reject> {
        let outcome = self.step_rates(s);
        self.counts.record(outcome.map(|_| ()));
        outcome
    }

    fn step_rates(&mut self, s: RawWheelRates) -> Result<Option<OdometryStep>, Reject> {
        let rates = WheelRates::new(s.t, s.left, s.right)?;
        let p = &self.params;
        if !(libm::fabsf(rim(p.left_radius, s.left)) <= p.max_wheel_speed
            && libm::fabsf(rim(p.right_radius, s.right)) <= p.max_wheel_speed)
        {
            return Err(Reject::OutOfRange);
        }
        let mut clock = self.clock;
        let accepted = clock.accept(s.t);
        let (dt, last) = match (accepted, self.last_rates) {
            (Ok(Some(dt)), Some(last)) => (dt, last),
            (Ok(_), _) => {
                self.clock = clock;
                self.last_rates = Some(s);
                return Ok(None);
            }
            (Err(Reject::Gap), _) => {
                self.clock = clock;
                self.last_rates = Some(s);
                return Err(Reject::Gap);
            }
            (Err(reason), _) => return Err(reason),
        };
        let left_rad = 0.5 * (last.left + s.left) * dt;
        let right_rad = 0.5 * (last.right + s.right) * dt;
        let step = self.integrate(last.t, dt, left_rad, right_rad, rates)?;
        self.clock = clock;
        self.last_rates = Some(s);
        Ok(Some(step))
    }

    /// The step from `t0` over `dt` seconds in which the wheels turned
    /// `left_rad` and `right_rad`, with the wheel `rates` for the EKF.
    fn integrate(
        &self,
        t0: Timestamp,
        dt: f32,
        left_rad: f32,
        right_rad: f32,
        rates: WheelRates,
    ) -> Result<OdometryStep, Reject> {
        let p = &self.params;
        let left_m = rim(p.left_radius, left_rad);
        let right_m = rim(p.right_radius, right_rad);
        let arc = integrate_arc(left_m, right_m, p.wheel_base);
        let t1 = rates.t();
        let velocity = BodyVelocity {
            t: t1,
            forward: arc.arc_length / dt,
            yaw_rate: arc.dyaw / dt,
        };
        let finite = [arc.x, arc.y, arc.dyaw, velocity.forward, velocity.yaw_rate];
        if !finite.iter().all(|v| v.is_finite()) {
            return Err(Reject::NonFinite);
        }
        let delta = OdometryDelta {
            t0,
            t1,
            translation: Vec3::new(arc.x, arc.y, 0.0),
            dyaw: arc.dyaw,
            path_length: arc.path_length(),
        };
        Ok(OdometryStep {
            delta,
            rates,
            velocity,
        })
    }
}
