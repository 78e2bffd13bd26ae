//! The pictures of a run: `trajectory.svg` (top view), `errors.svg` (error
//! over time against the truth) and `report.html` (one self-contained page
//! with both plots, the summary, the per-aid counts and the scale decisions).
//! Plain SVG text with no scripts and no fonts of its own, so a browser, an
//! SVG renderer (the tests use resvg) or an editor shows the same thing.

pub mod axes;
pub mod errors;
pub mod html;
pub mod markers;
pub mod scale_chart;
pub mod scene;
pub mod tables;
pub mod track;
pub mod trajectory;

pub use scene::Scene;

use crate::asl::GroundTruth;
use crate::tum::TumPose;
use serde_json::Value;

/// Colour of the truth.
pub const TRUTH_COLOUR: &str = "#7f7f7f";
/// Colour of the EKF.
pub const EKF_COLOUR: &str = "#d62728";
/// Colour of the camera path (VSLAM with metric scale).
pub const VSLAM_COLOUR: &str = "#1f77b4";
/// Colour of wheel odometry alone.
pub const WHEEL_COLOUR: &str = "#ff7f0e";

/// Line widths, px: the truth widest and under everything, then each
/// estimate narrower than the one drawn before it (wheels, camera, EKF), so
/// where they coincide every one still shows along the edges of the next.
pub const TRUTH_WIDTH: f64 = 8.0;
/// Width of the wheel-only line, px.
pub const WHEEL_WIDTH: f64 = 2.0;
/// Width of the camera path's line, px.
pub const VSLAM_WIDTH: f64 = 4.0;
/// Width of the EKF's line, px.
pub const EKF_WIDTH: f64 = 1.6;

/// Everything the plots and the page draw.
#[derive(Clone, Copy)]
pub struct PlotInputs<'a> {
    /// The EKF's trajectory.
    pub ekf: &'a [TumPose],
    /// The camera path with metric scale.
    pub vslam: &'a [TumPose],
    /// Wheel odometry alone.
    pub wheel_only: &'a [TumPose],
    /// The truth, when the log has it.
    pub truth: Option<&'a [GroundTruth]>,
    /// The simulated world, when the log comes from the simulator.
    pub scene: Option<&'a Scene>,
    /// `report.json` as written (with `errors` when there is a truth).
    pub report: &'a Value,
}

/// An event the estimator reported (`report.json` `events`).
#[derive(Clone, Debug, PartialEq)]
pub struct EstimatorEvent {
    /// Time stamp, nanoseconds.
    pub t_ns: u64,
    /// `SuspectedObstacle`, `ThresholdStrip` or `SurfaceNoise`.
    pub kind: String,
}

/// The estimator's events in `report`.
pub fn estimator_events(report: &Value) -> Vec<EstimatorEvent> {
    report["events"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|e| {
            Some(EstimatorEvent {
                t_ns: e["t"].as_u64()?,
                kind: e["kind"].as_str()?.to_string(),
            })
        })
        .collect()
}
