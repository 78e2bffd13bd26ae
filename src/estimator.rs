//! `Estimator`: wires every part of traction together, for firmware and host alike.
//!
//! Samples of every stream go in as they arrive ([`Estimator::offer`]); the
//! estimator puts them into one time order ([`crate::reorder`]) and, when
//! polled, processes them one by one:
//!
//! - IMU: validated once (non-finite, saturated), the EKF propagates, the
//!   scale pipeline keeps it for its slip checks, and the vertical
//!   specific-force deviation goes to the jolt monitor with the context of
//!   the current floor; a saturated reading (an IMU event) and a suspected
//!   obstacle (a wheel collision event) go to the adverse-event memory;
//! - wheel counts (or wheel angular rates, from a robot that reports those):
//!   `wheel-odom` turns them into a body displacement and wheel rates; the EKF fuses the rates with the floor's grip (forward gated,
//!   lateral and vertical always), the scale pipeline accumulates `Tw` of
//!   the displacement corrected to the filter's learned radii and the
//!   floor's expected slip ([`wheel_distance`]), and
//!   the forward innovation teaches the surface model its floors;
//! - flow reports: the EKF fuses the velocity with quality as noise, the
//!   scale pipeline accumulates `To`.
//!
//! Camera frames ([`Estimator::process_camera`]): the front end's frame
//! pair motion goes to the scale pipeline, and with the pair's scale (if
//! any) to the EKF as a relative-pose measurement, its noise inflated by
//! the camera's adverse-memory weight; the IMU's, the wheels' and the flow
//! sensor's memory weights where the pair ends go to the EKF
//! ([`ego_ekf::SensorWeights`]: process and measurement noise divided by
//! them until the next pair); before that, each sensor's motion
//! over the pair is checked against the EKF's ([`crate::disagreement`]),
//! a disagreement an adverse event of that sensor; the pair's slip and
//! wheel-outlier verdicts inflate the EKF's wheel noise (by default: refuse
//! the wheels' forward rows) over the next frame interval
//! ([`wheel_distrust`]). Camera frames and segmentation maps
//! ([`Estimator::process_segmentation`]) are borrowed views, processed at
//! once after every buffered sample up to their time. Every sample ends in
//! exactly one count of its stream (fused, or rejected with a reason), so a
//! report's counts add up to what went in.
//!
//! # Memory
//!
//! [`EstimatorWith`] takes its capacities as const generics (the ordering
//! buffer, the scale pipeline's camera trajectory, the jolt log, the
//! running-scale window);
//! [`Estimator`] is the type with the default capacities. All of its state
//! is inline (no allocator): 48,848 bytes with the defaults on
//! `thumbv7em-none-eabihf` (`size Estimator` in `firmware/report`). To build
//! it in place, e.g. in a `static` on a microcontroller, without an
//! estimator-sized value passing through the stack:
//! [`EstimatorWith::unconfigured`] is a `const fn` (a static initialiser),
//! and [`EstimatorWith::configure`] writes the configuration into every part
//! where it lies; [`EstimatorWith::fit_frontend`] adds the camera path.
//! [`EstimatorWith::new`] builds a value (on the stack or in a `Box`).
//!
//! # Measuring the parts
//!
//! The last type parameter is a [`Probe`] ([`NoProbe`] by default, zero
//! bytes and no code) that the estimator calls around each call into a part
//! ([`Part`]: the EKF's propagation and updates, the odometry, the scale
//! pipeline, the front end, the disagreement check);
//! [`EstimatorWith::unconfigured_with_probe`] builds one with another probe.

use crate::disagreement::DisagreementCheck;
use crate::estimate::{Estimate, estimate_of};
use crate::frontend::{FrontEnd, FrontEndBuffers, FrontEndConfig, FrontEndError, MAX_FEATURES};
use crate::reorder::{Event, Pushed, Reorder};
use ego_ekf::events::{JoltConfig, JoltContext, JoltEvent, JoltMonitor};
use ego_ekf::surface::{MapError, SurfaceModel};
use ego_ekf::{ConfigError, EgoEkf, FilterConfig, ImuStep, SensorWeights, WheelInnovation};
use heapless::Deque;
use probe::probed;
pub use probe::{NoProbe, Part, Probe};
use vslam_core::adverse::{AdverseError, AdverseKind, SensorKind};
use vslam_core::disagree::Gates;
use vslam_core::flow_frames::{FramePairMotion, raw_optics};
use vslam_core::image::{ImageView, LabelView};
use vslam_core::scale::flow::FlowStep;
use vslam_core::scale::{
    CameraMotion, FrameDecision, PipelineConfig, PipelineConfigError, ScalePipeline,
};
use vslam_core::sensors::{FlowSample, ImuSample, RawImuSample, RawWheelRates, WheelTicks};
use vslam_core::{Reject, RobotError, SampleCounts, Stream, StreamCounts, Timestamp};
use wheel_odom::odometry::{DiffDriveOdometry, DiffDriveParams};

pub mod probe;
pub mod wheel_distance;

/// Samples the ordering buffer holds ([`Estimator`]'s default).
pub const REORDER_CAPACITY: usize = 64;
/// Recent poses the scale pipeline keeps ([`Estimator`]'s default).
pub const TRAJECTORY_CAPACITY: usize = 32;
/// Jolt events the monitor keeps ([`Estimator`]'s default).
pub const JOLT_LOG: usize = 16;
/// Frames in the scale pipeline's running-scale window ([`Estimator`]'s
/// default; at least the configuration's `scale.robust.min_count`, which
/// [`EstimatorWith::configure`] checks).
pub const SCALE_WINDOW: usize = vslam_core::scale::config::SCALE_WINDOW;
/// Smallest ordering buffer: one sample.
pub const MIN_REORDER_CAPACITY: usize = 1;
/// Smallest camera trajectory: the two poses of a frame pair.
pub const MIN_TRAJECTORY_CAPACITY: usize = 2;
/// Smallest jolt log: the latest event.
pub const MIN_JOLT_LOG: usize = 1;
/// Smallest running-scale window: one frame.
pub const MIN_SCALE_WINDOW: usize = 1;

