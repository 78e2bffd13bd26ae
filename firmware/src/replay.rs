//! The firmware's run over the embedded sample data, through
//! `traction::Estimator`, shared word for word with the host check
//! (`crates/host-sim/tests/firmware_match.rs` includes this file by
//! `#[path]`), so the firmware and the host run the same code on the same
//! bytes.
//!
//! - [`run`]: the estimator is configured in place from the sample's header
//!   ([`EstimatorConfig::from_robot`]); every IMU, wheel and flow record goes
//!   in through `offer` and out through `poll`, every camera motion through
//!   `process_camera_motion` (after polling up to its time), as a user's
//!   firmware writes it. After each wheel update the waypoint navigator turns
//!   the estimate into a wheel command.
//! - [`run_frontend`]: the same estimator configured again, with the camera
//!   path fitted in the caller's buffers; the embedded 160x120 frames go
//!   through `process_camera`.
//! - [`run_segment`]: the reference floor segmenter on the same frames (not a
//!   part of the estimator, which takes label maps).
//! - [`run_flow_frames`]: the flow sensor's raw 35x35 frames through
//!   `FrameFlow`, the tracker whose pair motions `Estimator::process_flow_frame`
//!   takes (the alternative to the chip's motion counts).
//!
//! Each call of the estimator (and of the navigator and segmenter) is made
//! through a [`Measure`]; inside the estimator, its own probe
//! ([`traction::estimator::Probe`], the type parameter `P`) is called around
//! each part (EKF, odometry, scale pipeline, front end, disagreement check).
//! The firmware measures both (`crate::meter`); the host leaves both empty.

use core::fmt::{self, Write};

use traction::ego_ekf::surface::floor_model::{RowFeatures, cell_features};
use traction::ego_ekf::{EgoEkf, ImuPlausibility};
use traction::estimator::{EstimatorConfig, EstimatorError, EstimatorWith, Part, Probe};
use traction::frontend::{FrontEndBuffers, FrontEndConfig};
use traction::navigate::{Command, NavConfig, Navigator, Point, Policy};
use traction::reorder::Event;
use traction::vslam_core::adverse::SensorKind;
use traction::vslam_core::decompose::PinholeIntrinsics;
use traction::vslam_core::geometry::{Extrinsics, Vec3};
use traction::vslam_core::image::ImageView;
use traction::vslam_core::pose::Pose;
use traction::vslam_core::robot::{
    FlowDescription, ImuDescription, ImuNoise, RobotDescription, RobotError, Wheels,
};
use traction::vslam_core::scale::RobustEstimate;
use traction::vslam_core::{PerStream, SampleCounts, Stream, StreamCounts, Timestamp};
use traction::wheel_odom::odometry::DiffDriveOdometry;
use traction::{Estimate, Processed};

use crate::frames;
use crate::sample::{FormatError, Header, Record, open};

/// Recent poses the scale pipeline keeps (as in `traction::Estimator`).
pub const TRAJECTORY: usize = traction::estimator::TRAJECTORY_CAPACITY;

/// The measured calls: the estimator's parts (see [`Step::of`]) and the
/// calls the run makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// `EgoEkf::propagate`: nominal state, 36x36 covariance, clone, ZUPT when due.
    Propagate,
    /// `EgoEkf::fuse_wheel`.
    FuseWheel,
    /// `EgoEkf::fuse_flow`.
    FuseFlow,
    /// `DiffDriveOdometry::update`.
    Odometry,
    /// `ScalePipeline::push_imu`.
    ScaleImu,
    /// `ScalePipeline::push_wheel`.
    ScaleWheel,
    /// `ScalePipeline::push_flow`.
    ScaleFlow,
    /// `ScalePipeline::push_camera`.
    ScaleCamera,
    /// `EgoEkf::fuse_camera_weighted`: the frame pair against the pose clone.
    FuseCamera,
    /// `FrontEnd::process` of one camera frame (pyramid, corners, LK,
    /// RANSAC homography, decomposition).
    FrontEnd,
    /// `FloorModel::segment` of one 160x120 frame into an 80x60 label map
    /// (the reference floor segmenter; its cost does not depend on the
    /// image's content).
    Segment,
    /// `Estimator::estimate` plus `Navigator::command`: the waypoint
    /// navigator's wheel command from the estimate, after each wheel update.
    Navigate,
    /// `Estimator::configure` of the estimator in its static, in place.
    EstConfigure,
    /// `Estimator::offer` of one IMU, wheel or flow sample.
    EstOffer,
    /// `Estimator::poll` (or `poll_until`) that processed a sample.
    EstPoll,
    /// `DisagreementCheck::on_frame` inside the estimator: each sensor
    /// against the EKF per frame pair.
    Disagreement,
    /// `Estimator::process_camera_motion` of one camera motion.
    EstCameraMotion,
    /// `Estimator::process_camera` of one 160x120 frame (the front end and
    /// the rest of the camera path).
    EstCamera,
    /// `FrameFlow::push` of one 35x35 raw flow-sensor frame (high-pass,
    /// whole-frame block match, Shi-Tomasi corners, two-level LK against the
    /// previous frame).
    FlowFrame,
}

