//! Surface awareness: segmentation map -> floor kinds -> grip -> the wheel
//! update's noise, gate and jolt threshold ([`GripParams`]).
//!
//! - [`classes`]: which class ids of the segmentation model are which floor;
//! - [`mix`]: fractions of floor kinds (sum one), blended by weight;
//! - [`segmentation`]: a label map -> floor fractions (bottom rows weighted
//!   more, nothing above the horizon) and a floor change ahead;
//! - [`grip_table`]: (floor, wheel type) -> grip -> [`GripParams`], blended by
//!   the fractions;
//! - [`anticipation`]: image row -> floor distance -> arrival time;
//! - [`tracker`]: the floor between maps, its age, staleness fallback and the
//!   hand-over onto an anticipated floor;
//! - [`jolt_context`]: what the floor explains for the jolt monitor;
//! - [`learning`]: per-floor forward-noise multipliers learned from the NIS,
//!   exported and restored as a checked record;
//! - [`slip`]: per-floor expected slip learned from the forward innovation
//!   on the floors where the wheel radii are held, exported and restored as
//!   a checked record of its own.
//!
//! [`SurfaceModel`] wires them together for the filter: call
//! [`SurfaceModel::on_segmentation`] per map (2-5 Hz),
//! [`SurfaceModel::grip_params`] per wheel update (and
//! [`SurfaceModel::on_wheel_innovation`] and [`SurfaceModel::on_wheel_slip`]
//! after it), and
//! [`SurfaceModel::jolt_context`] per IMU step for [`crate::events`].

pub mod anticipation;
pub mod classes;
pub mod floor_model;
pub mod grip_table;
pub mod jolt_context;
pub mod learning;
pub mod mix;
pub mod segmentation;
pub mod slip;
pub mod tracker;

pub use anticipation::{Anticipation, CameraError, GroundCamera};
pub use classes::{ClassConfig, ClassRole, SurfaceKind};
pub use floor_model::FloorModel;
pub use grip_table::{GripModel, GripTable, GripTableError, WheelType, lerp_params};
pub use jolt_context::JoltContext;
pub use learning::{
    FloorStats, LEARNED_RECORD_LEN, LearningConfig, LearningConfigError, NoiseLearner, RecordError,
};
pub use mix::SurfaceMix;
pub use segmentation::{
    GroundView, NoSurface, SegmentationConfig, SegmentationConfigError, Segmenter, UpcomingSurface,
};
pub use slip::{SLIP_RECORD_LEN, SlipConfig, SlipConfigError, SlipLearner, SlipStats};
pub use tracker::{SurfaceState, SurfaceTracker, TrackerConfig, TrackerConfigError};

use core::fmt;

use vslam_core::image::LabelView;
use vslam_core::{Reject, Timestamp};

use crate::grip::GripParams;

/// Everything the surface model is configured with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceConfig {
    /// The robot's drive wheels.
    pub wheel: WheelType,
    /// Class id -> floor kind.
    pub classes: ClassConfig,
    /// Horizon, row weights and bands of the label map.
    pub segmentation: SegmentationConfig,
    /// Grip per floor and wheel, and how grip becomes parameters.
    pub table: GripTable,
    /// Timing between maps.
    pub tracker: TrackerConfig,
    /// The forward camera over the floor.
    pub camera: GroundCamera,
    /// How the forward noise is learned.
    pub learning: LearningConfig,
    /// How the expected slip is learned.
    pub slip: SlipConfig,
    /// The conservative parameters used before any map and when stale.
    pub fallback: GripParams,
}

impl SurfaceConfig {
    /// Conservative parameters for an unknown floor: carpet-like grip and
    /// noise, a wide gate, a moderate jolt threshold.
    pub fn conservative_params() -> GripParams {
        GripParams::new(0.6, 0.05, 0.01, 13.0, 3.5).unwrap_or_default()
    }

    /// Defaults for `wheel` and the given class table.
    pub fn new(wheel: WheelType, classes: ClassConfig) -> Self {
        SurfaceConfig {
            wheel,
            classes,
            segmentation: SegmentationConfig::default(),
            table: GripTable::default(),
            tracker: TrackerConfig::default(),
            camera: GroundCamera::default(),
            learning: LearningConfig::default(),
            slip: SlipConfig::default(),
            fallback: SurfaceConfig::conservative_params(),
        }
    }

