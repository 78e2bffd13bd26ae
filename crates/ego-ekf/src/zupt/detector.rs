//! When the robot is still, and so when to make a zero-velocity update.
//!
//! Still means, for `still_samples` IMU samples in a row: the latest wheel
//! sample reports both wheels stopped, the bias-corrected gyro norm is small
//! and the specific-force norm is close to gravity. While still, the clone
//! is frozen and a zero-velocity update is due every `every` IMU samples
//! (made by [`crate::zupt::fusion`]).

use crate::config::ZuptConfig;
use crate::state::Vec3;

/// The still detector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillDetector {
    run: u16,
    since_update: u16,
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
}
