//! The firmware's estimation loop over the embedded sample data, shared
//! word for word with the host check (`crates/host-sim/tests/firmware_match.rs` includes this
//! file by `#[path]`), so the firmware and the host run the same code on the
//! same bytes.
//!
//! Per record, in stream order, as `traction::Estimator` does it (without the
//! surface model and jolt monitor, which need segmentation maps):
//!
//! - IMU: validated with the filter's range, [`EgoEkf::propagate`] (250 Hz),
//!   then the scale pipeline's IMU window;
//! - wheel counts: `wheel-odom` odometry, the scale pipeline's wheel window,
//!   [`EgoEkf::fuse_wheel`] (the wheel rate, 50 Hz);
//! - flow report: the scale pipeline's flow window, [`EgoEkf::fuse_flow`];
//! - camera motion: [`ScalePipeline::push_camera`], then
//!   [`EgoEkf::fuse_camera`] with `traction::estimator::filter_scale` (10 Hz).
//!
//! Every call is made through a [`Probe`], which the firmware uses to count
//! instructions and paint the stack, and the host leaves empty.

use core::fmt::{self, Write};

use traction::ego_ekf::{EgoEkf, FilterConfig};
use traction::estimate::estimate_of;
use traction::estimator::{EstimatorConfig, EstimatorError, EstimatorWith, filter_scale};
use traction::frontend::{FrontEnd, FrontEndBuffers, FrontEndConfig};
use traction::navigate::{Command, NavConfig, Navigator, Point, Policy};
use traction::reorder::Event;
use traction::vslam_core::adverse::SensorKind;
use traction::vslam_core::decompose::PinholeIntrinsics;
use traction::vslam_core::geometry::{Extrinsics, Vec3};
use traction::vslam_core::image::ImageView;
use traction::vslam_core::robot::{
    FlowDescription, ImuDescription, ImuNoise, RobotDescription, RobotError, Wheels,
};
use traction::vslam_core::scale::CameraMotion;
use traction::vslam_core::scale::{PipelineConfig, ScalePipeline};
use traction::vslam_core::sensors::ImuSample;
use traction::vslam_core::{PerStream, Reject, SampleCounts, Stream};
use traction::wheel_odom::odometry::{DiffDriveOdometry, DiffDriveParams};

use crate::frames;
use crate::sample::{FormatError, Header, Record, open};

/// Recent poses the scale pipeline keeps (as in `traction::Estimator`).
pub const TRAJECTORY: usize = 32;

/// The calls the loop makes, each measured on its own.
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
    /// `EgoEkf::fuse_camera`: the frame pair against the pose clone.
    FuseCamera,
    /// `FrontEnd::process` of one camera frame (pyramid, corners, LK,
    /// RANSAC homography, decomposition).
    FrontEnd,
    /// `FloorModel::segment` of one 160x120 frame into an 80x60 label map
    /// (the reference floor segmenter; its cost does not depend on the
    /// image's content).
    Segment,
    /// `estimate_of` plus `Navigator::command`: the waypoint navigator's
    /// wheel command from the filter's estimate, after each wheel update.
    Navigate,
    /// `Estimator::configure` of the estimator in its static, in place.
    EstConfigure,
    /// `Estimator::offer` of one IMU, wheel or flow sample.
    EstOffer,
    /// `Estimator::poll` that processed a sample.
    EstPoll,
}

impl Step {
    /// Every step, in report order.
    pub const ALL: [Step; 15] = [
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
    ];

    /// Position in [`Step::ALL`].
    pub const fn index(self) -> usize {
        self as usize
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
        }
    }

    /// A call of `traction::Estimator` (held to the estimator's stack limit).
    pub const fn is_estimator(self) -> bool {
        matches!(self, Step::EstConfigure | Step::EstOffer | Step::EstPoll)
    }
}

