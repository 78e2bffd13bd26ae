//! The replay's run loop: every sample, failed read, camera frame and
//! segmentation map in time order through `traction::Estimator`, and what
//! it answers collected for the trajectories and the report.

use super::config::{estimator_config, frontend_config, sensor_yaml};
use super::memory as memory_file;
use super::report::{decision_json, report_json};
use super::{Feed, FlowSource, Health, Outcomes, ReplayOptions, ReplayOutput};
use crate::asl::{Dataset, GroundTruth, ImageEntry, LoggedFailure};
use crate::error::CliError;
use crate::faults::Stream;
use crate::metrics::trajectory_error;
use crate::pngio::{GrayImage, load_gray};
use crate::progress::Progress;
use crate::tum::{TumPose, truth_poses};
use serde_json::{Value, json};
use std::path::Path;
use traction::ego_ekf::events::JoltEvent;
use traction::ego_ekf::surface::FloorModel;
use traction::estimator::{Estimator, Processed};
use traction::frontend::{FrontEnd, FrontEndBuffers, FrontEndConfig};
use traction::reorder::Event;
use traction::vslam_core::flow_frames::{FrameFlow, FrameFlowConfig};
use traction::vslam_core::geometry::{Quat, Vec3};
use traction::vslam_core::image::LabelView;
use traction::vslam_core::segment::Segmenter;
use traction::vslam_core::sensors::{FLOW_FRAME_LEN, FLOW_FRAME_SIDE, RawWheelRates, WheelTicks};
use traction::vslam_core::{PerStream, Reject, StreamCounts, Timestamp};
use traction::wheel_odom::odometry::{DiffDriveOdometry, DiffDriveParams};

pub(super) fn outcome_name<T>(r: &Result<T, Reject>) -> &'static str {
    match r {
        Ok(_) => "fused",
        Err(e) => e.name(),
    }
}

fn processed_outcome(p: &Processed) -> (Stream, Timestamp, &'static str) {
    let name = match p {
        Processed::Imu { outcome, .. } => outcome_name(outcome),
        Processed::Wheel { outcome, .. } => match outcome {
            Ok(inn) if inn.gated => "gated",
            o => outcome_name(o),
        },
        Processed::Flow { outcome, .. } => outcome_name(outcome),
    };
    (p.stream(), p.t(), name)
}

fn pose(t: Timestamp, p: Vec3, q: &Quat) -> TumPose {
    TumPose {
        t,
        p: [p.x as f64, p.y as f64, p.z as f64],
        q_xyzw: [q.i as f64, q.j as f64, q.k as f64, q.w as f64],
    }
}

/// Image `k` of a stream's images, loaded, with its path; `None` when the
/// stream or the image is absent.
fn image(entries: Option<&[ImageEntry]>, k: usize) -> Result<Option<(GrayImage, &Path)>, CliError> {
    match entries.and_then(|v| v.get(k)) {
        Some(e) => Ok(Some((load_gray(&e.path)?, e.path.as_path()))),
        None => Ok(None),
    }
}

/// One item of the replay's schedule.
enum Next {
    Sample(Event),
    FlowFrame(usize),
    /// A read that failed: the feed's (`simulate --faults`) or the log's
    /// (`failed.csv`).
    Failed(LoggedFailure),
    Camera(usize),
    Labels(usize),
    Segment(usize),
}

/// The camera path's memory, borrowed by the estimator.
pub(crate) struct FrontEndMemory {
    previous_frame: Vec<u8>,
    previous_pyramid: Vec<u8>,
    current_pyramid: Vec<u8>,
    corner_scratch: Vec<f32>,
}

impl FrontEndMemory {
    pub(crate) fn new(config: Option<&FrontEndConfig>) -> Self {
        let sizes = config
            .map(|c| FrontEndBuffers::sizes(c.width, c.height, c.levels, c.corners.block_size))
            .unwrap_or([0; 4]);
        FrontEndMemory {
            previous_frame: vec![0u8; sizes[0]],
            previous_pyramid: vec![0u8; sizes[1]],
            current_pyramid: vec![0u8; sizes[2]],
            corner_scratch: vec![0f32; sizes[3]],
        }
    }