impl Step {
    /// Every step, in report order.
    pub const ALL: [Step; 19] = [
        Step::Propagate,
        Step::FuseWheel,
        Step::FuseFlow,
        Step::Odometry,
        Step::ScaleImu,
        Step::ScaleWheel,
        Step::ScaleFlow,
        Step::ScaleCamera,
        Step::FuseCamera,
        Step::FrontEnd,
        Step::Segment,
        Step::Navigate,
        Step::EstConfigure,
        Step::EstOffer,
        Step::EstPoll,
        Step::Disagreement,
        Step::EstCameraMotion,
        Step::EstCamera,
        Step::FlowFrame,
    ];

    /// Position in [`Step::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The step of a part of the estimator.
    pub const fn of(part: Part) -> Step {
        match part {
            Part::Propagate => Step::Propagate,
            Part::FuseWheel => Step::FuseWheel,
            Part::FuseFlow => Step::FuseFlow,
            Part::FuseCamera => Step::FuseCamera,
            Part::Odometry => Step::Odometry,
            Part::ScaleImu => Step::ScaleImu,
            Part::ScaleWheel => Step::ScaleWheel,
            Part::ScaleFlow => Step::ScaleFlow,
            Part::ScaleCamera => Step::ScaleCamera,
            Part::FrontEnd => Step::FrontEnd,
            Part::Disagreement => Step::Disagreement,
        }
    }

    /// Name in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Step::Propagate => "ekf.propagate",
            Step::FuseWheel => "ekf.fuse_wheel",
            Step::FuseFlow => "ekf.fuse_flow",
            Step::Odometry => "odometry.update",
            Step::ScaleImu => "scale.push_imu",
            Step::ScaleWheel => "scale.push_wheel",
            Step::ScaleFlow => "scale.push_flow",
            Step::ScaleCamera => "scale.push_camera",
            Step::FuseCamera => "ekf.fuse_camera",
            Step::FrontEnd => "frontend.process",
            Step::Segment => "segment.floor_model",
            Step::Navigate => "navigate.command",
            Step::EstConfigure => "estimator.configure",
            Step::EstOffer => "estimator.offer",
            Step::EstPoll => "estimator.poll",
            Step::Disagreement => "disagreement.on_frame",
            Step::EstCameraMotion => "estimator.process_camera_motion",
            Step::EstCamera => "estimator.process_camera",
            Step::FlowFrame => "flow_frames.push",
        }
    }

    /// A call of `traction::Estimator`, held to the estimator's stack limit
    /// (`process_camera` with the front end it runs).
    pub const fn is_estimator(self) -> bool {
        matches!(
            self,
            Step::EstConfigure
                | Step::EstOffer
                | Step::EstPoll
                | Step::EstCameraMotion
                | Step::EstCamera
        )
    }
}

/// Wraps every call the run makes: measure it, or just run it.
pub trait Measure {
    /// Runs `f`, the call `step`; its outcome tells a completed call from
    /// an early refusal.
    fn measure<T, E>(&mut self, step: Step, f: impl FnOnce() -> Result<T, E>) -> Result<T, E>;
}

/// Runs the calls unmeasured (the host).
pub struct Unmeasured;

impl Measure for Unmeasured {
    fn measure<T, E>(&mut self, _step: Step, f: impl FnOnce() -> Result<T, E>) -> Result<T, E> {
        f()
    }
}

