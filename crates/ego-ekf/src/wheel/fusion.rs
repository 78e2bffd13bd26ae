//! When to fuse a wheel sample: time checks, finite rates, the grip's gate on
//! the forward rows, and the counters.
//!
//! The forward and differential rows are each tested with the grip's 1-DOF
//! chi-square gate (`GripParams::forward_gate`); when either fails the wheels
//! slipped and only the lateral and vertical non-holonomic rows are fused,
//! and the sample is counted as [`Reject::Gated`]. The forward innovation and
//! its variance are returned either way, for the surface model's grip learning.
//!
//! A sample is fused at the filter's time: one whose time stamp lies more than
//! the configured age before the filter's latest IMU time measured a velocity
//! the state no longer has ([`Reject::OutOfOrder`]); one more than that ahead
//! of it, a velocity the state has not reached yet (the IMU lags or went
//! silent: [`Reject::NotReady`]). Both are counted and change nothing.
//!
//! Consecutive gated samples form a [`GatedRun`]; the filter re-examines its
//! velocity when the run is due (see [`crate::recovery`]).

use vslam_core::kinematics::{mid_axle, rim};
use vslam_core::sensors::WheelRates;
use vslam_core::{Reject, SampleClock, SampleCounts, Timestamp};

use crate::config::RecoveryConfig;
use crate::grip::GripParams;
use crate::recovery::{GatedRun, Verdict};
use crate::state::{Covariance, NominalState, Vec3};
use crate::wheel::model::wheel_rows;
use crate::wheel::update::{WheelUpdate, update};

/// The forward wheel-velocity innovation of one wheel sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelInnovation {
    /// Forward innovation (measured minus predicted forward speed), m/s.
    pub forward: f32,
    /// Its predicted variance `H P H^T + R`, (m/s)^2.
    pub forward_var: f32,
    /// Whether the forward rows failed the grip's gate (wheels slipped).
    pub gated: bool,
    /// The wheels' measured forward speed `(r_l w_l + r_r w_r) / 2`, m/s.
    pub speed: f32,
    /// What the filter decided when this sample completed a run of gated
    /// samples (see [`crate::recovery`]); `None` otherwise.
    pub recovery: Option<Verdict>,
}

/// The wheel sensor's fusion status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelFusion {
    clock: SampleClock,
    counts: SampleCounts,
    last: Option<WheelInnovation>,
    stopped: bool,
    stop_rate: f32,
    max_age_ns: u64,
    run: GatedRun,
    last_fused: Option<Timestamp>,
    resumed: Option<Timestamp>,
}

impl WheelFusion {
    /// A fresh status accepting sample intervals up to `max_dt_ns` and
    /// samples within `max_age_ns` of the filter's time; rates below
    /// `stop_rate` (rad/s) on both wheels mean stopped.
    pub fn new(max_dt_ns: u64, max_age_ns: u64, stop_rate: f32) -> Self {
        WheelFusion {
            clock: SampleClock::new(max_dt_ns),
            counts: SampleCounts::new(),
            last: None,
            stopped: false,
            stop_rate,
            max_age_ns,
            run: GatedRun::default(),
            last_fused: None,
            resumed: None,
        }
    }

    /// The current run of gated samples.
    pub fn gated_run(&self) -> &GatedRun {
        &self.run
    }

    /// Ends the run of gated samples (after a velocity reset).
    pub fn end_run(&mut self) {
        self.run.clear();
    }

    /// Samples fused, gated and rejected by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// The latest innovation.
    pub fn last(&self) -> Option<WheelInnovation> {
        self.last
    }

    /// Whether the latest accepted sample said both wheels stand still.
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// Counts a sample the filter refused before it reached the maths.
    pub fn refuse(&mut self, reason: Reject) -> Reject {
        self.counts.rejected_one(reason);
        reason
    }

    /// Checks, gates and fuses one sample at the filter time `now`; see the
    /// module documentation. A gated sample extends the gated run (with the
    /// `recovery` configuration's steadiness and onset rules).
    #[allow(clippy::too_many_arguments)]
    pub fn fuse(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        gyro: &Vec3,
        rates: &WheelRates,
        grip: &GripParams,
        now: Timestamp,
        recovery: &RecoveryConfig,
    ) -> Result<WheelInnovation, Reject> {
        let outcome = self.fuse_inner(x, p, gyro, rates, grip, now);
        match outcome {
            Ok(inn) if inn.gated => {
                // Silence: nothing fused for a while, or fusing resumed only
                // just now after such a while (the first samples back may
                // pass the gate and leave the rest of the offset).
                let within = |since: Option<Timestamp>| {
                    since.is_some_and(|s| {
                        rates
                            .t()
                            .nanos_since(s)
                            .is_some_and(|d| d <= recovery.silence_ns)
                    })
                };
                let after_silence = !within(self.last_fused) || within(self.resumed);
                self.run.push(recovery, inn.forward, after_silence);
            }
            Ok(_) => {
                let silent_before = !self.last_fused.is_some_and(|f| {
                    rates
                        .t()
                        .nanos_since(f)
                        .is_some_and(|d| d <= recovery.silence_ns)
                });
                if silent_before {
                    self.resumed = Some(rates.t());
                }
                self.run.clear();
                self.last_fused = Some(rates.t());
            }
            Err(_) => {}
        }
        match outcome {
            Ok(inn) if inn.gated => self.counts.rejected_one(Reject::Gated),
            Ok(_) => self.counts.fused_one(),
            Err(r) => self.counts.rejected_one(r),
        }
        outcome
    }

    fn fuse_inner(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        gyro: &Vec3,
        rates: &WheelRates,
        grip: &GripParams,
        now: Timestamp,
    ) -> Result<WheelInnovation, Reject> {
        match rates.t().nanos_since(now) {
            Some(ahead) if ahead > self.max_age_ns => return Err(Reject::NotReady),
            None if now
                .nanos_since(rates.t())
                .is_some_and(|d| d > self.max_age_ns) =>
            {
                return Err(Reject::OutOfOrder);
            }
            _ => {}
        }
        // Gaps are not fatal for rates (they are an average over the
        // interval), but the clock re-anchors and the sample is counted.
        self.clock.accept(rates.t())?;
        self.stopped = libm::fabsf(rates.left()) < self.stop_rate
            && libm::fabsf(rates.right()) < self.stop_rate;
        let rows = wheel_rows(x, gyro, rates, grip);
        let speed = mid_axle(
            rim(x.radius_left, rates.left()),
            rim(x.radius_right, rates.right()),
        );
        let WheelUpdate {
            forward,
            forward_var: var_fwd,
            gated,
        } = update(x, p, &rows, grip.forward_gate())?;
        let inn = WheelInnovation {
            forward,
            forward_var: var_fwd,
            gated,
            speed,
            recovery: None,
        };
        self.last = Some(inn);
        Ok(inn)
    }
}