    /// The camera path over this memory, when there is a camera.
    pub(crate) fn frontend(
        &mut self,
        config: Option<FrontEndConfig>,
        root: &Path,
    ) -> Result<Option<FrontEnd<'_>>, CliError> {
        let Some(c) = config else { return Ok(None) };
        let buffers = FrontEndBuffers {
            previous_frame: &mut self.previous_frame,
            previous_pyramid: &mut self.previous_pyramid,
            current_pyramid: &mut self.current_pyramid,
            corner_scratch: &mut self.corner_scratch,
        };
        FrontEnd::new(c, buffers)
            .map(Some)
            .map_err(|e| CliError::file(&sensor_yaml(root, "cam0"), e.to_string()))
    }
}

/// One stream's samples in file order, each at its arrival: its own time
/// stamp, or, for a sample whose time stamp does not increase on the
/// previous sample's (duplicated, out of order), right after the previous
/// sample, so that the estimator sees it where the log has it.
fn arrivals(events: impl Iterator<Item = Event>) -> Vec<(Timestamp, u8, Next)> {
    let mut out: Vec<(Timestamp, u8, Next)> = Vec::new();
    let mut previous: Option<(Timestamp, Timestamp)> = None;
    for e in events {
        let arrival = match previous {
            Some((t, arrival)) if e.t() <= t => arrival,
            _ => e.t(),
        };
        previous = Some((e.t(), arrival));
        out.push((arrival, 0, Next::Sample(e)));
    }
    out
}

/// Every stream in arrival order (see [`arrivals`]; time order for a log
/// whose time stamps increase); images after the samples of the same time
/// stamp. `feed`, when given, replaces the dataset's sample streams.
fn schedule(ds: &Dataset, feed: Option<&Feed>, flow: FlowSource) -> Vec<(Timestamp, u8, Next)> {
    let mut items: Vec<(Timestamp, u8, Next)> = Vec::new();
    let counts = flow == FlowSource::Counts;
    // The flow's samples and failed reads only when its counts are the source.
    let flow_counts = |s: Stream| counts || s != Stream::Flow;
    match feed {
        None => {
            if let Some((_, imu)) = &ds.imu {
                items.extend(arrivals(imu.iter().map(|s| Event::Imu(*s))));
            }
            if let Some((_, wheels)) = &ds.wheel {
                items.extend(arrivals(wheels.iter().map(|s| Event::Wheel(*s))));
            }
            if let Some((_, rates)) = &ds.wheel_rates {
                items.extend(arrivals(rates.iter().map(|s| Event::WheelRates(*s))));
            }
            if let Some((_, f)) = ds.flow.as_ref().filter(|_| counts) {
                items.extend(arrivals(f.iter().map(|s| Event::Flow(*s))));
            }
            items.extend(
                ds.failed
                    .iter()
                    .filter(|f| flow_counts(f.stream))
                    .map(|f| (f.t, 0, Next::Failed(*f))),
            );
        }
        Some(feed) => {
            items.extend(
                feed.samples
                    .iter()
                    .filter(|(_, e)| flow_counts(e.stream()))
                    .map(|(a, e)| (*a, 0, Next::Sample(*e))),
            );
            items.extend(
                feed.failed
                    .iter()
                    .filter(|f| flow_counts(f.stream))
                    .map(|f| (f.t, 0, Next::Failed(f.logged()))),
            );
        }
    }
    // Raw flow frames before a camera frame of the same time, so its pair sees them.
    if let Some((_, frames)) = ds.flowraw.as_ref().filter(|_| !counts) {
        items.extend(
            frames
                .iter()
                .enumerate()
                .map(|(i, e)| (e.t, 1, Next::FlowFrame(i))),
        );
    }
    if let Some((_, frames)) = &ds.cam {
        items.extend(
            frames
                .iter()
                .enumerate()
                .map(|(i, e)| (e.t, 1, Next::Camera(i))),
        );
    }
    if let Some((_, maps)) = &ds.seg {
        items.extend(
            maps.iter()
                .enumerate()
                .map(|(i, e)| (e.t, 2, Next::Labels(i))),
        );
    } else if let Some((_, frames)) = &ds.cam1 {
        // No maps in the log: the reference model labels the forward frames.
        items.extend(
            frames
                .iter()
                .enumerate()
                .map(|(i, e)| (e.t, 2, Next::Segment(i))),
        );
    }
    items.sort_by_key(|(t, k, _)| (*t, *k));
    items
}

