//! When the robot is still, and so when to make a zero-velocity update.
//!
//! Still means, for `still_samples` IMU samples in a row: the latest wheel
//! sample reports both wheels stopped, the bias-corrected gyro norm is small
//! and the specific-force norm is close to gravity. While still, the clone
//! is frozen and a zero-velocity update is due every `every` IMU samples.
//! Each update ([`StillDetector::fuse`], the measurement from
//! [`crate::zupt::model`]) is counted and leaves its [`ZuptStatus`].

use vslam_core::{Reject, SampleCounts, Timestamp};

use crate::aid_status::{AidOutcome, AidStatus, ZuptStatus, innovation_variances};
use crate::config::ZuptConfig;
use crate::state::{Covariance, NominalState, Vec3};
use crate::update::gated_update_with;
use crate::zupt::model::zupt_measurement;

/// The still detector and the zero-velocity update's counters and status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillDetector {
    run: u16,
    since_update: u16,
    counts: SampleCounts,
    status: Option<ZuptStatus>,
}

impl Default for StillDetector {
    fn default() -> Self {
        Self::new()
    }
}

impl StillDetector {
    /// Not still, nothing counted.
    pub const fn new() -> Self {
        StillDetector {
            run: 0,
            since_update: 0,
            counts: SampleCounts::new(),
            status: None,
        }
    }

    /// Feeds one IMU step; returns whether the robot is still now.
    pub fn step(
        &mut self,
        config: &ZuptConfig,
        gyro: &Vec3,
        accel: &Vec3,
        gravity: f32,
        wheels_stopped: bool,
    ) -> bool {
        let quiet = wheels_stopped
            && gyro.norm() < config.max_gyro
            && libm::fabsf(accel.norm() - gravity) < config.max_accel_deviation;
        if quiet {
            self.run = self.run.saturating_add(1);
        } else {
            self.run = 0;
            self.since_update = 0;
        }
        self.is_still(config)
    }

    /// Forgets the run of still samples (after a break in the IMU stream
    /// nothing says the robot stayed still); the counters are kept.
    pub fn interrupt(&mut self) {
        self.run = 0;
        self.since_update = 0;
    }

    /// Whether the robot is still.
    pub fn is_still(&self, config: &ZuptConfig) -> bool {
        self.run >= config.still_samples
    }

    /// Whether a zero-velocity update is due at this still step.
    pub fn update_due(&mut self, config: &ZuptConfig) -> bool {
        if !self.is_still(config) {
            return false;
        }
        self.since_update = self.since_update.saturating_add(1);
        if self.since_update >= config.every {
            self.since_update = 0;
            true
        } else {
            false
        }
    }

    /// Zero-velocity updates fused and rejected.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// The status after the latest zero-velocity update.
    pub fn status(&self) -> Option<&ZuptStatus> {
        self.status.as_ref()
    }

    /// Makes one zero-velocity update (ungated) at time `t`, counts it and
    /// keeps its status.
    pub fn fuse(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        config: &ZuptConfig,
        t: Timestamp,
    ) -> Result<(), Reject> {
        let m = zupt_measurement(x, config);
        let pht = m.p_ht(p);
        let result = gated_update_with(x, p, &m, &pht, None);
        let outcome = result.map(|_| ());
        self.counts.record(outcome);
        let status = AidStatus::new(t, AidOutcome::of(&outcome), self.status.as_ref())
            .with_observation(
                [0.0; 9],
                core::array::from_fn(|i| m.noise.get((i, i)).copied().unwrap_or(f32::NAN)),
            )
            .with_innovation(m.residual.data.0[0], innovation_variances(&m, &pht))
            .with_test(result.map_or(f32::NAN, |r| r.nis), None);
        self.status = Some(status);
        outcome
    }
}
