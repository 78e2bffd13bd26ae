//! [`ScalePipeline`]: the caller feeds wheel deltas, flow reports, IMU samples
//! and camera motions, each stream in its own time order; per camera motion it
//! returns a [`FrameDecision`] (sources, confidences, slip, the chosen scale or
//! the typed reason for none) and composes the trajectory
//! `P_k = P_{k-1} [R_k s_k T_k; 0 1]`.
//!
//! Sensor samples are kept in fixed windows; a camera motion is a query over
//! `[t0, t1]` of those windows, so it may arrive late (feed it once the
//! sensors have passed `t1` for full coverage; an uncovered tail is
//! extrapolated at the covered rate and lowers the confidence through the
//! coverage). The transactions are summed for the camera's optical centre
//! (`t_BC` of the camera mounting), so `Tw / |T|` is the ceiling distance also
//! while turning.
//!
//! The wheel, flow and camera confidences are multiplied by the sensors' weights from
//! the adverse-event memory ([`crate::adverse`]) at the current position and
//! time, and the pipeline fills that memory with the events it sees: wheel
//! slip and outliers, wheels stuck while the robot moves, blank or stuck flow,
//! a camera with zero confidence; the caller adds what it sees elsewhere
//! ([`ScalePipeline::record_event`]: collisions, saturated IMU readings).

use super::camera::CameraMotion;
use super::confidence::{camera_confidence, wheel_confidence};
pub use super::config::{
    ComposeScale, FLOW_WINDOW, IMU_WINDOW, PipelineConfig, PipelineConfigError, PipelineMemory,
    SCALE_WINDOW, WHEEL_WINDOW,
};
pub use super::decision::FrameDecision;
use super::flow::{FlowStep, FlowStepWindow};
use super::imu::ImuWindow;
use super::raw_flow::{FeatureMotion, RawFlowError, RawFlowOptics, raw_flow_step};
use super::robust::{RobustEstimate, RobustScale};
use super::select::{NoScale, SelectionInput, SelectionMethod, select};
use super::slip::{SlipEvidence, SlipReport, assess, disagreement};
use super::transactions::{Distance, Transaction, WheelWindow};
use crate::adverse::{AdverseError, AdverseKind, AdverseMemory, SensorKind};
use crate::geometry::Vec2;
use crate::pose::{Pose, Trajectory};
use crate::reject::{Reject, SampleCounts};
use crate::sensors::{FlowSample, ImuSample, OdometryDelta};
use crate::time::Timestamp;

/// The metric-scale pipeline; `N` is the number of recent poses kept, `W`
/// the frames of the running robust scale's window (default
/// [`SCALE_WINDOW`]; at least `robust.min_count` of the configuration,
/// which [`ScalePipeline::new`] checks).
///
/// ```
/// use vslam_core::Timestamp;
/// use vslam_core::geometry::{Extrinsics, Rot3, Vec3};
/// use vslam_core::scale::{CameraMotion, PipelineConfig, ScalePipeline};
/// use vslam_core::sensors::{FlowOptics, FlowSample, OdometryDelta};
///
/// let config = PipelineConfig {
///     flow_optics: Some(FlowOptics::new(500.0, 0.02, Extrinsics::identity()).unwrap()),
///     ..PipelineConfig::default()
/// };
/// let mut p: ScalePipeline<16> = ScalePipeline::new(config).unwrap();
/// let ms = 1_000_000;
/// let _ = p.push_flow(&FlowSample { t: Timestamp(0), ..FlowSample::default() });
/// for k in 0..10u64 {
///     let (a, b) = (Timestamp(k * 10 * ms), Timestamp((k + 1) * 10 * ms));
///     let step = Vec3::new(0.003, 0.0, 0.0); // 0.3 m/s
///     p.push_wheel(&OdometryDelta { t0: a, t1: b, translation: step, dyaw: 0.0, path_length: 0.003 })
///         .unwrap();
///     let flow = FlowSample { t: b, dx: 75, squal: 100, shutter: 0x200, ..FlowSample::default() };
///     p.push_flow(&flow).unwrap();
/// }
/// // The camera saw 3 cm under a ceiling 2.5 m away: |t/d| = 0.012.
/// let m = CameraMotion::new(Timestamp(0), Timestamp(100 * ms), Rot3::identity(),
///     Vec3::new(0.012, 0.0, 0.0), 120, 0.9, 0.4).unwrap();
/// let decision = p.push_camera(&m).unwrap();
/// let s = decision.scale.unwrap();
/// assert!((s.scale - 2.5).abs() < 0.01);
/// assert!((p.body_pose().translation.vector.x - 0.03).abs() < 1e-3);
/// ```
#[derive(Clone, Debug)]
pub struct ScalePipeline<const N: usize = 32, const W: usize = SCALE_WINDOW> {
    config: PipelineConfig,
    wheel: WheelWindow<WHEEL_WINDOW>,
    flow: FlowStepWindow<FLOW_WINDOW>,
    imu: ImuWindow<IMU_WINDOW>,
    robust: RobustScale<W>,
    memory: PipelineMemory,
    trajectory: Trajectory<FrameDecision, N>,
    camera_counts: SampleCounts,
    last_camera: Option<Timestamp>,
    wheel_grip: f32,
    last_event: [[Option<Timestamp>; AdverseKind::COUNT]; SensorKind::COUNT],
}