/// Everything the estimator is built from.
#[derive(Clone, Debug)]
pub struct EstimatorConfig {
    /// The EKF.
    pub filter: FilterConfig,
    /// Wheel odometry.
    pub odometry: DiffDriveParams,
    /// The metric-scale pipeline.
    pub scale: PipelineConfig,
    /// The surface model; `None` keeps the filter's fixed grip.
    pub surface: Option<ego_ekf::surface::SurfaceConfig>,
    /// Jolt detection.
    pub jolts: JoltConfig,
    /// How long the ordering buffer waits for late samples, nanoseconds.
    pub reorder_window_ns: u64,
    /// The factor by which the EKF's wheel noise (standard deviation) is
    /// inflated over the frame interval after a camera frame pair in which
    /// the scale pipeline found the wheels slipping or an outlier
    /// ([`wheel_distrust`]); infinite refuses the forward and differential
    /// rows instead; `None` cuts the link.
    pub wheel_distrust: Option<f32>,
}

/// How long and how much the EKF distrusts the wheels after a frame pair's
/// `decision` (see `ego_ekf::wheel::distrust`): when the pair's slip
/// exceeded the threshold or its wheel data were an outlier, the wheel
/// samples up to one frame interval after the pair's second frame (until
/// the next pair's verdict), with the noise's standard deviation times
/// `factor`; `None` when the wheels were trusted.
pub fn wheel_distrust(decision: &FrameDecision, factor: f32) -> Option<(Timestamp, f32)> {
    if !(decision.slip.exceeded || decision.wheel_outlier) {
        return None;
    }
    let interval = decision.t1.nanos_since(decision.t0).unwrap_or(0);
    Some((Timestamp(decision.t1.0.saturating_add(interval)), factor))
}

/// Whether a wheel sample's forward row, refused by the filter, still
/// teaches the floor's slip learner: its innovation `forward` (m/s, the
/// slip-corrected wheel speed minus the filter's) is negative, so it can
/// only lower the expected slip, and passes the grip's chi-square `gate`
/// with variance `var`. A refused row is suspected of slipping, and
/// slipping wheels over-count: they may not raise the expected slip (a
/// wheel-spin episode would become the floor's slip). But a learned slip
/// that is too high under-counts the corrected wheel distance, the scale
/// pipeline then finds the wheels an outlier against the flow and its
/// verdict refuses them, and without this the slip could not be learned
/// back while the robot stays on that floor (the wheels refused for 13 s
/// on a carpet in the chaos hour).
pub fn lowers_slip(forward: f32, var: f32, gate: f32) -> bool {
    forward < 0.0 && var > 0.0 && forward * forward <= gate * var
}

/// Why the estimator could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EstimatorError {
    /// The filter settings were refused.
    Filter(ConfigError),
    /// The scale pipeline settings were refused.
    Scale(PipelineConfigError),
    /// The robot description was refused.
    Robot(RobotError),
    /// Two parts of the configuration describe the robot differently.
    Inconsistent(Mismatch),
}

/// Which quantity two parts of an [`EstimatorConfig`] disagree on (a
/// configuration built by [`EstimatorConfig::from_robot`] has none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mismatch {
    /// The odometry's mean wheel radius and the EKF prior's radius, m.
    WheelRadius {
        /// Mean of the odometry's two radii.
        odometry: f32,
        /// The EKF robot prior's radius.
        filter: f32,
    },
    /// The flow optics of the EKF and of the scale pipeline (counts per
    /// radian, height or mounting) differ, or only one of them has a flow sensor.
    FlowOptics,
}

impl core::fmt::Display for EstimatorError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            EstimatorError::Filter(e) => write!(f, "filter settings: {e:?}"),
            EstimatorError::Scale(e) => write!(f, "scale settings: {e:?}"),
            EstimatorError::Robot(e) => write!(f, "robot description: {e}"),
            EstimatorError::Inconsistent(Mismatch::WheelRadius { odometry, filter }) => write!(
                f,
                "wheel radius {odometry} m in the odometry but {filter} m in the EKF prior \
                 (build the configuration with EstimatorConfig::from_robot)"
            ),
            EstimatorError::Inconsistent(Mismatch::FlowOptics) => write!(
                f,
                "the EKF and the scale pipeline have different flow optics \
                 (build the configuration with EstimatorConfig::from_robot)"
            ),
        }
    }
}

impl core::error::Error for EstimatorError {}

/// The metric scale and its variance the EKF's camera update gets for a
/// frame pair ([`EgoEkf::fuse_camera`]): none if the pair has no scale of
/// its own (a turn in place, no usable source), else the running robust
/// scale and its sigma squared (the pair's own scale and variance until the
/// running scale has enough values). The running scale is the ceiling
/// distance measured over many pairs, so one pair's wheel or flow distance
/// does not enter the EKF twice; on `host-sim simulate` office seed 1 the
/// two choices gave the same EKF ATE to 1 mm.
pub fn filter_scale(decision: &FrameDecision) -> Option<(f32, f32)> {
    match (decision.scale, decision.running) {
        (Ok(_), Some(r)) => Some((r.scale, r.sigma * r.sigma)),
        (Ok(e), None) => Some((e.scale, e.variance)),
        (Err(_), _) => None,
    }
}

