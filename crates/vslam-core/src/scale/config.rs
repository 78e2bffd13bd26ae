//! The pipeline's configuration: window sizes, every setting of the stages
//! it wires, and their validation.

use super::confidence::CameraConfidenceParams;
use super::flow::FlowParams;
use super::robust::RobustParams;
use super::select::{SelectParams, SelectionMethod};
use super::slip::SlipParams;
use super::transactions::{Distance, WheelParams};
use crate::adverse::{AdverseError, AdverseMemory, AdverseParams};
use crate::geometry::Extrinsics;
use crate::pose::Pose;
use crate::sensors::FlowOptics;
/// Odometry deltas kept (about 0.6 s at 100 Hz).
pub const WHEEL_WINDOW: usize = 64;
/// Flow reports kept (about 1.2 s at 100 Hz).
pub const FLOW_WINDOW: usize = 128;
/// IMU samples kept (about 0.5 s at 250 Hz).
pub const IMU_WINDOW: usize = 128;
/// Scale values in the running median.
pub const SCALE_WINDOW: usize = 15;
/// The pipeline's adverse-event memory: up to 256 cells with events (the
/// least recently used evicted beyond), 4 time slots each; 48 bytes a cell.
pub type PipelineMemory = AdverseMemory<256, 4>;

/// Which scale multiplies each frame pair's `t/d` in the composition.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ComposeScale {
    /// The running robust scale (median over [`SCALE_WINDOW`] frames).
    Running,
    /// The pair's own selected scale, as the seed composes (the running one
    /// when the pair has none: pure rotation, no usable source); default: it
    /// follows a change of ceiling height at once, where the running median
    /// lags by half its window (README, "Scale: composition").
    #[default]
    Pair,
}

/// Everything the pipeline is configured with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineConfig {
    /// Scale selection method.
    pub method: SelectionMethod,
    /// Which scale the composition uses.
    pub compose: ComposeScale,
    /// Which length of the wheel and flow motion is compared with `|T|`.
    pub distance: Distance,
    /// Camera mounting `T_BC`.
    pub camera: Extrinsics,
    /// IMU mounting `T_BI`.
    pub imu: Extrinsics,
    /// Flow sensor optics and mounting, if a counting flow sensor is fitted.
    pub flow_optics: Option<FlowOptics>,
    /// Initial body pose in the world.
    pub initial_body_pose: Pose,
    /// Wheel transaction settings.
    pub wheel: WheelParams,
    /// Flow transaction settings.
    pub flow: FlowParams,
    /// Camera confidence settings.
    pub camera_confidence: CameraConfidenceParams,
    /// Slip check settings.
    pub slip: SlipParams,
    /// Selection settings.
    pub select: SelectParams,
    /// Running scale settings.
    pub robust: RobustParams,
    /// Adverse-event memory settings.
    pub adverse: AdverseParams,
    /// Longest IMU step, nanoseconds.
    pub imu_max_step_ns: u64,
    /// Wheel/flow disagreement, in combined sigmas, that makes the wheel an outlier.
    pub wheel_outlier_sigmas: f32,
    /// Coverage below which the wheel data count as erroneous.
    pub min_wheel_coverage: f32,
    /// Floor grip at and above which the wheels get full confidence
    /// ([`super::ScalePipeline::set_wheel_grip`]).
    pub full_trust_grip: f32,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl PipelineConfig {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = PipelineConfig {
        method: SelectionMethod::Fusion,
        compose: ComposeScale::Pair,
        distance: Distance::Chord,
        camera: Extrinsics::IDENTITY,
        imu: Extrinsics::IDENTITY,
        flow_optics: None,
        initial_body_pose: crate::pose::POSE_IDENTITY,
        wheel: WheelParams::DEFAULT,
        flow: FlowParams::DEFAULT,
        camera_confidence: CameraConfidenceParams::DEFAULT,
        slip: SlipParams::DEFAULT,
        select: SelectParams::DEFAULT,
        robust: RobustParams::DEFAULT,
        adverse: AdverseParams::DEFAULT,
        imu_max_step_ns: 50_000_000,
        wheel_outlier_sigmas: 4.0,
        min_wheel_coverage: 0.5,
        full_trust_grip: 0.9,
    };
}

/// Why a pipeline configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PipelineConfigError {
    /// A setting is not finite or outside its range; names the setting.
    OutOfRange(&'static str),
    /// The adverse-memory settings were refused.
    Adverse(AdverseError),
}

impl core::fmt::Display for PipelineConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            PipelineConfigError::OutOfRange(name) => write!(f, "setting `{name}` out of range"),
            PipelineConfigError::Adverse(e) => write!(f, "adverse memory: {e}"),
        }
    }
}

impl core::error::Error for PipelineConfigError {}

impl PipelineConfig {
    /// Checks every numeric setting (finite, in range).
    pub fn validate(&self) -> Result<(), PipelineConfigError> {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        let non_negative = |v: f32| v.is_finite() && v >= 0.0;
        let unit = |v: f32| v.is_finite() && (0.0..=1.0).contains(&v);
        let checks: [(bool, &'static str); 21] = [
            (positive(self.wheel.k), "wheel.k"),
            (non_negative(self.wheel.rel_sigma), "wheel.rel_sigma"),
            (non_negative(self.wheel.floor_sigma), "wheel.floor_sigma"),
            (positive(self.wheel.max_speed), "wheel.max_speed"),
            (non_negative(self.flow.rel_sigma), "flow.rel_sigma"),
            (non_negative(self.flow.floor_sigma), "flow.floor_sigma"),
            (positive(self.slip.threshold), "slip.threshold"),
            (non_negative(self.slip.min_path), "slip.min_path"),
            (
                unit(self.slip.min_flow_confidence),
                "slip.min_flow_confidence",
            ),
            (
                positive(self.slip.yaw_rate_tolerance),
                "slip.yaw_rate_tolerance",
            ),
            (positive(self.slip.accel_tolerance), "slip.accel_tolerance"),
            (unit(self.slip.spin_ratio), "slip.spin_ratio"),
            (
                positive(self.slip.camera_tolerance),
                "slip.camera_tolerance",
            ),
            (positive(self.select.min_baseline), "select.min_baseline"),
            (
                non_negative(self.select.camera_rel_sigma),
                "select.camera_rel_sigma",
            ),
            (
                unit(self.select.min_source_confidence),
                "select.min_source_confidence",
            ),
            (positive(self.robust.gate_sigmas), "robust.gate_sigmas"),
            (positive(self.robust.rel_floor), "robust.rel_floor"),
            (positive(self.wheel_outlier_sigmas), "wheel_outlier_sigmas"),
            (unit(self.min_wheel_coverage), "min_wheel_coverage"),
            (
                positive(self.full_trust_grip) && self.full_trust_grip <= 1.0,
                "full_trust_grip",
            ),
        ];
        match checks.iter().find(|(ok, _)| !ok) {
            Some((_, name)) => Err(PipelineConfigError::OutOfRange(name)),
            None => Ok(()),
        }
    }
}