/// Events given to [`ScalePipeline::record_event`] of one sensor and kind
/// closer than this to the previous one are one episode, recorded once
/// (nanoseconds): the saturated samples of one knock, at 250 Hz, are one
/// event, not dozens.
pub const EPISODE_GAP_NS: u64 = 1_000_000_000;

impl<const N: usize, const W: usize> ScalePipeline<N, W> {
    /// A pipeline at the configured initial pose, after [`PipelineConfig::validate`].
    pub fn new(config: PipelineConfig) -> Result<Self, PipelineConfigError> {
        Self::check_window(&config)?;
        config.validate()?;
        Ok(ScalePipeline {
            wheel: WheelWindow::new(config.wheel),
            flow: FlowStepWindow::new(config.flow),
            imu: ImuWindow::new(config.imu, config.imu_max_step_ns),
            robust: RobustScale::new(config.robust),
            memory: AdverseMemory::new(config.adverse).map_err(PipelineConfigError::Adverse)?,
            trajectory: Trajectory::new(config.initial_body_pose, config.camera),
            camera_counts: SampleCounts::new(),
            last_camera: None,
            wheel_grip: 1.0,
            last_event: [[None; AdverseKind::COUNT]; SensorKind::COUNT],
            config,
        })
    }

    /// A pipeline with the default configuration ([`PipelineConfig::DEFAULT`])
    /// at the identity pose: a `const` value, so that a pipeline can live in
    /// a `static` and be configured there ([`ScalePipeline::reset`]) without
    /// a pipeline-sized value passing through the stack.
    pub const fn unconfigured() -> Self {
        let config = PipelineConfig::DEFAULT;
        ScalePipeline {
            wheel: WheelWindow::new(config.wheel),
            flow: FlowStepWindow::new(config.flow),
            imu: ImuWindow::new(config.imu, config.imu_max_step_ns),
            robust: RobustScale::new(config.robust),
            memory: AdverseMemory::empty(config.adverse),
            trajectory: Trajectory::at_origin(),
            camera_counts: SampleCounts::new(),
            last_camera: None,
            wheel_grip: 1.0,
            last_event: [[None; AdverseKind::COUNT]; SensorKind::COUNT],
            config,
        }
    }