/// Why the run could not start or finish.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RunError {
    /// The sample data is malformed.
    Format(FormatError),
    /// The header gives a configuration the filter, odometry or pipeline refuses.
    Config(&'static str),
    /// The header describes an inconsistent robot.
    Robot(RobotError),
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Format(e) => write!(f, "sample data: {e}"),
            RunError::Config(what) => write!(f, "configuration refused: {what}"),
            RunError::Robot(e) => write!(f, "robot description refused: {e}"),
        }
    }
}

/// The robot the header describes: wheels and encoders, IMU noise, every
/// `T_BS`, the flow optics; rim speed, wheel path noise and flow noise of the
/// robot-vacuum preset ([`RobotDescription::robot_vacuum`]).
pub fn robot(h: &Header) -> Result<RobotDescription, RunError> {
    let extrinsics =
        |m: &[f32; 16], what| Extrinsics::from_row_major(m).map_err(|_| RunError::Config(what));
    let preset = RobotDescription::robot_vacuum();
    let [
        accel_density,
        gyro_density,
        accel_random_walk,
        gyro_random_walk,
    ] = h.imu_noise;
    let [radius_left, radius_right] = h.wheel_radius;
    let flow = preset.flow.map(|flow| -> Result<_, RunError> {
        Ok(FlowDescription {
            mount: extrinsics(&h.flow_t_bs, "flow T_BS")?,
            height: h.flow_height,
            counts_per_radian: h.flow_counts_per_radian,
            ..flow
        })
    });
    Ok(RobotDescription {
        wheels: Wheels {
            radius_left,
            radius_right,
            track: h.wheel_base,
            track_factor: 1.0,
            counts_per_revolution: h.ticks_per_revolution,
            ..preset.wheels
        },
        imu: ImuDescription {
            mount: extrinsics(&h.imu_t_bs, "IMU T_BS")?,
            noise: ImuNoise {
                accel_density,
                gyro_density,
                accel_random_walk,
                gyro_random_walk,
            },
        },
        flow: flow.transpose()?,
        camera: Some(extrinsics(&h.camera_t_bs, "camera T_BS")?),
    })
}

/// The estimator's configuration for the header's robot, through
/// [`EstimatorConfig::from_robot`] as `host-sim replay` builds it, the
/// IMU judged as a real one's ([`ImuPlausibility::FIELD`]).
pub fn config(h: &Header) -> Result<EstimatorConfig, RunError> {
    let mut config = EstimatorConfig::from_robot(&robot(h)?).map_err(|e| match e {
        EstimatorError::Robot(e) => RunError::Robot(e),
        _ => RunError::Config("estimator"),
    })?;
    // A real IMU: a reading repeated bit for bit is a frozen output.
    config.filter.imu.plausibility = Some(ImuPlausibility::FIELD);
    Ok(config)
}

/// What the run ends with: the state the firmware prints and the host
/// compares.
#[derive(Clone, Debug)]
pub struct Summary {
    /// The estimator's filter after the last record.
    pub ekf: EgoEkf,
    /// Its odometry.
    pub odometry: DiffDriveOdometry,
    /// The scale pipeline's running scale.
    pub running: Option<RobustEstimate>,
    /// The scale pipeline's body pose (the scaled camera trajectory).
    pub body_pose: Pose,
    /// The scale pipeline's tallies per sensor, in [`SCALE_SENSORS`] order.
    pub scale_counts: [SampleCounts; 4],
    /// The estimate after the last record.
    pub estimate: Option<Estimate>,
    /// The estimator's per-stream counts.
    pub counts: StreamCounts,
    /// Records of each stream (the sample format carries IMU, wheel, flow
    /// and camera records; the other streams stay at zero).
    pub records: PerStream<u32>,
    /// Samples `poll` gave back.
    pub processed: u32,
    /// Camera motions that got a scale.
    pub scaled_frames: u32,
    /// Navigator commands computed.
    pub nav_commands: u32,
    /// The navigator's last command.
    pub nav_command: Command,
}

/// The scale pipeline's sensors in [`Summary::scale_counts`] and the names
/// of their tallies.
pub const SCALE_SENSORS: [(SensorKind, &str); 4] = [
    (SensorKind::Wheel, "scale.wheel_counts"),
    (SensorKind::Flow, "scale.flow_counts"),
    (SensorKind::Camera, "scale.camera_counts"),
    (SensorKind::Imu, "scale.imu_counts"),
];