/// What processing one buffered sample did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Processed {
    /// An IMU sample.
    Imu {
        /// Its time.
        t: Timestamp,
        /// The filter step, or why the sample was rejected.
        outcome: Result<ImuStep, Reject>,
        /// A jolt this sample completed.
        jolt: Option<JoltEvent>,
    },
    /// Wheel counts.
    Wheel {
        /// Their time.
        t: Timestamp,
        /// The forward innovation (with `gated` set when the gate refused the
        /// forward part), or why the sample was rejected.
        outcome: Result<WheelInnovation, Reject>,
    },
    /// A flow report.
    Flow {
        /// Its time.
        t: Timestamp,
        /// Fused, or why not.
        outcome: Result<(), Reject>,
    },
}

impl Processed {
    /// The stream of the processed sample.
    pub const fn stream(&self) -> Stream {
        match self {
            Processed::Imu { .. } => Stream::Imu,
            Processed::Wheel { .. } => Stream::Wheel,
            Processed::Flow { .. } => Stream::Flow,
        }
    }

    /// The sample's time stamp.
    pub const fn t(&self) -> Timestamp {
        match self {
            Processed::Imu { t, .. } | Processed::Wheel { t, .. } | Processed::Flow { t, .. } => *t,
        }
    }
}

/// The estimator with the default capacities ([`REORDER_CAPACITY`],
/// [`TRAJECTORY_CAPACITY`], [`JOLT_LOG`], [`SCALE_WINDOW`]).
pub type Estimator<'b> =
    EstimatorWith<'b, REORDER_CAPACITY, TRAJECTORY_CAPACITY, JOLT_LOG, SCALE_WINDOW>;

/// The whole estimator, with its capacities: `REORDER` samples in the
/// ordering buffer (at least [`MIN_REORDER_CAPACITY`]; it must hold the
/// samples of every stream that arrive within the ordering window),
/// `TRAJECTORY` camera poses in the scale pipeline (at least
/// [`MIN_TRAJECTORY_CAPACITY`]) and `JOLTS` jolt events in the log (at least
/// [`MIN_JOLT_LOG`]) and `SCALE` frames in the running-scale window (at
/// least [`MIN_SCALE_WINDOW`], and at least the configuration's
/// `scale.robust.min_count`, checked by [`EstimatorWith::configure`]); `P`
/// is called around each part's work ([`Probe`]; [`NoProbe`], the default,
/// does nothing); `FEATURES` features per camera frame in the camera path
/// ([`FrontEnd`]: default [`MAX_FEATURES`], at least
/// [`crate::frontend::MIN_FEATURES`]; a 160x120 camera with
/// [`FrontEndConfig::new`] tracks at most 50). Smaller capacities are
/// refused at compile time:
///
/// ```compile_fail
/// use traction::estimator::EstimatorWith;
/// // A trajectory of one pose cannot hold a frame pair.
/// let e: EstimatorWith<'static, 64, 1, 16, 15> = EstimatorWith::unconfigured();
/// ```
///
/// ```
/// use traction::estimator::EstimatorWith;
/// let e: EstimatorWith<'static, 64, 2, 16, 15> = EstimatorWith::unconfigured();
/// assert!(!e.is_configured());
/// ```
pub struct EstimatorWith<
    'b,
    const REORDER: usize,
    const TRAJECTORY: usize,
    const JOLTS: usize,
    const SCALE: usize,
    P: Probe = NoProbe,
    const FEATURES: usize = MAX_FEATURES,
> {
    ekf: EgoEkf,
    odometry: DiffDriveOdometry,
    scale: ScalePipeline<TRAJECTORY, SCALE>,
    surface: Option<SurfaceModel>,
    jolts: JoltMonitor<JOLTS>,
    frontend: Option<FrontEnd<'b, FEATURES>>,
    wheel_distrust: Option<f32>,
    reorder: Reorder<REORDER>,
    pending: Deque<Processed, 4>,
    counts: StreamCounts,
    disagreement: DisagreementCheck,
    ended: bool,
    configured: bool,
    probe: P,
}

impl<
    'b,
    const REORDER: usize,
    const TRAJECTORY: usize,
    const JOLTS: usize,
    const SCALE: usize,
    const FEATURES: usize,
> EstimatorWith<'b, REORDER, TRAJECTORY, JOLTS, SCALE, NoProbe, FEATURES>
{
    /// Builds the estimator; `frontend` is the camera path, if a camera is fitted.
    pub fn new(
        config: &EstimatorConfig,
        frontend: Option<FrontEnd<'b, FEATURES>>,
    ) -> Result<Self, EstimatorError> {
        let mut e = Self::unconfigured();
        e.configure(config)?;
        e.frontend = frontend;
        Ok(e)
    }

    /// An estimator that refuses every sample (counted as
    /// [`Reject::NotReady`]) until [`EstimatorWith::configure`] succeeds,
    /// with no camera path. A `const fn`, so that the estimator can be a
    /// `static` built at compile time and configured in place:
    ///
    /// ```
    /// use traction::estimator::{Estimator, EstimatorConfig};
    /// use traction::vslam_core::robot::RobotDescription;
    ///
    /// // Built at compile time (in firmware: behind the platform's mutex or
    /// // cell, e.g. `critical_section::Mutex<RefCell<..>>`).
    /// static ESTIMATOR: std::sync::Mutex<Estimator<'static>> =
    ///     std::sync::Mutex::new(Estimator::unconfigured());
    ///
    /// let config = EstimatorConfig::from_robot(&RobotDescription::robot_vacuum()).unwrap();
    /// let mut est = ESTIMATOR.lock().unwrap();
    /// assert!(!est.is_configured());
    /// est.configure(&config).unwrap();
    /// assert!(est.is_configured());
    /// ```
    pub const fn unconfigured() -> Self {
        Self::unconfigured_with_probe(NoProbe)
    }
}

