//! When to fuse a wheel sample: time checks, finite rates, the grip's gate on
//! the forward rows, and the counters.
//!
//! The forward and differential rows are each tested with the grip's 1-DOF
//! chi-square gate (`GripParams::forward_gate`); when either fails the wheels
//! slipped and the sample is counted as [`Reject::Gated`]. A distrust factor
//! inflates the noise the rows are fused with and, away from an impact, the
//! noise they are gated on; around an impact ([`crate::impact`]) they are
//! gated as the uninflated rows would be
//! ([`crate::wheel::update::update_gated_on`]). The lateral and
//! vertical non-holonomic rows are fused either way, and the forward row too
//! when it passed and only the differential row failed (the body did not
//! turn as the wheels did: [`crate::wheel::update`]). The forward innovation
//! and its variance are returned either way, for the surface model's grip
//! learning.
//!
//! A sample is fused at the filter's time: one whose time stamp lies more than
//! the configured age before the filter's latest IMU time measured a velocity
//! the state no longer has ([`Reject::OutOfOrder`]); one more than that ahead
//! of it, a velocity the state has not reached yet (the IMU lags or went
//! silent: [`Reject::NotReady`]). Both are counted and change nothing.
//!
//! Consecutive samples whose forward row was not fused form a
//! [`crate::recovery::GatedRun`], watched
//! by [`WheelWatch`]; the filter re-examines its velocity when the run is
//! due (see [`crate::recovery`]).
//!
//! Every sample, fused, gated or refused, leaves its [`WheelStatus`]
//! ([`WheelFusion::status`]): forward and differential rows.

use vslam_core::kinematics::{differential, mid_axle, rim};
use vslam_core::sensors::WheelRates;
use vslam_core::{Reject, SampleClock, SampleCounts, Timestamp};

use crate::aid_status::{AidOutcome, AidStatus, WheelStatus};
use crate::config::RecoveryConfig;
use crate::grip::GripParams;
use crate::recovery::{Verdict, WheelWatch};
use crate::state::{Covariance, NominalState, Vec3};
use crate::wheel::model::{DIFFERENTIAL, wheel_rows};
use crate::wheel::skid::{SkidConfig, TrackEstimate, TrackScale};
use crate::wheel::update::{WheelUpdate, update_gated_on};

/// The forward wheel-velocity innovation of one wheel sample: the short
/// answer of [`crate::EgoEkf::fuse_wheel`]; the sample's full record is its
/// [`WheelStatus`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelInnovation {
    /// Forward innovation (measured minus predicted forward speed), m/s.
    pub forward: f32,
    /// Its predicted variance `H P H^T + R`, (m/s)^2.
    pub forward_var: f32,
    /// Whether the forward or the differential row failed the grip's gate
    /// (the wheels slipped).
    pub gated: bool,
    /// Whether the forward row was fused (it passed the gate, and so did
    /// the differential row or the differential row alone failed).
    pub forward_fused: bool,
    /// The wheels' rolling forward speed `(r_l w_l + r_r w_r) / 2`, m/s
    /// (before the floor's expected slip; the sample's [`WheelStatus`]
    /// holds the speed after it).
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
    status: Option<WheelStatus>,
    stopped: bool,
    stop_rate: f32,
    max_age_ns: u64,
    watch: WheelWatch,
    gyro_scale: bool,
    skid: Option<TrackScale>,
}

impl WheelFusion {
    /// A fresh status accepting sample intervals up to `max_dt_ns` and
    /// samples within `max_age_ns` of the filter's time; rates below
    /// `stop_rate` (rad/s) on both wheels mean stopped.
    pub const fn new(max_dt_ns: u64, max_age_ns: u64, stop_rate: f32) -> Self {
        WheelFusion {
            clock: SampleClock::new(max_dt_ns),
            counts: SampleCounts::new(),
            status: None,
            stopped: false,
            stop_rate,
            max_age_ns,
            watch: WheelWatch::new(),
            gyro_scale: false,
            skid: None,
        }
    }

