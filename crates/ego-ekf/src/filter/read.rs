//! The read side of [`EgoEkf`]: configuration, time, the state and its
//! standard deviations, per-aid statuses and counts. Nothing here changes
//! the filter.

use vslam_core::kinematics::add_lever_arm;
use vslam_core::{SampleCounts, Timestamp};

use super::{EgoEkf, GapCounts, ImuStep};
use crate::aid_status::{FloorStatus, FlowStatus, WheelStatus, ZuptStatus};
use crate::config::FilterConfig;
use crate::floor::FloorFusion;
use crate::grip::GripParams;
use crate::recovery::RecoveryCounts;
use crate::state::{
    BA, BG, CL, CP, CR, CTH, Covariance, KG, NominalState, P, Quat, RAD_L, RAD_R, TH, V, Vec3,
};

impl EgoEkf {
    /// The current grip.
    pub fn grip(&self) -> GripParams {
        self.grip
    }

    /// The configuration.
    pub fn config(&self) -> &FilterConfig {
        &self.config
    }

    /// Whether the filter has started.
    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// Whether the robot is still (zero-velocity updates running).
    pub fn is_still(&self) -> bool {
        self.still.is_still(&self.config.zupt)
    }

    /// Time of the latest accepted IMU sample.
    pub fn time(&self) -> Option<Timestamp> {
        if self.initialised {
            self.imu_clock.last()
        } else {
            None
        }
    }

    /// The whole nominal state.
    pub fn state(&self) -> &NominalState {
        &self.x
    }

    /// The error-state covariance.
    pub fn covariance(&self) -> &Covariance {
        &self.p
    }

    /// IMU position, world, m.
    pub fn position(&self) -> Vec3 {
        self.x.p_wb
    }

    /// IMU attitude (body vectors into the world).
    pub fn attitude(&self) -> Quat {
        self.x.q_wb
    }

    /// IMU velocity, world, m/s.
    pub fn velocity(&self) -> Vec3 {
        self.x.v_wb
    }

    /// Velocity of the robot origin (mid-axle), robot frame, m/s.
    pub fn robot_velocity(&self) -> Vec3 {
        let v_b = self.x.q_wb.inverse() * self.x.v_wb;
        self.x.q_rb * add_lever_arm(&v_b, &self.angular_velocity(), &self.x.p_b_robot())
    }

    /// Bias-corrected angular rate of the latest step, body frame, rad/s.
    pub fn angular_velocity(&self) -> Vec3 {
        self.last_step.map_or(Vec3::zeros(), |s| s.gyro)
    }

    /// Accelerometer bias, m/s^2.
    pub fn accel_bias(&self) -> Vec3 {
        self.x.accel_bias
    }

    /// Gyroscope bias, rad/s.
    pub fn gyro_bias(&self) -> Vec3 {
        self.x.gyro_bias
    }

    /// The gyro's z scale-factor error `k` (it reads `(1 + k) w_z + b_z`).
    pub fn gyro_scale(&self) -> f32 {
        self.x.gyro_scale
    }

    /// Standard deviation of the gyro's z scale-factor error.
    pub fn gyro_scale_std(&self) -> f32 {
        self.std_dev(KG)
    }

    /// Wheel radii `[left, right]`, m.
    pub fn wheel_radii(&self) -> [f32; 2] {
        [self.x.radius_left, self.x.radius_right]
    }

    /// Standard deviation of error-state component `i` (`NaN` outside the state).
    pub fn std_dev(&self, i: usize) -> f32 {
        self.p
            .get((i, i))
            .map_or(f32::NAN, |v| libm::sqrtf(v.max(0.0)))
    }

    fn std3(&self, i: usize) -> Vec3 {
        Vec3::new(self.std_dev(i), self.std_dev(i + 1), self.std_dev(i + 2))
    }

    /// Position standard deviation, m.
    pub fn position_std(&self) -> Vec3 {
        self.std3(P)
    }

    /// Velocity standard deviation, m/s.
    pub fn velocity_std(&self) -> Vec3 {
        self.std3(V)
    }

    /// Attitude standard deviation (local angles), rad.
    pub fn attitude_std(&self) -> Vec3 {
        self.std3(TH)
    }

    /// Accelerometer bias standard deviation, m/s^2.
    pub fn accel_bias_std(&self) -> Vec3 {
        self.std3(BA)
    }

