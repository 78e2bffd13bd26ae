//! The filter's own motion since the camera's pose clone, with its
//! covariance: what the fused estimate says the robot did over the frame
//! pair's interval, for checking each sensor's own motion against it
//! (`vslam_core::disagree`). Read only: nothing in the filter changes.
//!
//! The relative pose is the camera update's prediction
//! (`crate::camera::model::predicted`) and its covariance `H P H^T` with
//! the camera update's Jacobian `H` (stochastic cloning: the clone's rows of
//! `P` carry its correlation with the pose, so the interval's covariance is
//! not the sum of the two poses' covariances).

use nalgebra::Matrix3;
use vslam_core::Timestamp;
use vslam_core::disagree::FusedMotion;

use super::{CloneUse, EgoEkf};
use crate::camera::model::{pose_measurement, predicted};
use crate::state::{Quat, Vec3};

/// The filter's motion from its pose clone to a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RelativeMotion {
    /// The clone's time: the previous camera frame's.
    pub t0: Timestamp,
    /// The end of the interval.
    pub t1: Timestamp,
    /// The IMU frame's motion (rotation vector and translation in the IMU
    /// frame at `t0`) and its covariance.
    pub imu: FusedMotion,
    /// The same motion with the translation of the camera's optical centre
    /// (`CameraConfig::t_ic`) instead of the IMU's, the point whose path
    /// the scale pipeline sums the wheel and flow transactions for; the
    /// covariance is the IMU frame's.
    pub camera_point: FusedMotion,
}

impl EgoEkf {
    /// The motion since the pose clone taken at the previous camera frame
    /// to `at`, when the clone holds such a frame (the robot moving, a
    /// camera configured, the filter started); `None` otherwise. `at` may
    /// be ahead of the filter's time by at most the IMU's largest step: the
    /// motion is extrapolated to it with the current velocity and angular
    /// rate (the covariance is the filter's time's); a time behind or
    /// further ahead gives the motion at the filter's time.
    pub fn relative_motion(&self, at: Timestamp) -> Option<RelativeMotion> {
        let CloneUse::Frame(t0) = self.clone else {
            return None;
        };
        let config = self.config.camera?;
        let now = self.imu_clock.last().filter(|_| self.initialised)?;
        let m = pose_measurement(
            &self.x,
            &Quat::identity(),
            &Vec3::zeros(),
            &Matrix3::zeros(),
            &config,
        );
        let covariance = m.h * self.p * m.h.transpose();
        let (q_rel, t_rel) = predicted(&self.x);
        let (t1, gap) = match at.nanos_since(now) {
            Some(ns) if ns <= self.imu_clock.max_step_ns() => {
                (at, at.seconds_since(now).unwrap_or(0.0))
            }
            _ => (now, 0.0),
        };
        let translation = t_rel + self.x.clone_q_wb.inverse() * self.x.v_wb * gap;
        let rotation = q_rel * Quat::from_scaled_axis(self.angular_velocity() * gap);
        let imu = FusedMotion {
            rotation: rotation.scaled_axis(),
            translation,
            covariance,
        };
        let camera_point = FusedMotion {
            translation: translation + rotation * config.t_ic - config.t_ic,
            ..imu
        };
        Some(RelativeMotion {
            t0,
            t1,
            imu,
            camera_point,
        })
    }
}