    /// A skid steer's effective track learned online and applied to the
    /// wheels' speed difference ([`crate::wheel::skid`]); `None` (the
    /// default, a differential drive) fuses the wheels as they are.
    pub const fn with_skid(mut self, skid: Option<SkidConfig>) -> Self {
        self.skid = match skid {
            Some(c) => Some(TrackScale::new(c)),
            None => None,
        };
        self
    }

    /// Gives a skid steer's learner one IMU step: the raw gyroscope rate
    /// over `dt` seconds ([`TrackScale::observe_imu`]); nothing for a
    /// differential drive.
    pub fn observe_imu(&mut self, x: &NominalState, gyro: &Vec3, dt: f32) {
        if let Some(s) = self.skid.as_mut() {
            s.observe_imu(x, gyro, dt);
        }
    }

    /// The skid steer's learned effective track at the state `x`; `None`
    /// for a differential drive.
    pub fn track_estimate(&self, x: &NominalState) -> Option<TrackEstimate> {
        let b_k = (x.p_br - x.p_bl).norm();
        self.skid.as_ref().map(|s| s.estimate(b_k))
    }

    /// Whether the rows carry their Jacobian on the gyro's scale factor
    /// ([`crate::config::ImuConfig::estimate_gyro_scale`]; off by default).
    pub const fn with_gyro_scale(mut self, on: bool) -> Self {
        self.gyro_scale = on;
        self
    }

    /// The current run of gated samples and the time of the last fused one
    /// (see [`crate::recovery`]).
    pub fn watch(&self) -> &WheelWatch {
        &self.watch
    }

    /// Ends the run of gated samples (after a velocity reset).
    pub fn end_run(&mut self) {
        self.watch.end_run();
    }

    /// Samples fused, gated and rejected by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// The status after the latest sample (fused, gated or refused).
    pub fn status(&self) -> Option<&WheelStatus> {
        self.status.as_ref()
    }

    /// Whether the latest accepted sample said both wheels stand still.
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// Counts a sample taken at `t` that the filter refused before it
    /// reached the maths.
    pub fn refuse(&mut self, t: Timestamp, reason: Reject) -> Reject {
        self.counts.rejected_one(reason);
        self.status = Some(
            AidStatus::new(t, AidOutcome::Rejected(reason), self.status.as_ref())
                .with_gated_run(self.watch.run().len()),
        );
        reason
    }