impl<
    'b,
    const REORDER: usize,
    const TRAJECTORY: usize,
    const JOLTS: usize,
    const SCALE: usize,
    P: Probe,
    const FEATURES: usize,
> EstimatorWith<'b, REORDER, TRAJECTORY, JOLTS, SCALE, P, FEATURES>
{
    /// The capacities' lower bounds, checked when the type is used.
    const CAPACITIES: () = assert!(
        REORDER >= MIN_REORDER_CAPACITY
            && TRAJECTORY >= MIN_TRAJECTORY_CAPACITY
            && JOLTS >= MIN_JOLT_LOG
            && SCALE >= MIN_SCALE_WINDOW,
        "estimator capacities below their minimum (MIN_REORDER_CAPACITY, \
         MIN_TRAJECTORY_CAPACITY, MIN_JOLT_LOG, MIN_SCALE_WINDOW)"
    );

    /// As [`EstimatorWith::unconfigured`], with `probe` called around each
    /// part's work (a `const fn` too).
    pub const fn unconfigured_with_probe(probe: P) -> Self {
        let () = Self::CAPACITIES;
        EstimatorWith {
            ekf: EgoEkf::unconfigured(),
            odometry: DiffDriveOdometry::new(DiffDriveParams::PLACEHOLDER),
            scale: ScalePipeline::unconfigured(),
            surface: None,
            jolts: JoltMonitor::new(JoltConfig::DEFAULT),
            frontend: None,
            wheel_distrust: None,
            reorder: Reorder::new(0),
            pending: Deque::new(),
            counts: StreamCounts::zero(),
            disagreement: DisagreementCheck::new(Gates::DEFAULT),
            ended: false,
            configured: false,
            probe,
        }
    }

    /// The probe.
    pub fn probe(&self) -> &P {
        &self.probe
    }

    /// The probe, to change.
    pub fn probe_mut(&mut self) -> &mut P {
        &mut self.probe
    }

    /// Configures every part in place and starts over: the filter, the
    /// odometry, the scale pipeline (its windows emptied where they lie),
    /// the surface model, the jolt monitor, the ordering buffer and the
    /// counts; the camera path is kept ([`EstimatorWith::fit_frontend`]).
    /// No part is built as a value and moved, so the stack holds at most a
    /// part's small pieces. A refused configuration leaves the estimator
    /// unconfigured: it refuses samples until a later call succeeds.
    pub fn configure(&mut self, config: &EstimatorConfig) -> Result<(), EstimatorError> {
        self.configured = false;
        config.check()?;
        self.ekf
            .reset(config.filter)
            .map_err(EstimatorError::Filter)?;
        self.scale
            .reset(config.scale)
            .map_err(EstimatorError::Scale)?;
        self.odometry = DiffDriveOdometry::new(config.odometry);
        self.surface = config.surface.map(SurfaceModel::new);
        self.jolts = JoltMonitor::new(config.jolts);
        self.wheel_distrust = config.wheel_distrust;
        self.reorder.reset(config.reorder_window_ns);
        self.pending.clear();
        self.counts = StreamCounts::zero();
        self.disagreement = DisagreementCheck::new(*self.disagreement.gates());
        self.ended = false;
        self.configured = true;
        Ok(())
    }

    /// Whether [`EstimatorWith::configure`] (or [`EstimatorWith::new`]) succeeded.
    pub fn is_configured(&self) -> bool {
        self.configured
    }

    /// Fits the camera path: built by [`FrontEnd::with_capacity`] from `config` and
    /// the caller's `buffers`, then moved in; on an error the estimator has
    /// no camera path.
    pub fn fit_frontend(
        &mut self,
        config: FrontEndConfig,
        buffers: FrontEndBuffers<'b>,
    ) -> Result<(), FrontEndError> {
        self.frontend = None;
        self.frontend = Some(FrontEnd::with_capacity(config, buffers)?);
        Ok(())
    }

    /// Offers an IMU sample.
    pub fn offer_imu(&mut self, s: RawImuSample) {
        self.offer(Event::Imu(s));
    }

    /// Offers cumulative wheel counts.
    pub fn offer_wheel(&mut self, s: WheelTicks) {
        self.offer(Event::Wheel(s));
    }

    /// Offers wheel angular rates (a robot that reports rates, not counts;
    /// the wheel stream, fused like counts).
    pub fn offer_wheel_rates(&mut self, s: RawWheelRates) {
        self.offer(Event::WheelRates(s));
    }

    /// Offers a flow report.
    pub fn offer_flow(&mut self, s: FlowSample) {
        self.offer(Event::Flow(s));
    }

    /// Offers a sample of any buffered stream. A sample that comes too late
    /// for the ordering window is rejected and counted as out of order.
    pub fn offer(&mut self, event: Event) {
        if !self.configured {
            let p = self.reject(event, Reject::NotReady);
            self.queue(p);
            return;
        }
        match self.reorder.push(event) {
            Ok(Pushed::Held) => {}
            Ok(Pushed::HeldReleasing(oldest)) => {
                let p = self.process(oldest);
                self.queue(p);
            }
            Err((reason, late)) => {
                let p = self.reject(late, reason);
                self.queue(p);
            }
        }
    }

    /// Counts a read of `stream` at `t` that failed before it produced a
    /// sample (a bus error, a parity or product-id check, a counter jump):
    /// the driver's error, turned into its reason, lands in the stream's
    /// tally like a rejected sample, so the counts hold every read. The
    /// filter's state is not touched. A wheel read missed on the bus or
    /// refused by its integrity check ([`Reject::Bus`],
    /// [`Reject::Integrity`]) never reached the counter extension: the
    /// counts continue across it, and the odometry step that spans it is
    /// kept when it continues the previous one
    /// ([`DiffDriveOdometry::read_missed`]). Any other failed wheel read (a
    /// counter jump the extension refused, [`Reject::OutOfRange`]) breaks
    /// the count stream, so no odometry step spans `t`
    /// ([`DiffDriveOdometry::read_failed`]).
    pub fn reject_read(&mut self, stream: Stream, t: Timestamp, reason: Reject) {
        self.counts[stream].rejected_one(reason);
        if stream == Stream::Wheel {
            match reason {
                Reject::Bus | Reject::Integrity => self.odometry.read_missed(t),
                _ => self.odometry.read_failed(t),
            }
        }
    }

    /// Processes the next sample whose ordering window has passed (all of
    /// them after [`Estimator::finish`]).
    pub fn poll(&mut self) -> Option<Processed> {
        if let Some(p) = self.pending.pop_front() {
            return Some(p);
        }
        let next = if self.ended {
            self.reorder.pop_any()
        } else {
            self.reorder.pop_ready()
        };
        next.map(|e| self.process(e))
    }

    /// Processes the next buffered sample at or before `t`, waited or not.
    pub fn poll_until(&mut self, t: Timestamp) -> Option<Processed> {
        if let Some(p) = self.pending.pop_front() {
            return Some(p);
        }
        self.reorder.pop_until(t).map(|e| self.process(e))
    }

    /// No more samples will come: [`Estimator::poll`] drains the buffer.
    pub fn finish(&mut self) {
        self.ended = true;
    }

    /// Processes an upward-camera frame taken at `t` (after every buffered
    /// sample up to `t`). Gives the scale decision of the frame pair, `None`
    /// for a first frame, or the reason the frame was not used.
    pub fn process_camera(
        &mut self,
        t: Timestamp,
        image: &ImageView<'_>,
    ) -> Result<Option<FrameDecision>, Reject> {
        while self.poll_until(t).is_some() {}
        let Some(frontend) = self.frontend.as_mut() else {
            // No camera path fitted: the frame is counted, not lost.
            self.counts[Stream::Camera].rejected_one(Reject::NotReady);
            return Err(Reject::NotReady);
        };
        // The floor's grip under the wheels sets how far the scale pipeline
        // trusts them (grips are in (0, 1]; a refusal keeps the last one).
        if let Some(s) = &self.surface {
            let _ = self.scale.set_wheel_grip(s.grip_params(t).grip());
        }
        let processed = probed(&mut self.probe, Part::FrontEnd, || {
            frontend.process(t, image)
        });
        let Some(motion) = processed? else {
            return Ok(None);
        };
        // The frame pair is counted once, by the camera path.
        self.fuse_camera_motion(&motion).map(Some)
    }

    /// Processes a frame pair's camera motion measured outside the
    /// estimator (another front end, a recorded log) as
    /// [`EstimatorWith::process_camera`] processes its front end's, after
    /// every buffered sample up to the pair's second frame. Gives the scale
    /// decision, or the reason the pair was not used; counted under
    /// [`Stream::Camera`].
    pub fn process_camera_motion(
        &mut self,
        motion: &CameraMotion,
    ) -> Result<FrameDecision, Reject> {
        let t = motion.t1();
        while self.poll_until(t).is_some() {}
        let outcome = if self.configured {
            self.set_wheel_grip(t);
            self.fuse_camera_motion(motion)
        } else {
            Err(Reject::NotReady)
        };
        self.counts[Stream::Camera].record(outcome.map(|_| ()));
        outcome
    }

    /// The floor's grip under the wheels at `t` into the scale pipeline,
    /// as [`EstimatorWith::process_camera`] sets it.
    fn set_wheel_grip(&mut self, t: Timestamp) {
        if let Some(s) = &self.surface {
            let _ = self.scale.set_wheel_grip(s.grip_params(t).grip());
        }
    }

    /// A frame pair's `motion` into the scale pipeline, the disagreement
    /// check and the EKF; the pair's verdicts into the wheels' distrust.
    fn fuse_camera_motion(&mut self, motion: &CameraMotion) -> Result<FrameDecision, Reject> {
        let decision = probed(&mut self.probe, Part::ScaleCamera, || {
            self.scale.push_camera(motion)
        })?;
        let scale = filter_scale(&decision);
        // Each sensor against the filter's motion over the pair, before
        // the pair is fused ([`crate::disagreement`]).
        let _ = probed(&mut self.probe, Part::Disagreement, || {
            Ok::<_, ()>(self.disagreement.on_frame(
                &self.ekf,
                motion,
                &decision,
                scale,
                &mut self.scale,
            ))
        });
        // The memory's weights where the robot is now hold in the EKF until
        // the next frame (weights lie in (0, 1]; a refusal keeps the last).
        let _ = self.ekf.set_sensor_weights(SensorWeights {
            imu: decision.imu_weight,
            wheel: decision.wheel_weight,
            flow: decision.flow_weight,
        });
        // The EKF counts its own outcome (`EgoEkf::camera_counts`). The
        // camera's memory weight here inflates its noise.
        let _ = probed(&mut self.probe, Part::FuseCamera, || {
            self.ekf
                .fuse_camera_weighted(motion, scale, decision.camera_weight)
        });
        // The scale pipeline's slip and wheel-outlier verdicts set the EKF's
        // wheel noise over the next interval (a factor the filter refuses
        // changes nothing).
        if let Some((until, factor)) = self
            .wheel_distrust
            .and_then(|f| wheel_distrust(&decision, f))
        {
            let _ = self.ekf.distrust_wheels_until(until, factor);
        }
        Ok(decision)
    }

    /// Processes one raw frame of the flow sensor grabbed at `t`, as the
    /// caller's [`FrameFlow`](vslam_core::flow_frames::FrameFlow) tracked it
    /// against the previous frame (`None`: the first frame, nothing to
    /// compare with), after every buffered sample up to `t`: the features'
    /// robust displacement becomes the scale pipeline's flow transaction `To`
    /// ([`ScalePipeline::push_raw_flow`], with the counting optics' height and
    /// mounting). Counted under [`Stream::FlowFrame`].
    pub fn process_flow_frame(
        &mut self,
        t: Timestamp,
        pair: Option<&FramePairMotion>,
    ) -> Result<FlowStep, Reject> {
        while self.poll_until(t).is_some() {}
        let optics = self
            .scale
            .config()
            .flow_optics
            .as_ref()
            .and_then(raw_optics);
        let outcome = match (pair, optics) {
            (Some(pair), Some(optics)) => {
                self.scale
                    .push_raw_flow(pair.t0, pair.t1, pair.features(), &optics)
            }
            _ => Err(Reject::NotReady),
        };
        self.counts[Stream::FlowFrame].record(outcome.map(|_| ()));
        outcome
    }

    /// Processes a segmentation map of the forward camera taken at `t`.
    pub fn process_segmentation(
        &mut self,
        t: Timestamp,
        labels: &LabelView<'_>,
    ) -> Result<(), Reject> {
        while self.poll_until(t).is_some() {}
        let speed = self.forward_speed();
        let outcome = match self.surface.as_mut() {
            None => Err(Reject::NotReady),
            Some(s) => match s.on_segmentation(t, labels, speed) {
                Ok(_) => Ok(()),
                Err(MapError::NoSurface(_)) => Err(Reject::LowQuality),
                Err(MapError::Rejected(r)) => Err(r),
            },
        };
        self.counts[Stream::Segmentation].record(outcome);
        outcome
    }

    fn queue(&mut self, p: Processed) {
        if let Err(p) = self.pending.push_back(p) {
            // The caller did not poll; the oldest record goes, its sample stays counted.
            let _ = self.pending.pop_front();
            let _ = self.pending.push_back(p);
        }
    }

    fn forward_speed(&self) -> f32 {
        if self.ekf.is_initialised() {
            self.ekf.robot_velocity().x
        } else {
            0.0
        }
    }

    fn reject(&mut self, event: Event, reason: Reject) -> Processed {
        self.counts[event.stream()].rejected_one(reason);
        match event {
            Event::Imu(s) => Processed::Imu {
                t: s.t,
                outcome: Err(reason),
                jolt: None,
            },
            Event::Wheel(WheelTicks { t, .. }) | Event::WheelRates(RawWheelRates { t, .. }) => {
                Processed::Wheel {
                    t,
                    outcome: Err(reason),
                }
            }
            Event::Flow(s) => Processed::Flow {
                t: s.t,
                outcome: Err(reason),
            },
        }
    }

    fn process(&mut self, event: Event) -> Processed {
        match event {
            Event::Imu(raw) => self.process_imu(&raw),
            Event::Wheel(ticks) => {
                let step = probed(&mut self.probe, Part::Odometry, || {
                    self.odometry.update(ticks)
                });
                self.process_wheel(ticks.t, step)
            }
            Event::WheelRates(rates) => {
                let step = probed(&mut self.probe, Part::Odometry, || {
                    self.odometry.update_rates(rates)
                });
                self.process_wheel(rates.t, step)
            }
            Event::Flow(s) => self.process_flow(&s),
        }
    }

    fn process_imu(&mut self, raw: &RawImuSample) -> Processed {
        let cfg = self.ekf.config();
        let outcome = match ImuSample::with_range(raw, cfg.imu.gyro_max, cfg.imu.accel_max) {
            Ok(s) => probed(&mut self.probe, Part::Propagate, || self.ekf.propagate(&s))
                .map(|step| (s, step)),
            Err(reason) => {
                self.ekf.refused_imu_at(raw.t);
                Err(reason)
            }
        };
        let mut jolt = None;
        if let Ok((sample, step)) = &outcome {
            let _ = probed(&mut self.probe, Part::ScaleImu, || {
                self.scale.push_imu(sample)
            });
            let ctx = match &self.surface {
                Some(s) => s.jolt_context(step.t, self.forward_speed()),
                None => JoltContext::from_params(&self.ekf.grip(), None),
            };
            jolt = self
                .jolts
                .push(step.t, step.vertical_deviation, &ctx)
                .ok()
                .flatten();
        }
        let outcome = outcome.map(|(_, step)| step);
        self.record_imu_events(raw.t, &outcome, jolt.as_ref());
        self.counts[Stream::Imu].record(outcome.map(|_| ()));
        Processed::Imu {
            t: raw.t,
            outcome,
            jolt,
        }
    }

    /// What an IMU sample tells the adverse-event memory: a saturated
    /// reading is an IMU event, a suspected obstacle (a collision) a wheel
    /// event; one episode is recorded once ([`ScalePipeline::record_event`]).
    fn record_imu_events(
        &mut self,
        t: Timestamp,
        outcome: &Result<ImuStep, Reject>,
        jolt: Option<&JoltEvent>,
    ) {
        // Times are the samples' own, positions the pipeline's: a refusal
        // (non-finite position) only skips the record.
        if matches!(outcome, Err(Reject::Saturated)) {
            let _ = self
                .scale
                .record_event(SensorKind::Imu, AdverseKind::Saturated, t);
        }
        if let Some(j) = jolt.filter(|j| j.kind.is_obstacle()) {
            let _ = self
                .scale
                .record_event(SensorKind::Wheel, AdverseKind::Collision, j.t);
        }
    }

    /// The odometry's `step` of a wheel sample taken at `t` into the scale
    /// pipeline, the EKF and the surface model.
    fn process_wheel(
        &mut self,
        t: Timestamp,
        step: Result<Option<wheel_odom::odometry::OdometryStep>, Reject>,
    ) -> Processed {
        let outcome = match step {
            Err(r) => Err(r),
            // The first sample only anchors the counts.
            Ok(None) => Err(Reject::NotReady),
            Ok(Some(step)) => {
                if let Some(s) = &self.surface {
                    self.ekf.set_grip(s.grip_params(t));
                }
                let params = self.odometry.params();
                let delta = wheel_distance::corrected_delta(
                    &step.delta,
                    &step.rates,
                    [params.left_radius(), params.right_radius()],
                    self.ekf.wheel_radii(),
                    self.ekf.grip().slip(),
                );
                let _ = probed(&mut self.probe, Part::ScaleWheel, || {
                    self.scale.push_wheel(&delta)
                });
                let fused = probed(&mut self.probe, Part::FuseWheel, || {
                    self.ekf.fuse_wheel(&step.rates)
                });
                if let (Ok(inn), Some(s)) = (&fused, self.surface.as_mut()) {
                    // The learners read the forward row: gated when it was not fused.
                    let forward_gated = !inn.forward_fused;
                    let _ = s.on_wheel_innovation(t, inn.forward, inn.forward_var, forward_gated);
                    let slip_gated = forward_gated
                        && !lowers_slip(
                            inn.forward,
                            inn.forward_var,
                            self.ekf.grip().forward_gate(),
                        );
                    let _ = s.on_wheel_slip(t, inn.forward, inn.speed, slip_gated);
                }
                fused
            }
        };
        // A gated forward part is a gated sample, even though lateral and vertical were fused.
        self.counts[Stream::Wheel].record(match &outcome {
            Ok(inn) if inn.gated => Err(Reject::Gated),
            Ok(_) => Ok(()),
            Err(r) => Err(*r),
        });
        Processed::Wheel { t, outcome }
    }

    fn process_flow(&mut self, s: &FlowSample) -> Processed {
        let _ = probed(&mut self.probe, Part::ScaleFlow, || self.scale.push_flow(s));
        let outcome = probed(&mut self.probe, Part::FuseFlow, || self.ekf.fuse_flow(s)).map(|_| ());
        self.counts[Stream::Flow].record(outcome);
        Processed::Flow { t: s.t, outcome }
    }

    /// The estimate: the pose of the body frame B (mid-axle on the floor)
    /// in the world, its velocity, yaw rate, pose covariance and the aids
    /// that contributed (see [`crate::estimate`]); `None` until the filter
    /// has started (it starts on the first still IMU samples).
    pub fn estimate(&self) -> Option<Estimate> {
        estimate_of(&self.ekf)
    }

    /// The filter.
    pub fn ekf(&self) -> &EgoEkf {
        &self.ekf
    }

    /// The scale pipeline (camera trajectory, decisions, adverse memory).
    pub fn scale(&self) -> &ScalePipeline<TRAJECTORY, SCALE> {
        &self.scale
    }

    /// Replaces the scale pipeline's adverse-event memory with the one in
    /// `record` (written by [`Estimator::export_memory`], e.g. at the end of
    /// an earlier run); a record that is corrupt or was made with other
    /// memory settings is refused and the memory kept
    /// ([`ScalePipeline::restore_memory`]).
    pub fn restore_memory(&mut self, record: &[u8]) -> Result<(), AdverseError> {
        self.scale.restore_memory(record)
    }

    /// Writes the scale pipeline's adverse-event memory into `out` (at least
    /// [`PipelineMemory::RECORD_LEN`](vslam_core::scale::pipeline::PipelineMemory::RECORD_LEN)
    /// bytes) as a record; gives the bytes written.
    pub fn export_memory(&self, out: &mut [u8]) -> Result<usize, AdverseError> {
        self.scale.memory().export(out)
    }

    /// Each sensor's checks against the filter's motion per camera frame
    /// pair ([`crate::disagreement`]).
    pub fn disagreement(&self) -> &DisagreementCheck {
        &self.disagreement
    }

    /// The surface model, if configured.
    pub fn surface(&self) -> Option<&SurfaceModel> {
        self.surface.as_ref()
    }

    /// The jolt monitor (event log and counters).
    pub fn jolts(&self) -> &JoltMonitor<JOLTS> {
        &self.jolts
    }

    /// The camera path, if fitted.
    pub fn frontend(&self) -> Option<&FrontEnd<'b, FEATURES>> {
        self.frontend.as_ref()
    }

    /// Wheel odometry (its own rejection counts included).
    pub fn odometry(&self) -> &DiffDriveOdometry {
        &self.odometry
    }

    /// Per-stream tallies of every sample offered, indexed by [`Stream`]:
    /// the buffered streams, segmentation maps, reads refused by
    /// [`Estimator::reject_read`], and the camera path's frame pairs
    /// ([`FrontEnd::counts`]). A stream the estimator does not take stays
    /// at zero.
    pub fn counts(&self) -> StreamCounts {
        let mut c = self.counts;
        c[Stream::Camera].add(&self.camera_counts());
        c
    }

    /// Camera frame pairs used and refused by the camera path.
    pub fn camera_counts(&self) -> SampleCounts {
        self.frontend
            .as_ref()
            .map(|f| *f.counts())
            .unwrap_or_default()
    }
}