/// Wraps every call of the loop: measure it, or just run it.
pub trait Probe {
    /// Runs `f`, the call `step`; its outcome tells a completed call from
    /// an early refusal.
    fn measure<T, E>(&mut self, step: Step, f: impl FnOnce() -> Result<T, E>) -> Result<T, E>;
}

/// A probe that only runs the calls (the host).
pub struct NoProbe;

impl Probe for NoProbe {
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

/// The configurations of the run, derived from the header as `host-sim
/// replay` derives them from an ASL dataset.
pub struct RunConfig {
    /// The EKF.
    pub filter: FilterConfig,
    /// Wheel odometry.
    pub odometry: DiffDriveParams,
    /// The scale pipeline.
    pub scale: PipelineConfig,
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

/// Builds the configurations from the header, through
/// [`EstimatorConfig::from_robot`] as `host-sim replay` does.
pub fn config(h: &Header) -> Result<RunConfig, RunError> {
    let c = EstimatorConfig::from_robot(&robot(h)?).map_err(|e| match e {
        EstimatorError::Robot(e) => RunError::Robot(e),
        _ => RunError::Config("estimator"),
    })?;
    Ok(RunConfig {
        filter: c.filter,
        odometry: c.odometry,
        scale: c.scale,
    })
}

/// What the run ends with: the state the firmware prints and the host
/// compares.
#[derive(Clone, Debug)]
pub struct Summary {
    /// The filter after the last record.
    pub ekf: EgoEkf,
    /// The odometry after the last record.
    pub odometry: DiffDriveOdometry,
    /// The scale pipeline after the last record.
    pub scale: ScalePipeline<TRAJECTORY>,
    /// IMU samples refused by the range check before the filter.
    pub imu_invalid: SampleCounts,
    /// Records of each stream (the sample format carries IMU, wheel, flow
    /// and camera records; the other streams stay at zero).
    pub records: PerStream<u32>,
    /// Camera motions that got a scale.
    pub scaled_frames: u32,
    /// Navigator commands computed, and the last one.
    pub nav_commands: u32,
    /// The navigator's last command.
    pub nav_command: Command,
}

/// The navigator's route over the sample's drive (the office's first leg):
/// metres in the start pose's frame.
pub const NAV_ROUTE: [Point; 2] = [[3.0, 0.0], [6.0, 0.3]];

/// Runs the loop over `data`, every call through `probe`.
pub fn run(data: &[u8], probe: &mut impl Probe) -> Result<Summary, RunError> {
    let (header, records) = open(data).map_err(RunError::Format)?;
    let cfg = config(&header)?;
    let mut ekf = EgoEkf::new(cfg.filter).map_err(|_| RunError::Config("filter"))?;
    let mut odometry = DiffDriveOdometry::new(cfg.odometry);
    let mut scale: ScalePipeline<TRAJECTORY> =
        ScalePipeline::new(cfg.scale).map_err(|_| RunError::Config("scale pipeline"))?;
    let mut imu_invalid = SampleCounts::new();
    let mut counts = PerStream::splat(0u32);
    let mut scaled_frames = 0u32;
    let mut nav: Navigator<4> =
        Navigator::new(NavConfig::default(), Policy::FloorAware, &NAV_ROUTE)
            .map_err(|_| RunError::Config("navigator"))?;
    let (mut nav_commands, mut nav_command) = (0u32, Command::default());
    let (gyro_max, accel_max) = (cfg.filter.imu.gyro_max, cfg.filter.imu.accel_max);
    for record in records {
        let record = record.map_err(RunError::Format)?;
        counts[record.stream()] += 1;
        match record {
            Record::Imu(raw) => match ImuSample::with_range(&raw, gyro_max, accel_max) {
                Ok(s) => {
                    let step = probe.measure(Step::Propagate, || ekf.propagate(&s));
                    if step.is_ok() {
                        let _ = probe.measure(Step::ScaleImu, || scale.push_imu(&s));
                    }
                }
                Err(r) => imu_invalid.rejected_one(r),
            },
            Record::Wheel(ticks) => {
                let step = probe.measure(Step::Odometry, || odometry.update(ticks));
                if let Ok(Some(step)) = step {
                    let _ = probe.measure(Step::ScaleWheel, || scale.push_wheel(&step.delta));
                    let _ = probe.measure(Step::FuseWheel, || ekf.fuse_wheel(&step.rates));
                    let command = probe.measure(Step::Navigate, || {
                        estimate_of(&ekf)
                            .map(|est| nav.command(&est, None).0)
                            .ok_or(())
                    });
                    if let Ok(c) = command {
                        nav_commands += 1;
                        nav_command = c;
                    }
                }
            }
            Record::Flow(s) => {
                let _ = probe.measure(Step::ScaleFlow, || scale.push_flow(&s));
                let _ = probe.measure(Step::FuseFlow, || ekf.fuse_flow(&s));
            }
            Record::Camera(m) => {
                let d = probe.measure(Step::ScaleCamera, || scale.push_camera(&m));
                if matches!(d, Ok(ref d) if d.scale.is_ok()) {
                    scaled_frames += 1;
                }
                if let Ok(d) = d {
                    let scale = filter_scale(&d);
                    let _ = probe.measure(Step::FuseCamera, || ekf.fuse_camera(&m, scale));
                }
            }
        }
    }
    Ok(Summary {
        ekf,
        odometry,
        scale,
        imu_invalid,
        records: counts,
        scaled_frames,
        nav_commands,
        nav_command,
    })
}

/// What `traction::Estimator` made of the sample's IMU, wheel and flow
/// records ([`run_estimator`]).
#[derive(Clone, Debug)]
pub struct EstimatorRun {
    /// Samples processed (each `poll` that gave one).
    pub processed: u32,
    /// Camera motions of the sample not offered (the estimator takes
    /// frames, not motions).
    pub camera_skipped: u32,
    /// The estimate after the last sample.
    pub position: Option<Vec3>,
    /// Its velocity.
    pub velocity: Option<Vec3>,
    /// Per-stream counts: (fused, gated, rejected).
    pub counts: [(u32, u32, u32); 3],
}

/// Configures `est` in place from the sample's header and feeds it every
/// IMU, wheel and flow record through `offer` and `poll`, every call
/// through `probe`; then drains it.
pub fn run_estimator<const R: usize, const T: usize, const J: usize, const W: usize>(
    data: &[u8],
    est: &mut EstimatorWith<'_, R, T, J, W>,
    probe: &mut impl Probe,
) -> Result<EstimatorRun, RunError> {
    let (header, records) = open(data).map_err(RunError::Format)?;
    let config = EstimatorConfig::from_robot(&robot(&header)?).map_err(|e| match e {
        EstimatorError::Robot(e) => RunError::Robot(e),
        _ => RunError::Config("estimator"),
    })?;
    probe
        .measure(Step::EstConfigure, || est.configure(&config))
        .map_err(|_| RunError::Config("estimator"))?;
    let mut run = EstimatorRun {
        processed: 0,
        camera_skipped: 0,
        position: None,
        velocity: None,
        counts: [(0, 0, 0); 3],
    };
    for record in records {
        let record = record.map_err(RunError::Format)?;
        let event = match record {
            Record::Imu(raw) => Event::Imu(raw),
            Record::Wheel(ticks) => Event::Wheel(ticks),
            Record::Flow(s) => Event::Flow(s),
            Record::Camera(_) => {
                run.camera_skipped += 1;
                continue;
            }
        };
        let _ = probe.measure(Step::EstOffer, || {
            est.offer(event);
            Ok::<(), ()>(())
        });
        run.processed += drain(est, probe);
    }
    est.finish();
    run.processed += drain(est, probe);
    let e = est.estimate();
    run.position = e.map(|e| e.p_wb);
    run.velocity = e.map(|e| e.v_b);
    let c = est.counts();
    for (slot, s) in run
        .counts
        .iter_mut()
        .zip([Stream::Imu, Stream::Wheel, Stream::Flow])
    {
        let s = &c[s];
        *slot = (s.fused(), s.gated(), s.rejected_total());
    }
    Ok(run)
}

/// Polls `est` until it has nothing ready; gives the samples processed.
fn drain<const R: usize, const T: usize, const J: usize, const W: usize>(
    est: &mut EstimatorWith<'_, R, T, J, W>,
    probe: &mut impl Probe,
) -> u32 {
    let mut n = 0;
    while probe
        .measure(Step::EstPoll, || est.poll().ok_or(()))
        .is_ok()
    {
        n += 1;
    }
    n
}

impl EstimatorRun {
    /// Every printed quantity: `(name, values)`.
    pub fn for_each(&self, f: &mut dyn FnMut(&str, &[Value])) {
        f(
            "estimator.samples",
            &[Value::N(self.processed), Value::N(self.camera_skipped)],
        );
        let v3 = |v: Option<Vec3>| v.map(|v| [Value::F(v.x), Value::F(v.y), Value::F(v.z)]);
        f(
            "estimator.position",
            &v3(self.position).unwrap_or([Value::N(0); 3]),
        );
        f(
            "estimator.velocity",
            &v3(self.velocity).unwrap_or([Value::N(0); 3]),
        );
        for (name, (a, b, c)) in [
            "estimator.imu_counts",
            "estimator.wheel_counts",
            "estimator.flow_counts",
        ]
        .iter()
        .zip(self.counts)
        {
            f(name, &[Value::N(a), Value::N(b), Value::N(c)]);
        }
    }

