//! When to fuse a flow report: time checks (the first report only opens the
//! interval), the datasheet's validity rule ([`Reject::LowQuality`]),
//! saturated counts ([`Reject::Saturated`]), the report's age against the
//! filter's time, the chi-square gate, counters.
//!
//! A report is fused at the filter's (latest IMU) time, as a wheel sample is
//! (see [`crate::wheel::fusion`]): one whose time lies more than the allowed
//! age ahead of it measured a velocity the state has not reached (the IMU
//! lags, went silent or saturated: an IMU gap, which [`crate::gap`] bridges
//! later) and is refused as [`Reject::NotReady`]; one more than that behind
//! it, a velocity the state no longer has ([`Reject::OutOfOrder`]). Fusing
//! such a report against the stale state would pull the velocity, and through
//! the covariance the pose, towards a motion measured in another place and
//! heading. The refused report still closes its interval (the counts are
//! since the previous report, so the next report's `dt` stays one report
//! interval) and, of valid quality and plausible speed, still feeds the
//! witness below: the gap's wheel dead reckoning checks spinning wheels
//! against it ([`crate::gap::odometry`]).
//!
//! A filter whose velocity has run away gates every flow and wheel
//! measurement from then on and never recovers (a lockout). As PX4 EKF2
//! resets its velocity to optical flow after a fusion timeout, a run of
//! [`FlowConfig::velocity_reset_after_gated`] consecutive gated reports of valid
//! quality and plausible speed ([`FlowConfig::reset_max_speed`]) resets the
//! horizontal velocity to the flow's measurement with the measurement's
//! variance (when: [`crate::recovery::flow_reset_due`]; the reset:
//! [`crate::covariance::reset_velocity`]); the reset is counted
//! ([`FlowFusion::resets`]) and reported ([`FlowFused::reset`]).
//!
//! Reports of valid quality and plausible speed, fused or gated, are averaged
//! over a short window ([`FlowWindow`]) as a witness of the robot's velocity
//! ([`FlowFusion::witness`]) for the wheel side's lockout recovery
//! ([`crate::recovery`]).
//!
//! Every report, fused, gated, reset to or refused, leaves its
//! [`FlowStatus`] ([`FlowFusion::status`]).

use nalgebra::Vector2;
use vslam_core::sensors::FlowSample;
use vslam_core::{Reject, SampleClock, SampleCounts, Timestamp};

use crate::aid_status::{AidOutcome, AidStatus, FlowStatus, diagonal, nis};
use crate::config::FlowConfig;
use crate::covariance::reset_velocity;
use crate::flow::model::{flow_measurement, flow_std, flow_velocity};
use crate::recovery::{FlowWindow, FlowWitness, flow_reset_due};
use crate::state::{Covariance, NominalState, Vec3};
use crate::update::gated_update_reporting;

/// What a fused flow report said: the short answer of
/// [`crate::EgoEkf::fuse_flow`]; the report's full record is its
/// [`FlowStatus`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowFused {
    /// Measured robot-origin velocity (x, y), robot frame, m/s.
    pub velocity: Vector2<f32>,
    /// Standard deviation given to each component, m/s.
    pub std: f32,
    /// Normalised innovation squared (2 DOF).
    pub nis: f32,
    /// The velocity was reset to this report instead of updated.
    pub reset: bool,
}

/// The flow sensor's fusion status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowFusion {
    clock: SampleClock,
    max_age_ns: u64,
    counts: SampleCounts,
    gated_run: u16,
    resets: u32,
    window: FlowWindow,
    status: Option<FlowStatus>,
}

impl FlowFusion {
    /// A fresh status accepting report intervals up to `max_dt_ns` and
    /// reports within `max_age_ns` of the filter's time, keeping a witness
    /// averaged over `window_ns` whose standard deviation is at least
    /// `floor_std` m/s.
    pub const fn new(max_dt_ns: u64, max_age_ns: u64, window_ns: u64, floor_std: f32) -> Self {
        FlowFusion {
            clock: SampleClock::new(max_dt_ns),
            max_age_ns,
            counts: SampleCounts::new(),
            gated_run: 0,
            resets: 0,
            window: FlowWindow::new(window_ns, floor_std),
            status: None,
        }
    }

    /// Samples fused, gated and rejected by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Velocity resets after runs of gated reports.
    pub fn resets(&self) -> u32 {
        self.resets
    }

    /// The mean of the recent reports of valid quality and plausible speed
    /// (fused or gated) before `t`, as a witness of the robot's velocity.
    pub fn witness(&self, t: vslam_core::Timestamp) -> Option<FlowWitness> {
        self.window.witness(t)
    }

    /// The status after the latest report (fused, gated, reset to or
    /// refused).
    pub fn status(&self) -> Option<&FlowStatus> {
        self.status.as_ref()
    }

    /// Counts a report taken at `t` that the filter refused before it
    /// reached the maths.
    pub fn refuse(&mut self, t: Timestamp, reason: Reject) -> Reject {
        self.counts.rejected_one(reason);
        self.keep(AidStatus::new(
            t,
            AidOutcome::Rejected(reason),
            self.status.as_ref(),
        ));
        reason
    }