/// The navigator's route over the sample's drive (the office's first leg):
/// metres in the start pose's frame.
pub const NAV_ROUTE: [Point; 2] = [[3.0, 0.0], [6.0, 0.3]];

/// The run's navigator and its tallies.
struct Nav {
    nav: Navigator<4>,
    commands: u32,
    last: Command,
    processed: u32,
}

impl Nav {
    /// After a processed sample: a wheel update gets a wheel command.
    fn on<const R: usize, const T: usize, const J: usize, const W: usize, P: Probe>(
        &mut self,
        p: &Processed,
        est: &EstimatorWith<'_, R, T, J, W, P>,
        m: &mut impl Measure,
    ) {
        self.processed += 1;
        if !matches!(p, Processed::Wheel { outcome: Ok(_), .. }) {
            return;
        }
        let nav = &mut self.nav;
        let command = m.measure(Step::Navigate, || {
            est.estimate().map(|e| nav.command(&e, None).0).ok_or(())
        });
        if let Ok(c) = command {
            self.commands += 1;
            self.last = c;
        }
    }
}

/// Polls `est` (every sample ready, or with `until` every sample up to that
/// time), each processed sample to the navigator.
fn drain<const R: usize, const T: usize, const J: usize, const W: usize, P: Probe>(
    est: &mut EstimatorWith<'_, R, T, J, W, P>,
    until: Option<Timestamp>,
    nav: &mut Nav,
    m: &mut impl Measure,
) {
    loop {
        let polled = m.measure(Step::EstPoll, || {
            match until {
                Some(t) => est.poll_until(t),
                None => est.poll(),
            }
            .ok_or(())
        });
        match polled {
            Ok(p) => nav.on(&p, est, m),
            Err(()) => return,
        }
    }
}

/// Configures `est` in place from the sample's header and feeds it every
/// record of `data`: IMU, wheel and flow through `offer` and `poll`, camera
/// motions through `process_camera_motion`; every call through `m`.
pub fn run<const R: usize, const T: usize, const J: usize, const W: usize, P: Probe>(
    data: &[u8],
    est: &mut EstimatorWith<'_, R, T, J, W, P>,
    m: &mut impl Measure,
) -> Result<Summary, RunError> {
    let (header, records) = open(data).map_err(RunError::Format)?;
    let cfg = config(&header)?;
    m.measure(Step::EstConfigure, || est.configure(&cfg))
        .map_err(|_| RunError::Config("estimator"))?;
    let mut nav = Nav {
        nav: Navigator::new(NavConfig::default(), Policy::FloorAware, &NAV_ROUTE)
            .map_err(|_| RunError::Config("navigator"))?,
        commands: 0,
        last: Command::default(),
        processed: 0,
    };
    let mut records_of = PerStream::splat(0u32);
    let mut scaled_frames = 0u32;
    for record in records {
        let record = record.map_err(RunError::Format)?;
        records_of[record.stream()] += 1;
        let event = match record {
            Record::Imu(raw) => Event::Imu(raw),
            Record::Wheel(ticks) => Event::Wheel(ticks),
            Record::Flow(s) => Event::Flow(s),
            Record::Camera(motion) => {
                // The samples up to the pair's end first, so that each
                // wheel update reaches the navigator.
                drain(est, Some(motion.t1()), &mut nav, m);
                let d = m.measure(Step::EstCameraMotion, || est.process_camera_motion(&motion));
                if matches!(d, Ok(ref d) if d.scale.is_ok()) {
                    scaled_frames += 1;
                }
                continue;
            }
        };
        let _ = m.measure(Step::EstOffer, || {
            est.offer(event);
            Ok::<(), ()>(())
        });
        drain(est, None, &mut nav, m);
    }
    est.finish();
    drain(est, None, &mut nav, m);
    let scale = est.scale();
    Ok(Summary {
        ekf: est.ekf().clone(),
        odometry: *est.odometry(),
        running: scale.running_scale(),
        body_pose: scale.body_pose(),
        scale_counts: SCALE_SENSORS.map(|(kind, _)| scale.counts(kind)),
        estimate: est.estimate(),
        counts: est.counts(),
        records: records_of,
        processed: nav.processed,
        scaled_frames,
        nav_commands: nav.commands,
        nav_command: nav.last,
    })
}