/// What the run collects from the estimator's answers.
#[derive(Default)]
pub(super) struct Collected {
    /// The estimator's body poses ([`Estimator::estimate`]), one per fused
    /// IMU sample once the filter runs.
    pub ekf: Vec<TumPose>,
    /// The estimate's yaw rate (robot frame, rad/s; [`Estimate::yaw_rate`](traction::estimate::Estimate::yaw_rate)) with each pose.
    pub yaw_rate: Vec<f32>,
    /// One report entry per scale decision.
    pub decisions: Vec<Value>,
    /// The camera path's body poses (the composed camera pose moved to B by
    /// the camera's `T_BS`).
    pub vslam: Vec<TumPose>,
    /// One report entry per segmentation map.
    pub surfaces: Vec<Value>,
    /// The model that labels `cam1` frames when the log has no maps.
    pub segmenter: FloorModel,
    /// Camera frames refused, with the reason.
    pub camera_rejections: Vec<Value>,
    /// Frames given to the camera path (the first of a run is no pair, so
    /// the camera counts' `seen` is one fewer).
    pub camera_frames: u64,
    /// Every jolt as it is judged: the monitor's own log keeps only the
    /// last few, a report keeps them all.
    pub jolts: Vec<JoltEvent>,
    /// Every outcome in processing order.
    pub outcomes: Outcomes,
    /// The filter's health, checked when `check_health`.
    pub health: Health,
    check_health: bool,
    /// Outcomes logged per stream (a first camera frame is no pair and not
    /// counted by the estimator, nor here).
    logged: PerStream<u32>,
    /// The estimator's counts at the last health check.
    last_counts: StreamCounts,
    /// Innovation and NIS statistics per aid.
    pub aids: super::aids::AidStats,
    /// The flow sensor's power (always on, or on demand).
    pub flow_power: super::flow_power::FlowPower,
    /// The raw flow frames' tracker (the previous frame).
    pub frame_flow: Option<FrameFlow>,
}

impl Collected {
    /// One sample the estimator processed.
    fn handle(&mut self, p: Processed, est: &Estimator<'_>) {
        self.log(processed_outcome(&p));
        self.aids.observe(est.ekf());
        self.flow_power.observe(est, &p);
        if self.check_health && matches!(p, Processed::Imu { .. }) {
            self.health.check(est.ekf(), p.t());
            let now = est.counts();
            self.health
                .check_counts(&now, &self.last_counts, &self.logged, p.t());
            self.last_counts = now;
        }
        if let Processed::Imu { jolt: Some(e), .. } = p {
            self.jolts.push(e);
        }
        if let Processed::Imu { outcome: Ok(_), .. } = p
            && let Some(e) = est.estimate()
        {
            self.ekf.push(pose(e.t, e.p_wb, &e.q_wb));
            self.yaw_rate.push(e.yaw_rate);
        }
    }