#[cfg(test)]
mod slip_learning_tests {
    use super::lowers_slip;

    /// The slip learner's test of a refused forward row: the chaos hour's
    /// carpet sample (innovation -0.0395 m/s, variance 0.00242, NIS 0.64)
    /// lowers the slip within a gate of 6.63; the same row the other way
    /// (wheels over-counting, as slipping wheels do) does not, nor do
    /// blocked wheels far outside the gate; nothing passes on a variance
    /// that is not positive or on a NaN.
    #[test]
    fn a_refused_row_only_lowers_the_slip_and_only_within_the_gate() {
        assert!(lowers_slip(-0.0395, 0.00242, 6.63));
        assert!(!lowers_slip(0.0395, 0.00242, 6.63));
        assert!(!lowers_slip(-0.3, 0.00242, 6.63));
        assert!(!lowers_slip(0.0, 1e-6, 6.63));
        assert!(!lowers_slip(-0.01, 0.0, 6.63));
        assert!(!lowers_slip(-0.01, -1.0, 6.63));
        assert!(!lowers_slip(f32::NAN, 0.00242, 6.63));
        assert!(!lowers_slip(-0.01, f32::NAN, 6.63));
    }
}

#[cfg(test)]
mod construction_tests {
    extern crate std;

    use super::*;
    use vslam_core::robot::RobotDescription;
    use vslam_core::sensors::RawImuSample;