/// What the camera path made of the embedded frames.
#[derive(Clone, Copy, Debug)]
pub struct FrontEndRun {
    /// Frames processed.
    pub frames: u32,
    /// Frame pairs that gave a scale decision.
    pub pairs: u32,
    /// The last pair's statistics (tracked, inliers, RMS error).
    pub last: Option<traction::frontend::FrameStats>,
    /// The last pair's camera baseline `|T|` (over the plane distance).
    pub baseline: Option<f32>,
    /// The camera stream's tallies.
    pub counts: SampleCounts,
}

/// Configures `est` again, fits the camera path in the caller's `buffers`
/// and runs the embedded frames through `process_camera`, every call
/// through `m`.
pub fn run_frontend<
    'b,
    const R: usize,
    const T: usize,
    const J: usize,
    const W: usize,
    P: Probe,
>(
    frame_data: &[u8],
    header: &Header,
    est: &mut EstimatorWith<'b, R, T, J, W, P>,
    buffers: FrontEndBuffers<'b>,
    m: &mut impl Measure,
) -> Result<FrontEndRun, RunError> {
    let (h, frames) =
        frames::open(frame_data).ok_or(RunError::Format(FormatError::NotSampleData))?;
    let [fu, fv, cu, cv] = h.intrinsics;
    let k = PinholeIntrinsics::new(fu, fv, cu, cv).map_err(|_| RunError::Config("intrinsics"))?;
    let mount = Extrinsics::from_row_major(&header.camera_t_bs)
        .map_err(|_| RunError::Config("camera T_BS"))?;
    let cfg = config(header)?;
    m.measure(Step::EstConfigure, || est.configure(&cfg))
        .map_err(|_| RunError::Config("estimator"))?;
    est.fit_frontend(FrontEndConfig::new(h.width, h.height, k, mount), buffers)
        .map_err(|_| RunError::Config("front-end buffers"))?;
    let mut run = FrontEndRun {
        frames: 0,
        pairs: 0,
        last: None,
        baseline: None,
        counts: SampleCounts::new(),
    };
    for (t, pixels) in frames {
        let view = ImageView::new(pixels, h.width, h.height, h.width)
            .map_err(|_| RunError::Format(FormatError::Truncated))?;
        run.frames += 1;
        if let Ok(Some(d)) = m.measure(Step::EstCamera, || est.process_camera(t, &view)) {
            run.pairs += 1;
            run.baseline = Some(d.baseline);
        }
    }
    run.last = est.frontend().and_then(|f| f.last_stats());
    run.counts = est.counts()[Stream::Camera];
    Ok(run)
}

impl FrontEndRun {
    /// Every printed quantity: `(name, values)`.
    pub fn for_each(&self, f: &mut dyn FnMut(&str, &[Value])) {
        f(
            "frontend.frames",
            &[Value::N(self.frames), Value::N(self.pairs)],
        );
        f(
            "frontend.counts",
            &[
                Value::N(self.counts.fused()),
                Value::N(self.counts.rejected_total()),
            ],
        );
        match self.last {
            Some(s) => f(
                "frontend.last_pair",
                &[
                    Value::N(u32::from(s.tracked)),
                    Value::N(u32::from(s.inliers)),
                    Value::F(s.rms_px),
                    Value::N(u32::from(s.pure_rotation)),
                ],
            ),
            None => f("frontend.last_pair", &[]),
        }
        match self.baseline {
            Some(b) => f("frontend.baseline", &[Value::F(b)]),
            None => f("frontend.baseline", &[]),
        }
    }

    /// Writes one line `result NAME V...` per quantity.
    pub fn write(&self, out: &mut dyn Write) -> fmt::Result {
        write_results(out, |f| self.for_each(f))
    }
}

/// Label maps made by [`run_segment`]: how many, the cells of each class
/// summed over them, a hash of every label, and the check of the model's
/// scores against the reference ones.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SegmentRun {
    /// Frames labelled.
    pub maps: u32,
    /// Cells per class id, over every map.
    pub classes: [u32; FLOOR_CLASSES],
    /// FNV-1a (32 bits) of every map's labels in order: the host and the
    /// firmware label every cell alike only if these agree.
    pub map_hash: u32,
    /// Feature vectors whose scores were checked (every cell of every
    /// frame, features computed pixel by pixel, and seeded draws around
    /// the training statistics).
    pub scores_checked: u32,
    /// Of those, how many had scores from the model in use
    /// (`FloorModel::table`, on Cortex-M the `VLDM` kernel) whose bits
    /// differ from the reference `MlpWeights::scores`.
    pub score_mismatches: u32,
}