    /// Writes one line `result NAME V...` per quantity.
    pub fn write(&self, out: &mut dyn Write) -> fmt::Result {
        write_results(out, |f| self.for_each(f))
    }
}

/// What the camera path made of the embedded frames.
#[derive(Clone, Copy, Debug)]
pub struct FrontEndRun {
    /// Frames processed.
    pub frames: u32,
    /// Camera motions measured.
    pub motions: u32,
    /// The last camera motion.
    pub last: Option<CameraMotion>,
    /// The front end's frame tallies.
    pub counts: SampleCounts,
}

/// Runs traction's camera path (`traction::frontend`) over the embedded
/// frames, in the caller's `buffers`, every frame through `probe`.
pub fn run_frontend(
    frame_data: &[u8],
    header: &Header,
    buffers: FrontEndBuffers<'_>,
    probe: &mut impl Probe,
) -> Result<FrontEndRun, RunError> {
    let (h, frames) =
        frames::open(frame_data).ok_or(RunError::Format(FormatError::NotSampleData))?;
    let [fu, fv, cu, cv] = h.intrinsics;
    let k = PinholeIntrinsics::new(fu, fv, cu, cv).map_err(|_| RunError::Config("intrinsics"))?;
    let mount = Extrinsics::from_row_major(&header.camera_t_bs)
        .map_err(|_| RunError::Config("camera T_BS"))?;
    let config = FrontEndConfig::new(h.width, h.height, k, mount);
    let mut frontend =
        FrontEnd::new(config, buffers).map_err(|_| RunError::Config("front-end buffers"))?;
    let mut run = FrontEndRun {
        frames: 0,
        motions: 0,
        last: None,
        counts: SampleCounts::new(),
    };
    for (t, pixels) in frames {
        let view = ImageView::new(pixels, h.width, h.height, h.width)
            .map_err(|_| RunError::Format(FormatError::Truncated))?;
        run.frames += 1;
        if let Ok(Some(m)) = probe.measure(Step::FrontEnd, || frontend.process(t, &view)) {
            run.motions += 1;
            run.last = Some(m);
        }
    }
    run.counts = *frontend.counts();
    Ok(run)
}

impl FrontEndRun {
    /// Every printed quantity: `(name, values)`.
    pub fn for_each(&self, f: &mut dyn FnMut(&str, &[Value])) {
        f(
            "frontend.frames",
            &[Value::N(self.frames), Value::N(self.motions)],
        );
        f(
            "frontend.counts",
            &[
                Value::N(self.counts.fused()),
                Value::N(self.counts.rejected_total()),
            ],
        );
        match self.last {
            Some(m) => {
                let t = m.t_over_d();
                f(
                    "frontend.t_over_d",
                    &[Value::F(t.x), Value::F(t.y), Value::F(t.z)],
                );
                let q = traction::vslam_core::geometry::Quat::from_rotation_matrix(m.r());
                f(
                    "frontend.rotation_wxyz",
                    &[Value::F(q.w), Value::F(q.i), Value::F(q.j), Value::F(q.k)],
                );
                f(
                    "frontend.inliers",
                    &[Value::N(u32::from(m.inliers())), Value::F(m.residual_px())],
                );
            }
            None => f("frontend.t_over_d", &[]),
        }
    }