    /// Defaults for `wheel` and `classes`, with the label map read through
    /// the geometry of the camera that took it: the ground region starts at
    /// the camera's horizon ([`GroundCamera::horizon_fraction`]) instead of a
    /// fixed fraction, so no row that sees the floor is ignored, and the ahead
    /// band covers all of the ground above the near band. A camera pitched
    /// steeply down sees only a short stretch of floor; between two maps the
    /// robot may travel further than a fixed middle band is deep, and a narrow
    /// threshold strip would then go from unseen straight to under the
    /// camera's nearest row without ever being announced.
    pub fn for_camera(wheel: WheelType, classes: ClassConfig, camera: GroundCamera) -> Self {
        let defaults = SegmentationConfig::default();
        let near = defaults.near_band();
        let segmentation = SegmentationConfig::new(
            camera.horizon_fraction(),
            defaults.bottom_gain(),
            near,
            1.0 - near,
            defaults.min_coverage(),
            defaults.min_change_fraction(),
        )
        .map(|s| s.with_min_strip_fraction(defaults.min_strip_fraction()))
        .unwrap_or(defaults);
        SurfaceConfig {
            segmentation,
            camera,
            ..SurfaceConfig::new(wheel, classes)
        }
    }
}

/// Why a segmentation map did not update the floor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapError {
    /// The map holds no usable ground: the last floor is kept.
    NoSurface(NoSurface),
    /// The map's time stamp was refused (out of order, duplicate).
    Rejected(Reject),
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MapError::NoSurface(n) => write!(f, "no surface information: {n}"),
            MapError::Rejected(r) => write!(f, "segmentation map refused: {r}"),
        }
    }
}

impl core::error::Error for MapError {}

/// The surface model the filter talks to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceModel {
    wheel: WheelType,
    segmenter: Segmenter,
    table: GripTable,
    tracker: SurfaceTracker,
    learner: NoiseLearner,
    slip: SlipLearner,
    fallback: GripParams,
}

impl SurfaceModel {
    /// A model that has seen no map yet.
    pub fn new(config: SurfaceConfig) -> Self {
        SurfaceModel {
            wheel: config.wheel,
            segmenter: Segmenter::new(config.classes, config.segmentation),
            table: config.table,
            tracker: SurfaceTracker::new(config.tracker, config.camera),
            learner: NoiseLearner::new(config.learning, config.wheel),
            slip: SlipLearner::new(config.slip),
            fallback: config.fallback,
        }
    }

    /// Reads one segmentation map taken at `t` while the robot moved forward
    /// at `forward_speed` m/s, and updates the floor.
    pub fn on_segmentation(
        &mut self,
        t: Timestamp,
        labels: &LabelView<'_>,
        forward_speed: f32,
    ) -> Result<GroundView, MapError> {
        let view = self.segmenter.analyze(labels);
        self.tracker
            .on_map(t, view.as_ref().map_err(|e| *e), forward_speed)
            .map_err(|r| match view {
                Err(n) => MapError::NoSurface(n),
                Ok(_) => MapError::Rejected(r),
            })?;
        view.map_err(MapError::NoSurface)
    }

    /// The floor in effect at `t`.
    pub fn state_at(&self, t: Timestamp) -> SurfaceState {
        self.tracker.state_at(t)
    }

    /// The wheel-update parameters at `t`: the grip table blended by the
    /// floor fractions (with the learned noise), handed over onto an
    /// anticipated floor, and blended towards the conservative fallback when
    /// the floor is stale (fully before the first map).
    pub fn grip_params(&self, t: Timestamp) -> GripParams {
        self.params_for(&self.tracker.state_at(t))
    }

    fn params_for(&self, state: &SurfaceState) -> GripParams {
        let Some(mix) = state.mix else {
            return self.fallback;
        };
        let own = self.table.blended_learned(
            &mix,
            self.wheel,
            &self.learner.multipliers(),
            &self.slip.offsets(),
        );
        lerp_params(&own, &self.fallback, state.fallback_weight)
    }