    fn config() -> EstimatorConfig {
        EstimatorConfig::from_robot(&RobotDescription::robot_vacuum()).unwrap()
    }

    fn feed(est: &mut Estimator<'_>, n: u64) {
        for i in 0..n {
            est.offer_imu(RawImuSample {
                t: Timestamp(i * 4_000_000),
                gyro: [0.001, -0.002, 0.003],
                accel: [0.05, -0.02, 9.81],
            });
            while est.poll().is_some() {}
        }
    }

    /// Configuring in place, even over a used estimator, gives the state
    /// `new` builds, and both run on identically.
    #[test]
    fn configure_in_place_matches_new() {
        let c = config();
        let mut fresh = Estimator::new(&c, None).unwrap();
        let mut reused: Estimator<'static> = Estimator::unconfigured();
        reused.configure(&c).unwrap();
        feed(&mut reused, 300);
        reused.configure(&c).unwrap();
        let state =
            |e: &Estimator<'_>| std::format!("{:?} {:?} {:?}", e.ekf(), e.scale(), e.counts());
        assert_eq!(state(&fresh), state(&reused));
        feed(&mut fresh, 300);
        feed(&mut reused, 300);
        assert!(fresh.ekf().is_initialised());
        assert_eq!(state(&fresh), state(&reused));
    }

