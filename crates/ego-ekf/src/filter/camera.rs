//! The camera's frames in [`EgoEkf`]: bringing the filter to a frame's
//! time between IMU samples, the camera update against the pose clone and
//! the clone's copy for the next pair (see [`crate::camera`] and
//! [`super::CloneUse`]).

use vslam_core::scale::camera::CameraMotion;
use vslam_core::{Reject, SampleCounts, Timestamp};

use super::{CloneUse, EgoEkf, clone_pose};
use crate::aid_status::CameraStatus;
use crate::camera::CameraSkips;
use crate::camera::model::imu_motion;
use crate::covariance;
use crate::propagate::{process_noise, propagate_nominal};
use crate::vibration::SampleNoise;

impl EgoEkf {
    /// Fuses a camera frame pair's motion (see [`crate::camera`]): the
    /// pose of the camera at `motion.t1()` in the camera frame at
    /// `motion.t0()`, and the pair's metric scale with its variance
    /// (metres per unit of `t/d`), if the scale pipeline gave one.
    ///
    /// The filter is first brought to the frame's time: a frame after the
    /// latest IMU sample (by at most the IMU's largest step) is propagated
    /// to with that sample's rates held (the IMU counts are not touched:
    /// it is no sample; the next IMU sample continues from the frame's
    /// time); a frame at most [`crate::CameraConfig::max_lag_ns`] behind is
    /// measured at the filter's time. The pair is measured if the clone
    /// holds the pose of its first frame, and the pose is then cloned for
    /// the next pair, whatever the update did.
    ///
    /// Errors: [`Reject::NotReady`] without a camera configuration, before
    /// the filter starts, for a frame too far ahead of the IMU, while the
    /// robot is still, or without a clone at `motion.t0()` (the reason is
    /// counted in [`EgoEkf::camera_skips`]); [`Reject::OutOfOrder`] for a
    /// frame too far behind; [`Reject::Gated`], [`Reject::Degenerate`],
    /// [`Reject::NonFinite`] from the update. Every frame is counted in
    /// [`EgoEkf::camera_counts`].
    pub fn fuse_camera(
        &mut self,
        motion: &CameraMotion,
        scale: Option<(f32, f32)>,
    ) -> Result<(), Reject> {
        self.fuse_camera_weighted(motion, scale, 1.0)
    }

    /// As [`EgoEkf::fuse_camera`], with the camera's weight from the
    /// adverse-event memory where the robot is (`0 < weight <= 1`): the
    /// measurement's noise covariance is divided by it (standard deviations
    /// by its square root), so a camera that repeatedly misled the estimate
    /// here corrects it less. A weight outside `(0, 1]` or NaN is taken as 1.
    pub fn fuse_camera_weighted(
        &mut self,
        motion: &CameraMotion,
        scale: Option<(f32, f32)>,
        weight: f32,
    ) -> Result<(), Reject> {
        let noise_factor = if weight > 0.0 && weight <= 1.0 {
            1.0 / weight
        } else {
            1.0
        };
        let t = motion.t1();
        let Some(config) = self.config.camera else {
            return Err(self.camera.refuse(t, Reject::NotReady));
        };
        let (true, Some(now)) = (self.initialised, self.imu_clock.last()) else {
            return Err(self.camera.refuse(t, Reject::NotReady));
        };
        if let Some(ahead) = t.nanos_since(now).filter(|&n| n > 0) {
            if ahead > self.imu_clock.max_step_ns() || !self.propagate_to(t) {
                return Err(self.camera.refuse(t, Reject::NotReady));
            }
        } else if now.nanos_since(t).is_none_or(|lag| lag > config.max_lag_ns) {
            return Err(self.camera.refuse(t, Reject::OutOfOrder));
        }
        if self.clone == CloneUse::Still {
            return Err(self.camera.skip_still(t));
        }
        let out = if self.clone == CloneUse::Frame(motion.t0()) {
            let m = imu_motion(&config, motion.r(), motion.t_over_d(), scale);
            let before = self.before_update();
            let out = self
                .camera
                .fuse(&mut self.x, &mut self.p, &m, &config, noise_factor, t);
            self.reanchor(before.as_ref());
            out
        } else {
            Err(self.camera.skip_no_clone(t))
        };
        clone_pose(&mut self.x, &mut self.p);
        self.clone = CloneUse::Frame(t);
        debug_assert!(covariance::looks_valid(&self.p));
        out
    }

    /// Propagates from the latest IMU sample's time to `t` (later, by at
    /// most one IMU step) with that sample's rates, bias-corrected: a
    /// zero-order hold over the partial step. The IMU clock moves to `t`;
    /// the still detector, the floor's schedule and the IMU counts do not
    /// (no sample was taken). `false` (nothing changed) before any IMU
    /// sample was accepted.
    pub(super) fn propagate_to(&mut self, t: Timestamp) -> bool {
        let Some((gyro, accel)) = self.last_imu else {
            return false;
        };
        let Ok(Some(dt)) = self.imu_clock.accept(t) else {
            return false;
        };
        let gyro = self.x.corrected_gyro(&gyro);
        let accel = accel - self.x.accel_bias;
        let r_wb = self.x.q_wb.to_rotation_matrix().into_inner();
        let f = self.transition(&r_wb, &accel, &gyro, dt);
        let weighted = self.weighted_imu();
        let imu = weighted.as_ref().unwrap_or(&self.config.imu);
        let mut q = process_noise(imu, &self.config.robot, dt);
        if let Some(vc) = &self.config.vibration {
            let noise = SampleNoise::new(imu.noise.accel_density, imu.noise.gyro_density, dt);
            self.vibration.add_to_process_noise(vc, &mut q, noise, dt);
        }
        propagate_nominal(&mut self.x, &accel, &gyro, dt);
        self.propagate_covariance(&f, &q);
        true
    }

    /// Camera frames fused, gated and rejected (each frame once).
    pub fn camera_counts(&self) -> &SampleCounts {
        self.camera.counts()
    }

    /// Camera frames not measured, by reason, and pairs fused on their
    /// rotation alone.
    pub fn camera_skips(&self) -> &CameraSkips {
        self.camera.skips()
    }

    /// The status after the latest camera frame.
    pub fn camera_status(&self) -> Option<&CameraStatus> {
        self.camera.status()
    }
}