/// Seeded feature draws of [`run_segment`]'s score check.
const SCORE_DRAWS: u32 = 2_000;

/// Class ids of the reference floor model.
pub const FLOOR_CLASSES: usize = traction::ego_ekf::surface::floor_model::CLASSES;

/// Labels every frame of `frame_data` with the reference floor model into
/// `map` (at least a quarter of a frame: the model labels 2x2 cells), its
/// window sums' tables in `tables`.
pub fn run_segment(
    frame_data: &[u8],
    map: &mut [u8],
    tables: &mut RowFeatures,
    m: &mut impl Measure,
) -> Result<SegmentRun, RunError> {
    use traction::ego_ekf::surface::FloorModel;
    use traction::vslam_core::segment::Segmenter;
    let (h, frames) =
        frames::open(frame_data).ok_or(RunError::Format(FormatError::NotSampleData))?;
    let model = FloorModel::reference();
    let (w, hh) = model
        .map_size(h.width, h.height)
        .map_err(|_| RunError::Config("segmentation map size"))?;
    let cells = map
        .get(..w.saturating_mul(hh))
        .map(<[u8]>::len)
        .ok_or(RunError::Config("segmentation map buffer"))?;
    let mut run = SegmentRun {
        map_hash: FNV_OFFSET,
        ..SegmentRun::default()
    };
    for (_, pixels) in frames {
        let view = ImageView::new(pixels, h.width, h.height, h.width)
            .map_err(|_| RunError::Format(FormatError::Truncated))?;
        m.measure(Step::Segment, || {
            model
                .segment_with(&view, &mut *map, &mut *tables)
                .map(|_| ())
        })
        .map_err(|_| RunError::Config("segmentation map buffer"))?;
        run.maps += 1;
        for &c in map.get(..cells).unwrap_or(&[]) {
            if let Some(n) = run.classes.get_mut(usize::from(c)) {
                *n += 1;
            }
            run.map_hash = (run.map_hash ^ u32::from(c)).wrapping_mul(FNV_PRIME);
        }
        // Outside the measured call: every cell's scores against the
        // reference's.
        for cy in 0..hh {
            for cx in 0..w {
                run.check_scores(&model, &cell_features(&view, cx, cy));
            }
        }
    }
    // Draws around the training statistics (xorshift32), so that hidden
    // units switch on and off in many patterns.
    let weights = model.weights();
    let mut s = 0x2545_f491u32;
    for _ in 0..SCORE_DRAWS {
        let mut f = [0.0f32; FLOOR_FEATURES];
        for (fi, (m, sc)) in f.iter_mut().zip(weights.mean.iter().zip(&weights.scale)) {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let u = (s >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0;
            *fi = m + 3.0 * u / sc;
        }
        run.check_scores(&model, &f);
    }
    Ok(run)
}

/// The FNV-1a offset basis and prime (32 bits).
const FNV_OFFSET: u32 = 0x811c_9dc5;
const FNV_PRIME: u32 = 0x0100_0193;

/// Features of the reference floor model.
const FLOOR_FEATURES: usize = traction::ego_ekf::surface::floor_model::FEATURES;

impl SegmentRun {
    /// Counts `f`, and a mismatch if the model's scores differ in any bit
    /// from the reference's.
    fn check_scores(
        &mut self,
        model: &traction::ego_ekf::surface::FloorModel,
        f: &[f32; FLOOR_FEATURES],
    ) {
        let used = model.table().scores(f);
        let reference = model.weights().scores(f);
        self.scores_checked += 1;
        if used.map(f32::to_bits) != reference.map(f32::to_bits) {
            self.score_mismatches += 1;
        }
    }
}

/// Raw flow frames tracked by [`run_flow_frames`]: pairs, how they ended,
/// and the tracked features' displacements summed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlowFramesRun {
    /// Frames pushed.
    pub frames: u32,
    /// Pairs with a motion (every frame after the first).
    pub pairs: u32,
    /// Pairs refused for want of texture.
    pub textureless: u32,
    /// Corners found in the previous frames, summed over the pairs.
    pub corners: u32,
    /// Features tracked, summed over the pairs.
    pub tracked: u32,
    /// The tracked features' displacements summed, pixels.
    pub sum_dx: f32,
    /// See [`FlowFramesRun::sum_dx`].
    pub sum_dy: f32,
}