    /// Gyroscope bias standard deviation, rad/s.
    pub fn gyro_bias_std(&self) -> Vec3 {
        self.std3(BG)
    }

    /// Wheel radius standard deviations `[left, right]`, m.
    pub fn wheel_radius_std(&self) -> [f32; 2] {
        [self.std_dev(RAD_L), self.std_dev(RAD_R)]
    }

    /// A skid steer's learned effective track (expansion factor `chi` over
    /// the physical track; [`crate::wheel::skid`]); `None` for a
    /// differential drive.
    pub fn track_estimate(&self) -> Option<crate::wheel::skid::TrackEstimate> {
        self.wheel.track_estimate(&self.x)
    }

    /// Contact-point standard deviations `[left, right]`, m.
    pub fn contact_std(&self) -> [Vec3; 2] {
        [self.std3(CL), self.std3(CR)]
    }

    /// Clone standard deviations `(position, attitude)`. The clone is taken
    /// at the first still step after motion (the zero-velocity update reads
    /// it); while the robot moves it is the last one taken, kept decoupled,
    /// so these are its variances from then, not the current pose's.
    pub fn clone_std(&self) -> (Vec3, Vec3) {
        (self.std3(CP), self.std3(CTH))
    }

    /// The latest IMU step (bias-corrected sample, vertical deviation).
    pub fn last_imu_step(&self) -> Option<ImuStep> {
        self.last_step
    }

    /// The wheels' status after their latest sample: forward and
    /// differential rows (see [`crate::aid_status`]).
    pub fn wheel_status(&self) -> Option<&WheelStatus> {
        self.wheel.status()
    }

    /// The optical flow's status after its latest report.
    pub fn flow_status(&self) -> Option<&FlowStatus> {
        self.flow.status()
    }

    /// The zero-velocity update's status after the latest update.
    pub fn zupt_status(&self) -> Option<&ZuptStatus> {
        self.zupt.status()
    }

    /// The floor constraint: its plane's height, counts, re-anchorings,
    /// suspensions and latest status (see [`crate::floor`]).
    pub fn floor(&self) -> &FloorFusion {
        &self.floor
    }

    /// The status after the latest floor update.
    pub fn floor_status(&self) -> Option<&FloorStatus> {
        self.floor.status()
    }

    /// Floor updates fused, gated and rejected by reason.
    pub fn floor_counts(&self) -> &SampleCounts {
        self.floor.counts()
    }

    /// IMU samples propagated and rejected by reason.
    pub fn imu_counts(&self) -> &SampleCounts {
        &self.imu_counts
    }

    /// Wheel samples fused, gated and rejected by reason.
    pub fn wheel_counts(&self) -> &SampleCounts {
        self.wheel.counts()
    }

    /// Velocity resets to the flow after runs of gated flow reports.
    pub fn flow_resets(&self) -> u32 {
        self.flow.resets()
    }

    /// Verdicts after runs of gated wheel samples: velocity resets by source,
    /// and re-examinations that kept gating (see [`crate::recovery`]).
    pub fn recovery(&self) -> &RecoveryCounts {
        &self.recovery
    }

    /// The mean of the recent flow reports of valid quality and plausible
    /// speed, at the filter's time (see [`crate::recovery::FlowWindow`]).
    pub fn flow_witness(&self) -> Option<crate::recovery::FlowWitness> {
        self.flow.witness(self.time()?)
    }

    /// IMU gaps bridged (see [`crate::gap`]).
    pub fn gaps(&self) -> &GapCounts {
        &self.gaps
    }

    /// Wheel samples that dead-reckoned IMU gaps, and those refused for it
    /// by reason (see [`crate::gap::odometry`]); the same samples are also in
    /// [`EgoEkf::wheel_counts`] with the wheel update's outcome.
    pub fn gap_wheel_counts(&self) -> &SampleCounts {
        self.gap_odometry.counts()
    }

    /// Of those, the samples whose wheels disagreed with the flow (spinning)
    /// and were scaled to its speed.
    pub fn gap_wheel_slips(&self) -> u32 {
        self.gap_odometry.slips()
    }

    /// Flow reports fused, gated and rejected by reason.
    pub fn flow_counts(&self) -> &SampleCounts {
        self.flow.counts()
    }

    /// Zero-velocity updates fused and rejected.
    pub fn zupt_counts(&self) -> &SampleCounts {
        self.zupt.counts()
    }
}