    /// Starts over in place with `config`, as [`ScalePipeline::new`] would
    /// build it (every window emptied where it is). A refused configuration
    /// leaves the pipeline as it was.
    pub fn reset(&mut self, config: PipelineConfig) -> Result<(), PipelineConfigError> {
        Self::check_window(&config)?;
        config.validate()?;
        self.memory
            .reset(config.adverse)
            .map_err(PipelineConfigError::Adverse)?;
        self.wheel.reset(config.wheel);
        self.flow.reset(config.flow);
        self.imu.reset(config.imu, config.imu_max_step_ns);
        self.robust.reset(config.robust);
        self.trajectory
            .reset(config.initial_body_pose, config.camera);
        self.camera_counts = SampleCounts::new();
        self.last_camera = None;
        self.wheel_grip = 1.0;
        self.last_event = [[None; AdverseKind::COUNT]; SensorKind::COUNT];
        self.config = config;
        Ok(())
    }

    /// The running scale needs `robust.min_count` values: a window of `W`
    /// must hold them.
    fn check_window(config: &PipelineConfig) -> Result<(), PipelineConfigError> {
        if usize::from(config.robust.min_count) > W {
            return Err(PipelineConfigError::OutOfRange("robust.min_count"));
        }
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &PipelineConfig {
        &self.config
    }

    /// Switches the selection method from the next frame on.
    pub fn set_method(&mut self, method: SelectionMethod) {
        self.config.method = method;
    }

    /// The floor's grip under the wheels now, `(0, 1]` (the surface model's
    /// estimate): below [`PipelineConfig::full_trust_grip`] the wheel
    /// confidence is scaled by `grip / full_trust_grip` from the next frame
    /// on, so on a slippery floor the wheels are trusted less before slip
    /// shows. A value outside `(0, 1]` is refused with [`Reject::OutOfRange`]
    /// and the previous grip kept.
    pub fn set_wheel_grip(&mut self, grip: f32) -> Result<(), Reject> {
        if grip.is_finite() && grip > 0.0 && grip <= 1.0 {
            self.wheel_grip = grip;
            Ok(())
        } else {
            Err(Reject::OutOfRange)
        }
    }

    /// The wheel confidence factor of the floor's grip, `(0, 1]`.
    pub fn grip_factor(&self) -> f32 {
        (self.wheel_grip / self.config.full_trust_grip).min(1.0)
    }

    /// Adds one IMU sample.
    pub fn push_imu(&mut self, s: &ImuSample) -> Result<(), Reject> {
        self.imu.push(s)
    }

    /// Adds one wheel odometry delta.
    pub fn push_wheel(&mut self, d: &OdometryDelta) -> Result<(), Reject> {
        self.wheel.push(d)
    }

    fn yaw_between(&self, t0: Timestamp, t1: Timestamp) -> f32 {
        self.imu
            .yaw_between(t0, t1)
            .or_else(|| {
                let w = self
                    .wheel
                    .summarize(t0, t1, &crate::geometry::Vec3::zeros());
                (w.coverage > 0.0).then_some(w.yaw)
            })
            .unwrap_or(0.0)
    }

    /// Adds one flow report (needs `flow_optics`; else [`Reject::NotReady`]).
    /// The heading change for the lever arm comes from the gyro, else the wheels.
    pub fn push_flow(&mut self, s: &FlowSample) -> Result<FlowStep, Reject> {
        let Some(optics) = self.config.flow_optics else {
            return Err(Reject::NotReady);
        };
        let dyaw = match self.flow.last_report() {
            Some(t0) if t0 < s.t => self.yaw_between(t0, s.t),
            _ => 0.0,
        };
        self.flow.push_sample(s, &optics, dyaw)
    }

    /// Adds the flow of one raw-frame pair: per-feature pixel displacements from
    /// Lucas-Kanade between the raw frames at `t0` and `t1`.
    pub fn push_raw_flow(
        &mut self,
        t0: Timestamp,
        t1: Timestamp,
        features: &[FeatureMotion],
        optics: &RawFlowOptics,
    ) -> Result<FlowStep, Reject> {
        let dyaw = if t1 > t0 {
            self.yaw_between(t0, t1)
        } else {
            0.0
        };
        let step = raw_flow_step(t0, t1, features, optics, dyaw).map_err(|e| match e {
            RawFlowError::TooFewFeatures => Reject::LowQuality,
            RawFlowError::BadInterval => Reject::OutOfOrder,
            RawFlowError::NonFinite => Reject::NonFinite,
        });
        match step {
            Ok(st) => self.flow.push_step(&st).map(|()| st),
            Err(e) => {
                self.flow.count_rejected(e);
                Err(e)
            }
        }
    }

    /// Processes one camera motion: transactions over `[t0, t1]`, slip,
    /// confidences, selection, running scale, adverse events, composition.
    /// A motion whose `t1` is not after the previous one's is rejected.
    pub fn push_camera(&mut self, m: &CameraMotion) -> Result<FrameDecision, Reject> {
        if let Some(last) = self.last_camera {
            if m.t1() == last {
                self.camera_counts.rejected_one(Reject::Duplicate);
                return Err(Reject::Duplicate);
            }
            if m.t1() < last {
                self.camera_counts.rejected_one(Reject::OutOfOrder);
                return Err(Reject::OutOfOrder);
            }
        }
        self.last_camera = Some(m.t1());
        let decision = self.decide(m);
        if decision.scale.is_ok() {
            self.camera_counts.fused_one();
        } else {
            self.camera_counts.rejected_one(match decision.scale {
                Err(NoScale::BaselineTooSmall) | Err(NoScale::Degenerate) => Reject::Degenerate,
                Err(NoScale::CameraUnreliable) => Reject::LowQuality,
                _ => Reject::NotReady,
            });
        }
        Ok(decision)
    }

    fn decide(&mut self, m: &CameraMotion) -> FrameDecision {
        let cfg = self.config;
        let (t0, t1) = (m.t0(), m.t1());
        let point = *cfg.camera.t_bs();
        let position = {
            let p = self.trajectory.body_pose().translation.vector;
            Vec2::new(p.x, p.y)
        };
        let ws = self.wheel.summarize(t0, t1, &point);
        let wheel_m = match cfg.distance {
            Distance::Path => ws.path,
            Distance::Chord => ws.chord,
        };
        let (flow_raw, fs) = self.flow.transaction(t0, t1, &point, cfg.distance);
        let imu = self.imu.summarize(t0, t1);
        let imu_ok = imu.coverage >= 0.5;
        let before = self.robust.estimate();
        let baseline = m.baseline();
        let camera_weight = self.memory.weight(SensorKind::Camera, &position, t1);
        let cam_conf = camera_confidence(m, &cfg.camera_confidence) * camera_weight;
        let dt = t1.seconds_since(t0).unwrap_or(0.0);

        let slip = assess(
            &SlipEvidence {
                dt,
                wheel_path: wheel_m,
                wheel_yaw: ws.yaw,
                wheel_accel: ws.accel,
                wheel_discontinuities: ws.discontinuities,
                flow_path: flow_raw.metres,
                flow_confidence: flow_raw.confidence,
                imu_yaw: imu_ok.then_some(imu.yaw),
                imu_accel: imu_ok.then_some(imu.accel_fwd),
                camera_baseline: baseline,
                scale: before.map(|e| e.scale),
            },
            &cfg.slip,
        );

        let wheel_weight = self.memory.weight(SensorKind::Wheel, &position, t1);
        let flow_weight = self.memory.weight(SensorKind::Flow, &position, t1);
        let imu_weight = self.memory.weight(SensorKind::Imu, &position, t1);
        let wc = wheel_confidence(
            slip.amount,
            cfg.slip.threshold,
            ws.coverage,
            ws.discontinuities,
        ) * wheel_weight
            * self.grip_factor();
        let wheel = Transaction {
            metres: wheel_m,
            variance: Transaction::variance_for(
                wheel_m,
                cfg.wheel.rel_sigma,
                cfg.wheel.floor_sigma,
                wc,
            ),
            confidence: wc,
            coverage: ws.coverage,
        };
        let fc = flow_raw.confidence * flow_weight;
        let flow = Transaction {
            confidence: fc,
            variance: Transaction::variance_for(
                flow_raw.metres,
                cfg.flow.rel_sigma,
                cfg.flow.floor_sigma,
                fc,
            ),
            ..flow_raw
        };

        // Wheel data erroneous (gaps, glitches, too little coverage) or an
        // outlier against the flow or against the running scale.
        let erroneous =
            !wheel_m.is_finite() || ws.coverage < cfg.min_wheel_coverage || ws.discontinuities > 0;
        let vs_flow = flow.confidence >= cfg.slip.min_flow_confidence && {
            let wheel_var =
                Transaction::variance_for(wheel_m, cfg.wheel.rel_sigma, cfg.wheel.floor_sigma, 1.0);
            let k = cfg.wheel_outlier_sigmas;
            disagreement(wheel_m, wheel_var, flow.metres, flow.variance) > k * k
        };
        let vs_running = baseline >= cfg.select.min_baseline
            && before.is_some_and(|e| e.z(wheel_m / baseline) > cfg.robust.gate_sigmas);
        let wheel_outlier = erroneous || vs_flow || vs_running;

        let input = SelectionInput {
            baseline,
            camera_confidence: cam_conf,
            wheel,
            flow,
            slip,
            wheel_outlier,
            robust: before,
        };
        let scale = select(cfg.method, &input, &cfg.select);
        let scale_outlier = match scale {
            Ok(e) => self.robust.push(e.scale).outlier,
            Err(_) => false,
        };
        let running = self.robust.estimate();
        let applied = match (cfg.compose, scale) {
            (ComposeScale::Pair, Ok(e)) => Some(e.scale),
            _ => running.map(|r| r.scale).or(scale.ok().map(|e| e.scale)),
        };

        self.record_events(
            &position,
            t1,
            &slip,
            wheel_outlier,
            &ws,
            &fs,
            &flow,
            cam_conf,
            baseline,
            running,
        );

        let decision = FrameDecision {
            t0,
            t1,
            method: cfg.method,
            baseline,
            camera_confidence: cam_conf,
            wheel,
            flow,
            wheel_weight,
            flow_weight,
            camera_weight,
            imu_weight,
            wheel_yaw: ws.yaw,
            imu_yaw: imu_ok.then_some(imu.yaw),
            slip,
            wheel_outlier,
            scale,
            scale_outlier,
            running,
            applied_scale: applied,
        };
        self.trajectory
            .compose(t1, m.r(), m.t_over_d(), applied.unwrap_or(0.0), decision);
        decision
    }

    #[allow(clippy::too_many_arguments)]
    fn record_events(
        &mut self,
        p: &Vec2,
        t: Timestamp,
        slip: &SlipReport,
        wheel_outlier: bool,
        ws: &super::transactions::WheelSummary,
        fs: &super::flow::FlowSummary,
        flow: &Transaction,
        cam_conf: f32,
        baseline: f32,
        running: Option<RobustEstimate>,
    ) {
        let min = self.config.slip.min_path;
        let camera_moved = running.is_some_and(|r| baseline * r.scale > 10.0 * min);
        let flow_trusted = flow.confidence >= self.config.slip.min_flow_confidence;
        let mut events: [Option<(SensorKind, AdverseKind)>; 6] = [None; 6];
        if slip.exceeded {
            events[0] = Some((SensorKind::Wheel, AdverseKind::Slip));
        } else if wheel_outlier {
            events[0] = Some((SensorKind::Wheel, AdverseKind::Outlier));
        }
        if ws.path < min && (camera_moved || (flow_trusted && flow.metres > 10.0 * min)) {
            events[1] = Some((SensorKind::Wheel, AdverseKind::Stuck));
        }
        if fs.samples > 0 && u32::from(fs.blank) * 2 >= u32::from(fs.samples) {
            events[2] = Some((SensorKind::Flow, AdverseKind::Blank));
        }
        if flow_trusted && flow.metres < min && camera_moved {
            events[3] = Some((SensorKind::Flow, AdverseKind::Stuck));
        }
        if cam_conf <= 0.0 {
            events[4] = Some((SensorKind::Camera, AdverseKind::Blank));
        }
        for (sensor, kind) in events.iter().flatten() {
            // Positions are finite poses; a failure only skips the record.
            let _ = self.memory.record(*sensor, *kind, p, t);
        }
    }

    /// The composed trajectory (current pose and the last `N` decisions).
    pub fn trajectory(&self) -> &Trajectory<FrameDecision, N> {
        &self.trajectory
    }

    /// The current camera pose `T_WC`.
    pub fn camera_pose(&self) -> &Pose {
        self.trajectory.camera_pose()
    }

    /// The current body pose `T_WB`.
    pub fn body_pose(&self) -> Pose {
        self.trajectory.body_pose()
    }

    /// The newest decision.
    pub fn last_decision(&self) -> Option<&FrameDecision> {
        self.trajectory.last().map(|e| &e.record)
    }

    /// The running robust scale.
    pub fn running_scale(&self) -> Option<RobustEstimate> {
        self.robust.estimate()
    }

    /// The adverse-event memory (export it with [`AdverseMemory::export`]).
    pub fn memory(&self) -> &PipelineMemory {
        &self.memory
    }

    /// Records an adverse event seen outside the frame decisions (a
    /// collision from the jolt monitor, a saturated IMU reading) at time `t`
    /// and the current body position (that of the latest camera frame).
    /// Events of one sensor and kind less than [`EPISODE_GAP_NS`] after the
    /// previous one continue its episode and are not recorded again; gives
    /// whether this one was recorded.
    pub fn record_event(
        &mut self,
        sensor: SensorKind,
        kind: AdverseKind,
        t: Timestamp,
    ) -> Result<bool, AdverseError> {
        let Some(last) = self
            .last_event
            .get_mut(sensor as usize)
            .and_then(|r| r.get_mut(kind as usize))
        else {
            return Ok(false);
        };
        let new_episode = match *last {
            Some(prev) => t.nanos_since(prev).is_none_or(|ns| ns >= EPISODE_GAP_NS),
            None => true,
        };
        *last = Some(t);
        if !new_episode {
            return Ok(false);
        }
        let p = self.trajectory.body_pose().translation.vector;
        self.memory
            .record(sensor, kind, &Vec2::new(p.x, p.y), t)
            .map(|()| true)
    }

    /// Replaces the adverse-event memory (e.g. restored from a record).
    pub fn set_memory(&mut self, memory: PipelineMemory) {
        self.memory = memory;
    }

    /// Replaces the adverse-event memory with one restored from `record`
    /// ([`AdverseMemory::export`], e.g. by an earlier run). A record that
    /// does not restore, or whose settings differ from
    /// [`PipelineConfig::adverse`] ([`AdverseError::SettingsMismatch`]: its
    /// cells would be read with another cell size or slot length), is
    /// refused and the memory kept as it was.
    pub fn restore_memory(&mut self, record: &[u8]) -> Result<(), AdverseError> {
        let memory = PipelineMemory::restore(record)?;
        if memory.params() != &self.config.adverse {
            return Err(AdverseError::SettingsMismatch);
        }
        self.memory = memory;
        Ok(())
    }

    /// Samples fused and rejected, by sensor. Camera: a frame with a scale is
    /// fused; one without is rejected as `Degenerate` (baseline), `LowQuality`
    /// (camera) or `NotReady` (no usable source).
    pub fn counts(&self, sensor: SensorKind) -> SampleCounts {
        match sensor {
            SensorKind::Wheel => *self.wheel.counts(),
            SensorKind::Flow => *self.flow.counts(),
            SensorKind::Camera => self.camera_counts,
            SensorKind::Imu => *self.imu.counts(),
        }
    }
}