/// Tracks every raw frame of `frame_data` (35x35 frames in the format of
/// [`crate::frames`]) against the one before with the raw-frame tracker's
/// default tuning.
pub fn run_flow_frames(frame_data: &[u8], m: &mut impl Measure) -> Result<FlowFramesRun, RunError> {
    use traction::vslam_core::flow_frames::{FrameFlow, FrameFlowConfig};
    use traction::vslam_core::sensors::{FLOW_FRAME_LEN, FLOW_FRAME_SIDE};
    let (h, frames) =
        frames::open(frame_data).ok_or(RunError::Format(FormatError::NotSampleData))?;
    if (h.width, h.height) != (FLOW_FRAME_SIDE, FLOW_FRAME_SIDE) {
        return Err(RunError::Config("raw flow frames are 35x35"));
    }
    let mut tracker = FrameFlow::new(FrameFlowConfig::default())
        .map_err(|_| RunError::Config("raw-frame tracker"))?;
    let mut run = FlowFramesRun::default();
    for (t, pixels) in frames {
        let frame: &[u8; FLOW_FRAME_LEN] = pixels
            .try_into()
            .map_err(|_| RunError::Format(FormatError::Truncated))?;
        run.frames += 1;
        let pair = m
            .measure(Step::FlowFrame, || tracker.push(t, frame))
            .map_err(|_| RunError::Config("raw flow frames out of time order"))?;
        let Some(pair) = pair else { continue };
        run.pairs += 1;
        run.textureless += u32::from(pair.textureless);
        run.corners += pair.corners as u32;
        for f in pair.features() {
            run.tracked += 1;
            run.sum_dx += f.dx;
            run.sum_dy += f.dy;
        }
    }
    Ok(run)
}

impl FlowFramesRun {
    /// Every printed quantity: `(name, values)`.
    pub fn for_each(&self, f: &mut dyn FnMut(&str, &[Value])) {
        f(
            "flow_frames.pairs",
            &[
                Value::N(self.frames),
                Value::N(self.pairs),
                Value::N(self.textureless),
            ],
        );
        f(
            "flow_frames.features",
            &[Value::N(self.corners), Value::N(self.tracked)],
        );
        f(
            "flow_frames.sum_displacement",
            &[Value::F(self.sum_dx), Value::F(self.sum_dy)],
        );
    }

    /// Writes one line `result NAME V...` per quantity.
    pub fn write(&self, out: &mut dyn Write) -> fmt::Result {
        write_results(out, |f| self.for_each(f))
    }
}

impl SegmentRun {
    /// Every printed quantity: `(name, values)`.
    pub fn for_each(&self, f: &mut dyn FnMut(&str, &[Value])) {
        f("segment.maps", &[Value::N(self.maps)]);
        let mut v = [Value::N(0); FLOOR_CLASSES];
        for (slot, &n) in v.iter_mut().zip(self.classes.iter()) {
            *slot = Value::N(n);
        }
        f("segment.classes", &v);
        f("segment.map_hash", &[Value::N(self.map_hash)]);
        f(
            "segment.scores_checked",
            &[
                Value::N(self.scores_checked),
                Value::N(self.score_mismatches),
            ],
        );
    }

    /// Writes one line `result NAME V...` per quantity.
    pub fn write(&self, out: &mut dyn Write) -> fmt::Result {
        write_results(out, |f| self.for_each(f))
    }
}

/// Writes `result NAME V...` lines for every quantity `for_each` gives.
pub fn write_results(
    out: &mut dyn Write,
    for_each: impl FnOnce(&mut dyn FnMut(&str, &[Value])),
) -> fmt::Result {
    let mut result = Ok(());
    for_each(&mut |name, values| {
        if result.is_err() {
            return;
        }
        result = (|| {
            write!(out, "result {name}")?;
            for v in values {
                match v {
                    Value::F(x) => write!(out, " {x:e}")?,
                    Value::N(n) => write!(out, " {n}")?,
                }
            }
            writeln!(out)
        })();
    });
    result
}