    /// Checks, gates and fuses one sample at the filter time `now`; see the
    /// module documentation. A gated sample extends the gated run (with the
    /// `recovery` configuration's steadiness and onset rules). `refuted`:
    /// the flow stands against the wheels' forward speed, which is gated
    /// whatever its test ([`crate::recovery::Refutation`]). `noise_factor`
    /// (at least 1) multiplies the forward and differential noise's standard
    /// deviation: the scale pipeline's distrust of the wheels
    /// ([`crate::wheel::distrust`]); 1 leaves the grip's noise. `strict`:
    /// the rows are gated on the grip's noise, not the inflated one (an
    /// impact, [`crate::impact`]).
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
        refuted: bool,
        noise_factor: f32,
        strict: bool,
    ) -> Result<WheelInnovation, Reject> {
        // A factor the grip refuses (not finite, not positive) leaves the grip's noise.
        let inflated = GripParams::new(
            grip.grip(),
            grip.forward_std() * noise_factor,
            grip.lateral_std(),
            grip.forward_gate(),
            grip.jolt_threshold(),
        )
        .map(|g| {
            g.with_slip(grip.slip())
                .with_learn_radius(grip.learn_radius())
        })
        .unwrap_or(*grip);
        // Strict: the gate counts `1 / ratio^2` of the inflated noise.
        let ratio = inflated.forward_std() / grip.forward_std();
        let gate_noise = if strict && ratio.is_finite() && ratio > 1.0 {
            1.0 / (ratio * ratio)
        } else {
            1.0
        };
        let grip = &inflated;
        let checked = self.fuse_inner(x, p, gyro, rates, grip, now, refuted, gate_noise);
        let outcome = checked.map(|(inn, _)| inn);
        match outcome {
            Ok(inn) if !inn.forward_fused => self.watch.gated(recovery, rates.t(), inn.forward),
            Ok(_) => self.watch.fused(recovery, rates.t()),
            Err(_) => {}
        }
        match outcome {
            Ok(inn) if inn.gated => self.counts.rejected_one(Reject::Gated),
            Ok(_) => self.counts.fused_one(),
            Err(r) => self.counts.rejected_one(r),
        }
        let previous = self.status.as_ref();
        let status = match checked {
            Ok((inn, rows)) => {
                let outcome = if inn.gated {
                    AidOutcome::Gated
                } else {
                    AidOutcome::Fused
                };
                AidStatus::new(rates.t(), outcome, previous)
                    .with_observation(rows.observation, rows.observation_var)
                    .with_innovation(
                        [inn.forward, rows.update.differential],
                        [inn.forward_var, rows.update.differential_var],
                    )
                    .with_test(rows.nis(), Some(grip.forward_gate()))
            }
            Err(r) => AidStatus::new(rates.t(), AidOutcome::of::<()>(&Err(r)), previous),
        };
        self.status = Some(status.with_gated_run(self.watch.run().len()));
        outcome
    }

    #[allow(clippy::too_many_arguments)]
    fn fuse_inner(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        gyro: &Vec3,
        rates: &WheelRates,
        grip: &GripParams,
        now: Timestamp,
        refuted: bool,
        gate_noise: f32,
    ) -> Result<(WheelInnovation, GatedRows), Reject> {
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
        // A skid steer: learn the floor's effective track from this sample,
        // then fuse the wheels with their difference scaled to it.
        let scaled;
        let rates = match self.skid.as_mut() {
            Some(skid) => {
                skid.observe(x, rates, now, 1.0 - grip.slip());
                scaled = skid.apply(x, rates);
                &scaled
            }
            None => rates,
        };
        let mut rows = wheel_rows(x, gyro, rates, grip);
        // The scaled difference's noise scales with it.
        if let (Some(skid), Some(n)) = (self.skid.as_ref(), rows.noise.get_mut(DIFFERENTIAL)) {
            *n *= skid.gain() * skid.gain();
        }
        if !self.gyro_scale {
            rows.scale = [0.0; 4];
        }
        let speed = mid_axle(
            rim(x.radius_left, rates.left()),
            rim(x.radius_right, rates.right()),
        );
        let differential = differential(
            rim(x.radius_left, rates.left()),
            rim(x.radius_right, rates.right()),
        );
        let [noise_fwd, noise_diff, ..] = rows.noise;
        // Refuted by the flow ([`crate::recovery::Refutation`]): the
        // forward and differential rows are gated whatever their test says.
        let gate = if refuted { 0.0 } else { grip.forward_gate() };
        let u = update_gated_on(x, p, &rows, gate, gate_noise)?;
        let inn = WheelInnovation {
            forward: u.forward,
            forward_var: u.forward_var,
            gated: u.gated,
            forward_fused: u.forward_fused,
            speed,
            recovery: None,
        };
        // What the wheels say the robot does on this floor: their speeds
        // times `1 - slip` (the expected slip, see `wheel::model`).
        let keep = 1.0 - grip.slip();
        let gated_rows = GatedRows {
            observation: [keep * speed, keep * differential],
            observation_var: [noise_fwd, noise_diff],
            update: u,
        };
        Ok((inn, gated_rows))
    }
}

/// The gated rows' side of one sample, for its [`WheelStatus`].
#[derive(Clone, Copy, Debug, PartialEq)]
struct GatedRows {
    observation: [f32; 2],
    observation_var: [f32; 2],
    update: WheelUpdate,
}

impl GatedRows {
    /// The larger of the forward and differential 1-DOF statistics (each
    /// is gated on its own).
    fn nis(&self) -> f32 {
        let u = &self.update;
        let forward = u.forward * u.forward / u.forward_var;
        let differential = u.differential * u.differential / u.differential_var;
        forward.max(differential)
    }
}