    /// Writes one line `result NAME V...` per quantity.
    pub fn write(&self, out: &mut dyn Write) -> fmt::Result {
        write_results(out, |f| self.for_each(f))
    }
}

/// Label maps made by [`run_segment`]: how many, and the cells of each
/// class summed over them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SegmentRun {
    /// Frames labelled.
    pub maps: u32,
    /// Cells per class id, over every map.
    pub classes: [u32; FLOOR_CLASSES],
}

/// Class ids of the reference floor model.
pub const FLOOR_CLASSES: usize = traction::ego_ekf::surface::floor_model::CLASSES;

/// Labels every frame of `frame_data` with the reference floor model into
/// `map` (at least a quarter of a frame: the model labels 2x2 cells).
pub fn run_segment(
    frame_data: &[u8],
    map: &mut [u8],
    probe: &mut impl Probe,
) -> Result<SegmentRun, RunError> {
    use traction::ego_ekf::surface::FloorModel;
    use traction::vslam_core::segment::Segmenter;
    let (h, frames) =
        frames::open(frame_data).ok_or(RunError::Format(FormatError::NotSampleData))?;
    let mut model = FloorModel::reference();
    let (w, hh) = model
        .map_size(h.width, h.height)
        .map_err(|_| RunError::Config("segmentation map size"))?;
    let cells = map
        .get(..w.saturating_mul(hh))
        .map(<[u8]>::len)
        .ok_or(RunError::Config("segmentation map buffer"))?;
    let mut run = SegmentRun::default();
    for (_, pixels) in frames {
        let view = ImageView::new(pixels, h.width, h.height, h.width)
            .map_err(|_| RunError::Format(FormatError::Truncated))?;
        probe
            .measure(Step::Segment, || {
                model.segment(&view, &mut *map).map(|_| ())
            })
            .map_err(|_| RunError::Config("segmentation map buffer"))?;
        run.maps += 1;
        for &c in map.get(..cells).unwrap_or(&[]) {
            if let Some(n) = run.classes.get_mut(usize::from(c)) {
                *n += 1;
            }
        }
    }
    Ok(run)
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
        match self.scale.running_scale() {
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
        let b = self.scale.body_pose();
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
        f(
            "imu.invalid",
            &[
                Value::N(self.imu_invalid.rejected(Reject::Saturated)),
                Value::N(self.imu_invalid.rejected_total()),
            ],
        );
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
        for (name, kind) in [
            ("scale.wheel_counts", SensorKind::Wheel),
            ("scale.flow_counts", SensorKind::Flow),
            ("scale.camera_counts", SensorKind::Camera),
            ("scale.imu_counts", SensorKind::Imu),
        ] {
            f(name, &self.scale.counts(kind));
        }
        f("odometry.counts", self.odometry.counts());
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