    /// Learns from one forward wheel innovation (see
    /// [`NoiseLearner::observe`]) seen at `t`. Refused with
    /// [`Reject::NotReady`] while the floor is unknown or stale.
    pub fn on_wheel_innovation(
        &mut self,
        t: Timestamp,
        forward: f32,
        forward_var: f32,
        gated: bool,
    ) -> Result<(), Reject> {
        let state = self.tracker.state_at(t);
        match state.mix {
            Some(mix) if !state.is_stale() => {
                self.learner.observe(&mix, forward, forward_var, gated)
            }
            _ => Err(Reject::NotReady),
        }
    }

    /// Learns the floor's expected slip from one forward wheel innovation
    /// `forward` (m/s) of a sample seen at `t` whose wheels rolled at
    /// `speed` (m/s; see [`SlipLearner::observe`]). Refused with
    /// [`Reject::NotReady`] while the floor is unknown or stale.
    pub fn on_wheel_slip(
        &mut self,
        t: Timestamp,
        forward: f32,
        speed: f32,
        gated: bool,
    ) -> Result<(), Reject> {
        let state = self.tracker.state_at(t);
        match state.mix {
            Some(mix) if !state.is_stale() => self.slip.observe(
                &mix,
                forward,
                speed,
                gated,
                &self.table.slip_priors(self.wheel),
                &self.table.held_floors(self.wheel),
            ),
            _ => Err(Reject::NotReady),
        }
    }

    /// The expected slip of a floor: the grip table's prior plus what was
    /// learned.
    pub fn expected_slip(&self, kind: SurfaceKind) -> f32 {
        self.table.slip_prior(kind, self.wheel) + self.slip.stats(kind).offset
    }

    /// What the floor explains at `t`, for the jolt detector.
    pub fn jolt_context(&self, t: Timestamp, forward_speed: f32) -> JoltContext {
        let state = self.tracker.state_at(t);
        let params = self.params_for(&state);
        let strip = self
            .table
            .params(SurfaceKind::Threshold, self.wheel, 1.0)
            .jolt_threshold();
        // The floors beside a strip: the mix without the strip's share.
        let floor = match state.mix {
            Some(mix) if mix.fraction(SurfaceKind::Threshold) > 0.0 => {
                match mix.without(SurfaceKind::Threshold) {
                    Some(beside) => self.params_for(&SurfaceState {
                        mix: Some(beside),
                        ..state
                    }),
                    None => self.fallback,
                }
            }
            _ => params,
        };
        JoltContext {
            jolt_threshold: params.jolt_threshold(),
            floor_jolt_threshold: floor.jolt_threshold().min(params.jolt_threshold()),
            strip_threshold: strip.max(params.jolt_threshold()),
            surface: state.dominant(),
            last_crossing: self.tracker.last_crossing(t),
            next_crossing: self.tracker.next_crossing(t),
            forward_speed,
        }
    }

    /// The learned state as a fixed-size record.
    pub fn export_learned(&self) -> [u8; LEARNED_RECORD_LEN] {
        self.learner.to_bytes()
    }

    /// Restores a learned record; on error nothing changes.
    pub fn restore_learned(&mut self, bytes: &[u8]) -> Result<(), RecordError> {
        self.learner.restore(bytes)
    }

    /// The learned expected slips as a fixed-size record
    /// ([`slip`] module docs).
    pub fn export_learned_slip(&self) -> [u8; SLIP_RECORD_LEN] {
        self.slip.to_bytes(self.wheel)
    }

    /// Restores a learned-slip record; on error nothing changes.
    pub fn restore_learned_slip(&mut self, bytes: &[u8]) -> Result<(), RecordError> {
        self.slip.restore(bytes, self.wheel)
    }

    /// The wheel type.
    pub fn wheel(&self) -> WheelType {
        self.wheel
    }
    /// The segmenter.
    pub fn segmenter(&self) -> &Segmenter {
        &self.segmenter
    }
    /// The grip table.
    pub fn table(&self) -> &GripTable {
        &self.table
    }
    /// The tracker.
    pub fn tracker(&self) -> &SurfaceTracker {
        &self.tracker
    }
    /// The learner.
    pub fn learner(&self) -> &NoiseLearner {
        &self.learner
    }
    /// The slip learner.
    pub fn slip_learner(&self) -> &SlipLearner {
        &self.slip
    }
}
