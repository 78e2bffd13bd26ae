//! The adverse-event memory's weights in [`EgoEkf`]: where the robot is, a
//! sensor that repeatedly misled the estimate before gets a weight below
//! one (seed 000's weighting-factor component; the memory lives in
//! `vslam_core::adverse`, the estimator looks the weights up and hands
//! them here). Each weight is applied where its sensor is used, as noise,
//! never as a refusal:
//!
//! - IMU: the accelerometer's and the gyro's noise densities in the
//!   propagation's process noise are divided by `sqrt(weight)` (their
//!   variances by the weight), so the aids correct the propagated state
//!   more; the bias random walks are the sensor's drift, not its
//!   measurement, and keep their values;
//! - wheels: the forward and differential noise's standard deviation is
//!   multiplied by `1/sqrt(weight)` (on top of the scale pipeline's
//!   distrust, [`EgoEkf::distrust_wheels_until`]);
//! - flow sensor: the velocity's standard deviation is multiplied by
//!   `1/sqrt(weight)`.
//!
//! The camera's weight goes with each frame pair
//! ([`EgoEkf::fuse_camera_weighted`]). With every weight one (the default)
//! the filter's arithmetic is that of a filter without weights: the factors
//! are skipped, not multiplied by one.

use vslam_core::Reject;

use super::EgoEkf;
use crate::config::ImuConfig;

/// The adverse-event memory's weights of the IMU, the wheels and the flow
/// sensor, each in `(0, 1]` (one: nothing repeated here).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorWeights {
    /// The IMU's weight (divides the variance of its noise densities).
    pub imu: f32,
    /// The wheels' weight (divides the variance of their noise).
    pub wheel: f32,
    /// The flow sensor's weight (divides the variance of its velocity).
    pub flow: f32,
}

impl SensorWeights {
    /// Every sensor at full weight.
    pub const FULL: SensorWeights = SensorWeights {
        imu: 1.0,
        wheel: 1.0,
        flow: 1.0,
    };

    /// Whether every weight lies in `(0, 1]` (NaN does not).
    pub fn is_valid(&self) -> bool {
        [self.imu, self.wheel, self.flow]
            .iter()
            .all(|w| *w > 0.0 && *w <= 1.0)
    }
}

impl Default for SensorWeights {
    fn default() -> Self {
        SensorWeights::FULL
    }
}

/// The standard-deviation factor of a weight: `1/sqrt(w)`, exactly one at
/// full weight.
pub(crate) fn std_factor(weight: f32) -> f32 {
    if weight >= 1.0 {
        1.0
    } else {
        1.0 / libm::sqrtf(weight)
    }
}

impl EgoEkf {
    /// Sets the adverse-event memory's weights where the robot is now (see
    /// the module docs); they hold until the next call. Errors:
    /// [`Reject::OutOfRange`] for a weight outside `(0, 1]` or NaN (the
    /// weights are unchanged).
    pub fn set_sensor_weights(&mut self, weights: SensorWeights) -> Result<(), Reject> {
        if !weights.is_valid() {
            return Err(Reject::OutOfRange);
        }
        self.weights = weights;
        Ok(())
    }

    /// The weights in use ([`SensorWeights::FULL`] until set).
    pub fn sensor_weights(&self) -> SensorWeights {
        self.weights
    }

    /// The IMU configuration the propagation's process noise is built
    /// from when the IMU's weight is below one: the configured one, its
    /// noise densities scaled by the weight (`None` at full weight: the
    /// configured one as it is).
    pub(super) fn weighted_imu(&self) -> Option<ImuConfig> {
        if self.weights.imu >= 1.0 {
            return None;
        }
        let mut imu = self.config.imu;
        let f = std_factor(self.weights.imu);
        imu.noise.accel_density *= f;
        imu.noise.gyro_density *= f;
        Some(imu)
    }
}