    /// One outcome, in processing order.
    fn log(&mut self, o: (Stream, Timestamp, &'static str)) {
        if o.2 != "first" {
            self.logged[o.0] += 1;
        }
        self.outcomes.push(o);
    }

    /// Everything the estimator has ready.
    fn drain(&mut self, est: &mut Estimator<'_>) {
        while let Some(p) = est.poll() {
            self.handle(p, est);
        }
    }

    /// Everything up to `t`, before an image of time `t`.
    fn drain_until(&mut self, est: &mut Estimator<'_>, t: Timestamp) {
        while let Some(p) = est.poll_until(t) {
            self.handle(p, est);
        }
    }

    /// A read that produced no sample.
    fn failed(&mut self, est: &mut Estimator<'_>, f: &LoggedFailure) {
        est.reject_read(f.stream, f.t, f.reason);
        self.log((f.stream, f.t, f.reason.name()));
    }

    /// Camera frame `k` of the dataset.
    fn camera(
        &mut self,
        est: &mut Estimator<'_>,
        ds: &Dataset,
        t: Timestamp,
        k: usize,
    ) -> Result<(), CliError> {
        self.drain_until(est, t);
        let Some((img, path)) = image(ds.cam.as_ref().map(|(_, v)| v.as_slice()), k)? else {
            return Ok(());
        };
        let view = img
            .view()
            .map_err(|e| CliError::file(path, e.to_string()))?;
        let outcome = est.process_camera(t, &view);
        self.aids.observe(est.ekf());
        self.camera_frames += 1;
        self.log((
            Stream::Camera,
            t,
            match &outcome {
                Ok(None) => "first",
                o => outcome_name(o),
            },
        ));
        match outcome {
            Ok(decision) => {
                if let Some(d) = decision {
                    let mut record = decision_json(t, &d);
                    record["disagree"] = super::disagreement::last_frame(est);
                    self.decisions.push(record);
                }
                let b = est.scale().body_pose();
                self.vslam.push(pose(t, b.translation.vector, &b.rotation));
            }
            Err(r) => self
                .camera_rejections
                .push(json!({"t": t.0, "reason": r.name()})),
        }
        Ok(())
    }

    /// Raw flow frame `k` of the dataset (`flowraw0`): tracked against the
    /// previous frame, its motion into the scale pipeline's `To`.
    fn flow_frame(
        &mut self,
        est: &mut Estimator<'_>,
        ds: &Dataset,
        t: Timestamp,
        k: usize,
    ) -> Result<(), CliError> {
        self.drain_until(est, t);
        let Some(e) = ds.flowraw.as_ref().and_then(|(_, v)| v.get(k)) else {
            return Ok(());
        };
        let img = load_gray(&e.path)?;
        let frame: &[u8; FLOW_FRAME_LEN] = img
            .data
            .as_slice()
            .try_into()
            .ok()
            .filter(|_| img.width == FLOW_FRAME_SIDE && img.height == FLOW_FRAME_SIDE)
            .ok_or_else(|| {
                CliError::file(
                    &e.path,
                    format!("a raw flow frame is {FLOW_FRAME_SIDE}x{FLOW_FRAME_SIDE} pixels"),
                )
            })?;
        let tracker = match self.frame_flow.as_mut() {
            Some(f) => f,
            None => self.frame_flow.insert(
                FrameFlow::new(FrameFlowConfig::default())
                    .map_err(|err| CliError::file(&e.path, err.to_string()))?,
            ),
        };
        // A frame out of time order is refused like an out-of-order sample.
        let outcome = match tracker.push(t, frame) {
            Ok(pair) => est.process_flow_frame(t, pair.as_ref()),
            Err(_) => {
                est.reject_read(Stream::FlowFrame, t, Reject::OutOfOrder);
                Err(Reject::OutOfOrder)
            }
        };
        self.log((Stream::FlowFrame, t, outcome_name(&outcome)));
        Ok(())
    }

    /// Segmentation map `k` of the dataset.
    fn labels(
        &mut self,
        est: &mut Estimator<'_>,
        ds: &Dataset,
        t: Timestamp,
        k: usize,
    ) -> Result<(), CliError> {
        self.drain_until(est, t);
        let Some((img, path)) = image(ds.seg.as_ref().map(|(_, v)| v.as_slice()), k)? else {
            return Ok(());
        };
        let labels = LabelView::new(&img.data, img.width, img.height, img.width)
            .map_err(|e| CliError::file(path, e.to_string()))?;
        self.use_labels(est, t, &labels);
        Ok(())
    }

    /// Forward frame `k` of the dataset (`cam1`), labelled by the reference
    /// floor model ([`FloorModel`]) and used as a segmentation map.
    fn segment(
        &mut self,
        est: &mut Estimator<'_>,
        ds: &Dataset,
        t: Timestamp,
        k: usize,
    ) -> Result<(), CliError> {
        self.drain_until(est, t);
        let Some((img, path)) = image(ds.cam1.as_ref().map(|(_, v)| v.as_slice()), k)? else {
            return Ok(());
        };
        let view = img
            .view()
            .map_err(|e| CliError::file(path, e.to_string()))?;
        let mut map = vec![0u8; img.data.len()];
        let labels = self
            .segmenter
            .segment(&view, &mut map)
            .map_err(|e| CliError::file(path, e.to_string()))?;
        self.use_labels(est, t, &labels);
        Ok(())
    }

    /// One label map into the estimator, and its surface entry.
    fn use_labels(&mut self, est: &mut Estimator<'_>, t: Timestamp, labels: &LabelView<'_>) {
        let outcome = est.process_segmentation(t, labels);
        self.log((Stream::Segmentation, t, outcome_name(&outcome)));
        let state = est.surface().map(|s| s.state_at(t));
        let grip = est.surface().map(|s| s.grip_params(t));
        self.surfaces.push(json!({
            "t": t.0,
            "outcome": match outcome { Ok(()) => "used".to_string(), Err(r) => r.name().to_string() },
            "surface": state.and_then(|s| s.dominant()).map(|k| k.name()),
            "grip": grip.map(|g| g.grip()),
            "forward_std": grip.map(|g| g.forward_std()),
        }));
    }

    /// One item of the schedule.
    fn step(
        &mut self,
        est: &mut Estimator<'_>,
        ds: &Dataset,
        t: Timestamp,
        next: &Next,
    ) -> Result<(), CliError> {
        match next {
            Next::Sample(Event::Flow(s)) if !self.flow_power.pass(s.t) => {}
            Next::Sample(e) => {
                est.offer(*e);
                self.drain(est);
            }
            Next::Failed(f) => self.failed(est, f),
            Next::FlowFrame(k) => self.flow_frame(est, ds, t, *k)?,
            Next::Camera(k) => self.camera(est, ds, t, *k)?,
            Next::Labels(k) => self.labels(est, ds, t, *k)?,
            Next::Segment(k) => self.segment(est, ds, t, *k)?,
        }
        Ok(())
    }
}

/// Replays `ds` (read from `root`) through the estimator; `feed`, when
/// given, replaces the dataset's sample streams.
pub(super) fn run(
    ds: &Dataset,
    root: &Path,
    progress: bool,
    options: ReplayOptions,
    feed: Option<&Feed>,
) -> Result<ReplayOutput, CliError> {
    // Any sensor may be absent: what is missing simply never arrives, and the
    // report's `missing_sensors` says so. Without an IMU the EKF never starts
    // (and no ekf.tum is written); without wheels the EKF runs on IMU and flow.
    let missing = ds.missing();
    let config = estimator_config(ds, root, &options)?;
    let fe_config = frontend_config(ds, root, config.scale.camera, &options)?;
    let mut memory = FrontEndMemory::new(fe_config.as_ref());
    let frontend = memory.frontend(fe_config, root)?;
    let mut est = Box::new(
        Estimator::new(&config, frontend)
            .map_err(|e| CliError::file(root, format!("configuration: {e}")))?,
    );
    let loaded = options.memory.as_deref().map(|path| {
        (
            memory_file::load(&mut est, path),
            est.scale().memory().cells(),
        )
    });

    let flow_source = FlowSource::resolve(options.flow_source, ds);
    let items = schedule(ds, feed, flow_source);
    let bar = Progress::new(progress).bar("replay", items.len() as u64, "samples");
    let mut c = Collected {
        check_health: feed.is_some(),
        flow_power: super::flow_power::FlowPower::new(options.flow_demand)
            .map_err(|e| CliError::file(root, format!("configuration: {e}")))?,
        ..Collected::default()
    };
    for (i, (t, _, next)) in items.iter().enumerate() {
        c.step(&mut est, ds, *t, next)?;
        if i % 256 == 0 {
            bar.set_position(i as u64);
        }
    }
    est.finish();
    c.drain(&mut est);
    bar.set_position(items.len() as u64);
    bar.finish_and_clear();

    let wheels = ds.wheel.as_ref().map(|(_, v)| v.as_slice()).unwrap_or(&[]);
    let rates = ds
        .wheel_rates
        .as_ref()
        .map(|(_, v)| v.as_slice())
        .unwrap_or(&[]);
    let wheel_only = wheel_only(&config.odometry, wheels, rates);
    let mut report = report_json(&missing, &c, &est);
    if let (Some(path), Some((loaded, cells))) = (options.memory.as_deref(), &loaded) {
        memory_file::save(&est, path)?;
        report["memory"] = memory_file::report(path, loaded, *cells, &est);
    }
    if let Some(l) = &ds.labels {
        report["labels"] = l.to_json();
    }
    let errors = match &ds.groundtruth {
        Some(gt) => errors(
            gt,
            [
                ("ekf", &c.ekf),
                ("vslam", &c.vslam),
                ("wheel_only", &wheel_only),
            ],
        ),
        None => Vec::new(),
    };
    let imu = super::config::imu_rate_hz(ds).zip(
        ds.imu
            .as_ref()
            .and_then(|(_, v)| v.iter().map(|s| s.t).min()),
    );
    Ok(ReplayOutput {
        imu,
        ekf: c.ekf,
        yaw_rate: c.yaw_rate,
        vslam: c.vslam,
        wheel_only,
        report,
        errors,
        outcomes: c.outcomes,
        health: c.health,
        wheel_records: c.aids.wheel_records,
    })
}

/// Each trajectory's error against ground truth, for those that have one.
fn errors(
    gt: &[GroundTruth],
    trajectories: [(&'static str, &Vec<TumPose>); 3],
) -> Vec<(&'static str, crate::metrics::TrajectoryError)> {
    let truth = truth_poses(gt);
    trajectories
        .into_iter()
        .filter_map(|(name, traj)| trajectory_error(traj, &truth).map(|e| (name, e)))
        .collect()
}

/// Dead reckoning from the wheels alone (counts or rates): the baseline
/// every estimate must beat. The odometry integrates B's origin (mid-axle
/// on the floor), from the origin, heading along x, on the floor (z = 0).
fn wheel_only(
    params: &DiffDriveParams,
    wheels: &[WheelTicks],
    rates: &[RawWheelRates],
) -> Vec<TumPose> {
    let mut odo = DiffDriveOdometry::new(*params);
    let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
    let mut out = Vec::with_capacity(wheels.len() + rates.len());
    let steps = wheels
        .iter()
        .map(|w| (w.t, Event::Wheel(*w)))
        .chain(rates.iter().map(|r| (r.t, Event::WheelRates(*r))));
    for (t, sample) in steps {
        let step = match sample {
            Event::WheelRates(r) => odo.update_rates(r),
            Event::Wheel(w) => odo.update(w),
            _ => continue,
        };
        // A sample the odometry refused for its time stamp (duplicated, out
        // of order) writes no pose: the trajectory's times increase.
        if out.last().is_some_and(|p: &TumPose| t <= p.t) {
            continue;
        }
        if let Ok(Some(step)) = step {
            let d = step.delta.translation;
            let (s, c) = yaw.sin_cos();
            x += c * d.x as f64 - s * d.y as f64;
            y += s * d.x as f64 + c * d.y as f64;
            yaw += step.delta.dyaw as f64;
        }
        let (s, c) = (0.5 * yaw).sin_cos();
        out.push(TumPose {
            t,
            p: [x, y, 0.0],
            q_xyzw: [0.0, 0.0, s, c],
        });
    }
    out
}