    /// A running-scale window shorter than the configuration's
    /// `robust.min_count` is refused, and the estimator stays unconfigured.
    #[test]
    fn scale_window_must_hold_min_count() {
        let c = config();
        let n = usize::from(c.scale.robust.min_count);
        let mut short: EstimatorWith<'static, 64, 32, 16, 4> = EstimatorWith::unconfigured();
        assert!(n > 4);
        assert_eq!(
            short.configure(&c),
            Err(EstimatorError::Scale(
                vslam_core::scale::PipelineConfigError::OutOfRange("robust.min_count")
            ))
        );
        assert!(!short.is_configured());
        let mut enough: EstimatorWith<'static, 64, 32, 16, 5> = EstimatorWith::unconfigured();
        assert_eq!(n, 5);
        assert!(enough.configure(&c).is_ok());
    }

    /// Readings refused at entry (here not finite) are held over like the
    /// ones the EKF refuses: the reading after them turns the heading by
    /// its own step only, as if the refused ones had been the true rate.
    #[test]
    fn readings_refused_at_entry_are_held_over() {
        let c = config();
        let run = |nan: bool| {
            let mut est = Estimator::new(&c, None).unwrap();
            for i in 0..600u64 {
                // Still, then turning at 0.3 rad/s; from 500, four readings
                // (not finite in the first run) and a spike 0.15 rad/s off.
                let jitter = (i % 3) as f32 * 1e-4;
                let gz = match i {
                    0..300 => 0.0,
                    500..504 if nan => f32::NAN,
                    504 => 0.45,
                    _ => 0.3,
                };
                est.offer_imu(RawImuSample {
                    t: Timestamp(i * 4_000_000),
                    gyro: [jitter, 0.0, gz],
                    accel: [0.0, jitter, 9.81],
                });
                while est.poll().is_some() {}
            }
            assert!(est.ekf().is_initialised());
            (
                est.ekf().attitude().euler_angles().2,
                est.counts()[Stream::Imu],
            )
        };
        let (held, counts) = run(true);
        let (clean, _) = run(false);
        assert_eq!(counts.rejected(Reject::NonFinite), 4);
        // Integrated over the whole 20 ms, the spike would turn it 2.4 mrad
        // more.
        assert!((held - clean).abs() < 1e-4, "{held} against {clean}");
    }

    /// An unconfigured estimator counts every sample as not ready.
    #[test]
    fn unconfigured_refuses_samples() {
        let mut est: EstimatorWith<'static, 4, 2, 1, 1> = EstimatorWith::unconfigured();
        est.offer_imu(RawImuSample {
            t: Timestamp(0),
            gyro: [0.0; 3],
            accel: [0.0, 0.0, 9.81],
        });
        assert!(matches!(
            est.poll(),
            Some(Processed::Imu {
                outcome: Err(Reject::NotReady),
                ..
            })
        ));
        assert_eq!(est.counts()[Stream::Imu].rejected(Reject::NotReady), 1);
        assert!(!est.ekf().is_initialised());
    }
}