    /// Keeps `status` as the latest, with the current gated run.
    fn keep(&mut self, status: FlowStatus) {
        self.status = Some(status.with_gated_run(self.gated_run));
    }

    /// Checks, gates and fuses one report at the filter time `now`; see the
    /// module docs. The report's standard deviation is multiplied by
    /// `noise_factor` (the adverse-event memory's weight, see
    /// [`crate::SensorWeights`]; one: as modelled).
    #[allow(clippy::too_many_arguments)] // the filter's parts, borrowed apart
    pub fn fuse(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        gyro: &Vec3,
        sample: &FlowSample,
        config: &FlowConfig,
        now: Timestamp,
        noise_factor: f32,
    ) -> Result<FlowFused, Reject> {
        let outcome = match self.check(x, gyro, sample, config, now, noise_factor) {
            Ok(report) => self.gate_and_fuse(x, p, gyro, &report, config),
            Err(r) => {
                let previous = self.status.as_ref();
                let status = AidStatus::new(sample.t, AidOutcome::of::<()>(&Err(r)), previous);
                self.keep(status);
                Err(r)
            }
        };
        self.counts.record(outcome.map(|_| ()));
        outcome
    }

    /// The checks before the gate: time, quality, the velocity and its
    /// noise, the witness, the report's age against the filter's time.
    fn check(
        &mut self,
        x: &NominalState,
        gyro: &Vec3,
        sample: &FlowSample,
        config: &FlowConfig,
        now: Timestamp,
        noise_factor: f32,
    ) -> Result<Checked, Reject> {
        // The counts are since the previous report: the first one only
        // opens the interval.
        let dt = self.clock.accept(sample.t)?.ok_or(Reject::NotReady)?;
        if dt.is_nan() || dt <= 0.0 {
            return Err(Reject::Degenerate);
        }
        sample.check_motion()?;
        let z = flow_velocity(sample, config, &x.q_rb, gyro, dt);
        if !z.iter().all(|v| v.is_finite()) {
            return Err(Reject::NonFinite);
        }
        let std = flow_std(sample, config, z.norm(), dt) * noise_factor;
        let plausible = z.norm() <= config.reset_max_speed;
        if plausible {
            self.window.push(sample.t, z, std);
        }
        // After the clock and the witness: a refused report still closes
        // its interval and still witnesses the speed.
        match sample.t.nanos_since(now) {
            Some(ahead) if ahead > self.max_age_ns => return Err(Reject::NotReady),
            None if now
                .nanos_since(sample.t)
                .is_some_and(|d| d > self.max_age_ns) =>
            {
                return Err(Reject::OutOfOrder);
            }
            _ => {}
        }
        Ok(Checked {
            t: sample.t,
            z,
            std,
            plausible,
        })
    }

    /// Gates and fuses a checked report, or resets the velocity to it at
    /// the end of a run of gated reports; keeps its status.
    fn gate_and_fuse(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        gyro: &Vec3,
        report: &Checked,
        config: &FlowConfig,
    ) -> Result<FlowFused, Reject> {
        let Checked { t, z, std, .. } = *report;
        let m = flow_measurement(x, gyro, &z, std);
        let (result, s) = gated_update_reporting(x, p, &m, Some(config.gate));
        let (outcome, nis) = match result {
            Ok(update) => {
                self.gated_run = 0;
                (
                    Ok(FlowFused {
                        velocity: z,
                        std,
                        nis: update.nis,
                        reset: false,
                    }),
                    update.nis,
                )
            }
            Err(Reject::Gated) => {
                self.gated_run = self.gated_run.saturating_add(1);
                let nis = s.as_ref().map_or(f32::NAN, |s| nis(s, &m.residual));
                if flow_reset_due(config, self.gated_run, report.plausible) {
                    self.gated_run = 0;
                    self.resets = self.resets.saturating_add(1);
                    reset_velocity(x, p, gyro, &z, std);
                    (
                        Ok(FlowFused {
                            velocity: z,
                            std,
                            nis: f32::NAN,
                            reset: true,
                        }),
                        nis,
                    )
                } else {
                    (Err(Reject::Gated), nis)
                }
            }
            Err(r) => (Err(r), f32::NAN),
        };
        let aid_outcome = match outcome {
            Ok(FlowFused { reset: true, .. }) => AidOutcome::Reset,
            other => AidOutcome::of(&other),
        };
        let var = std * std;
        let status = AidStatus::new(t, aid_outcome, self.status.as_ref())
            .with_observation([z.x, z.y], [var, var])
            .with_innovation([m.residual.x, m.residual.y], diagonal(s.as_ref()))
            .with_test(nis, Some(config.gate));
        self.keep(status);
        outcome
    }
}

/// A report that passed the checks before the gate.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Checked {
    t: Timestamp,
    /// Robot-origin horizontal velocity, robot frame, m/s.
    z: Vector2<f32>,
    /// Standard deviation of each component, m/s.
    std: f32,
    /// Whether the speed is plausible (a reset may use it).
    plausible: bool,
}
