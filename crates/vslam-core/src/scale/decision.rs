//! The per-frame decision record the pipeline returns and keeps with each pose.

use super::robust::RobustEstimate;
use super::select::{NoScale, ScaleEstimate, SelectionMethod};
use super::slip::SlipReport;
use super::transactions::Transaction;
use crate::time::Timestamp;

/// The per-frame decision record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameDecision {
    /// First frame time.
    pub t0: Timestamp,
    /// Second frame time.
    pub t1: Timestamp,
    /// The method that decided.
    pub method: SelectionMethod,
    /// Camera baseline `|T|`.
    pub baseline: f32,
    /// Camera confidence (includes the adverse weight).
    pub camera_confidence: f32,
    /// Wheel transaction `Tw` (confidence includes slip and the adverse weight).
    pub wheel: Transaction,
    /// Flow transaction `To` (confidence includes the adverse weight).
    pub flow: Transaction,
    /// Adverse-memory weight applied to the wheels here.
    pub wheel_weight: f32,
    /// Adverse-memory weight applied to the flow here.
    pub flow_weight: f32,
    /// Adverse-memory weight applied to the camera here (its confidence
    /// includes it).
    pub camera_weight: f32,
    /// Adverse-memory weight of the IMU here (the pipeline does not use
    /// the IMU's readings as a distance; the EKF's propagation takes it).
    pub imu_weight: f32,
    /// The wheels' heading change over the pair, rad.
    pub wheel_yaw: f32,
    /// The gyro's heading change over the pair (not bias-corrected), rad,
    /// when its samples covered at least half of it.
    pub imu_yaw: Option<f32>,
    /// Slip verdict.
    pub slip: SlipReport,
    /// The wheel data were erroneous or an outlier.
    pub wheel_outlier: bool,
    /// This frame's scale, or why there is none.
    pub scale: Result<ScaleEstimate, NoScale>,
    /// The frame's scale lay outside the running scale's gate.
    pub scale_outlier: bool,
    /// The running scale after this frame.
    pub running: Option<RobustEstimate>,
    /// The scale the composition used (`None`: translation not composed).
    pub applied_scale: Option<f32>,
}
