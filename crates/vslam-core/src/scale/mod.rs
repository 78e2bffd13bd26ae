//! Metric scale for the monocular, ceiling-facing camera (seed: "slip-aware
//! metric scale"): the unit-less homography translation `t/d` times a scale
//! `s` from the wheels or the downward flow sensor, whichever is right now.
//!
//! - [`camera`]: the camera's input record, [`CameraMotion`];
//! - [`transactions`]: the wheel transaction `Tw` and the shared [`Transaction`];
//! - [`flow`]: the flow transaction `To` from counts; [`raw_flow`]: from raw frames;
//! - [`imu`]: gyro yaw and forward acceleration over an interval;
//! - [`confidence`]: per-source confidences; [`slip`]: the slip check;
//! - [`select`]: the five selection methods; [`robust`]: the running scale;
//! - [`pipeline`]: [`ScalePipeline`], which wires it all per camera frame,
//!   with its [`config`] and the per-frame [`decision`] record.

pub mod camera;
pub mod confidence;
pub mod config;
pub mod decision;
pub mod flow;
pub mod imu;
pub mod interval;
pub mod pipeline;
pub mod raw_flow;
pub mod robust;
pub mod select;
pub mod slip;
pub mod transactions;

pub use camera::{CameraMotion, CameraMotionError};
pub use pipeline::{
    ComposeScale, FrameDecision, PipelineConfig, PipelineConfigError, ScalePipeline,
};
pub use robust::{RobustEstimate, RobustScale};
pub use select::{NoScale, ScaleEstimate, ScaleSource, SelectionMethod};
pub use slip::{SlipCause, SlipReport, disagreement};
pub use transactions::{Distance, Transaction};