/// One printed value: a float compared within tolerance, or an integer
/// compared exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A float.
    F(f32),
    /// A count.
    N(u32),
}

impl Summary {
    /// Every printed quantity: `(name, values)`.
    pub fn for_each(&self, f: &mut dyn FnMut(&str, &[Value])) {
        f(
            "navigate.command",
            &[
                Value::N(self.nav_commands),
                Value::F(self.nav_command.v),
                Value::F(self.nav_command.w),
            ],
        );
        let e = &self.ekf;
        let v3 = |v: Vec3| [Value::F(v.x), Value::F(v.y), Value::F(v.z)];
        let q = e.attitude();
        let counts = |c: &SampleCounts| {
            [
                Value::N(c.fused()),
                Value::N(c.gated()),
                Value::N(c.rejected_total()),
            ]
        };
        f("ekf.position", &v3(e.position()));
        f("ekf.velocity", &v3(e.velocity()));
        f(
            "ekf.attitude_wxyz",
            &[Value::F(q.w), Value::F(q.i), Value::F(q.j), Value::F(q.k)],
        );
        let [l, r] = e.wheel_radii();
        f("ekf.wheel_radii", &[Value::F(l), Value::F(r)]);
        f("ekf.accel_bias", &v3(e.accel_bias()));
        f("ekf.gyro_bias", &v3(e.gyro_bias()));
        f("ekf.position_std", &v3(e.position_std()));
        match self.estimate {
            Some(est) => {
                f("estimator.position", &v3(est.p_wb));
                f("estimator.velocity", &v3(est.v_b));
            }
            None => {
                f("estimator.position", &[]);
                f("estimator.velocity", &[]);
            }
        }
        match self.running {
            Some(s) => f(
                "scale.running",
                &[
                    Value::F(s.scale),
                    Value::F(s.sigma),
                    Value::N(u32::from(s.count)),
                ],
            ),
            None => f("scale.running", &[]),
        }
        let b = &self.body_pose;
        f("scale.body_position", &v3(b.translation.vector));
        let bq = b.rotation;
        f(
            "scale.body_attitude_wxyz",
            &[
                Value::F(bq.w),
                Value::F(bq.i),
                Value::F(bq.j),
                Value::F(bq.k),
            ],
        );
        f("scale.scaled_frames", &[Value::N(self.scaled_frames)]);
        self.each_count(&mut |name, c| f(name, &counts(c)));
        f("records", &self.records.as_array().map(Value::N));
        f("estimator.processed", &[Value::N(self.processed)]);
    }

    /// Every tally of the run: `(name, counts)`.
    pub fn each_count(&self, f: &mut dyn FnMut(&str, &SampleCounts)) {
        let e = &self.ekf;
        f("ekf.imu_counts", e.imu_counts());
        f("ekf.wheel_counts", e.wheel_counts());
        f("ekf.flow_counts", e.flow_counts());
        f("ekf.zupt_counts", e.zupt_counts());
        f("ekf.floor_counts", e.floor_counts());
        f("ekf.camera_counts", e.camera_counts());
        for ((_, name), c) in SCALE_SENSORS.iter().zip(self.scale_counts.iter()) {
            f(name, c);
        }
        f("odometry.counts", self.odometry.counts());
        for (stream, name) in [
            (Stream::Imu, "estimator.imu_counts"),
            (Stream::Wheel, "estimator.wheel_counts"),
            (Stream::Flow, "estimator.flow_counts"),
            (Stream::Camera, "estimator.camera_counts"),
        ] {
            f(name, &self.counts[stream]);
        }
    }

    /// Writes one line `counts NAME fused F, gated G, rejected: REASON N, ...`
    /// per tally: the counts with their reason names, for a reader (the
    /// `result` lines carry the same numbers for the host comparison).
    pub fn write_counts(&self, out: &mut dyn Write) -> fmt::Result {
        let mut result = Ok(());
        self.each_count(&mut |name, c| {
            if result.is_ok() {
                result = writeln!(out, "counts {name} {c}");
            }
        });
        result
    }

    /// Writes one line `result NAME V...` per quantity; floats in the
    /// shortest form that reads back to the same `f32`.
    pub fn write(&self, out: &mut dyn Write) -> fmt::Result {
        write_results(out, |f| self.for_each(f))
    }
}
