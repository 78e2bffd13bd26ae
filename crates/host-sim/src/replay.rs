//! Replay of a recorded ASL dataset through `traction::Estimator`, and the
//! files it writes: `ekf.tum`, `vslam.tum`, `wheel_only.tum`, `report.json`,
//! `trajectory.svg`. All estimation happens in the no_std crates; this
//! module only reads, feeds, collects and writes.

use crate::asl::{Dataset, GroundTruth, SegMeta};
use crate::error::CliError;
use crate::faults::{FailedRead, Stream};
use crate::metrics::{TrajectoryError, trajectory_error};
use crate::pngio::load_gray;
use crate::svg::{Series, top_view};
use crate::tum::{TumPose, write_tum};
use serde_json::{Value, json};
use std::path::Path;
use traction::ego_ekf::events::JoltEvent;
use traction::ego_ekf::surface::{
    ClassConfig, GroundCamera, SurfaceConfig, SurfaceKind, WheelType,
};
use traction::estimator::{Estimator, EstimatorConfig, Processed};
use traction::frontend::{FrontEnd, FrontEndBuffers, FrontEndConfig};
use traction::reorder::Event;
use traction::vslam_core::decompose::PinholeIntrinsics;
use traction::vslam_core::geometry::{Extrinsics, Vec3};
use traction::vslam_core::image::LabelView;
use traction::vslam_core::robot::{
    FlowDescription, ImuDescription, ImuNoise, MountedSensor, RobotDescription, RobotError, Wheels,
};
use traction::vslam_core::scale::FrameDecision;
use traction::vslam_core::{Reject, SampleCounts, StreamCounts, Timestamp};
use traction::wheel_odom::odometry::{DiffDriveOdometry, DiffDriveParams};

/// What a replay produced.
pub struct ReplayOutput {
    /// The EKF's body trajectory.
    pub ekf: Vec<TumPose>,
    /// Camera poses composed with the metric scale, expressed for the body.
    pub vslam: Vec<TumPose>,
    /// Wheel odometry alone.
    pub wheel_only: Vec<TumPose>,
    /// The report.
    pub report: Value,
    /// Errors against ground truth, when present: `(name, error)`.
    pub errors: Vec<(&'static str, TrajectoryError)>,
    /// The outcome of every sample, frame, map and failed read, in
    /// processing order: stream, time stamp, `fused` (`first` for a first
    /// camera frame) or the reason name.
    pub outcomes: Outcomes,
    /// The filter's health after every IMU step.
    pub health: Health,
}

/// The filter's health, checked after every processed IMU sample once the
/// filter runs: every nominal state value finite, the covariance finite,
/// symmetric and positive definite (Cholesky of the correlation matrix,
/// `ego_ekf::covariance::is_positive_definite`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Health {
    /// Steps checked.
    pub steps: u32,
    /// Steps with a non-finite state value.
    pub non_finite: u32,
    /// Steps whose covariance was not symmetric positive definite.
    pub not_spd: u32,
}

impl Health {
    fn check(&mut self, ekf: &traction::ego_ekf::EgoEkf) {
        if !ekf.is_initialised() {
            return;
        }
        let x = ekf.state();
        let finite = [
            x.p_wb,
            x.v_wb,
            x.accel_bias,
            x.gyro_bias,
            x.gravity,
            x.clone_p_wb,
            x.p_bl,
            x.p_br,
        ]
        .iter()
        .all(|v| v.iter().all(|c| c.is_finite()))
            && [x.q_wb, x.clone_q_wb, x.q_rb]
                .iter()
                .all(|q| q.coords.iter().all(|c| c.is_finite()))
            && x.radius_left.is_finite()
            && x.radius_right.is_finite();
        self.steps += 1;
        if !finite {
            self.non_finite += 1;
        }
        if !traction::ego_ekf::covariance::is_positive_definite(ekf.covariance()) {
            self.not_spd += 1;
        }
    }

    /// Whether every checked step was healthy.
    pub fn ok(&self) -> bool {
        self.non_finite == 0 && self.not_spd == 0
    }
}

/// Outcomes of samples in processing order: stream, time stamp, name.
pub type Outcomes = Vec<(Stream, Timestamp, &'static str)>;

/// What reaches the estimator instead of the dataset's own sample streams
/// (`simulate --faults`): samples in arrival order, and reads that failed.
#[derive(Clone, Debug, Default)]
pub struct Feed {
    /// `(arrival, sample)`: the estimator gets them sorted by arrival (stably).
    pub samples: Vec<(Timestamp, Event)>,
    /// Reads that produced no sample.
    pub failed: Vec<FailedRead>,
}

fn outcome_name<T>(r: &Result<T, Reject>) -> &'static str {
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

fn extrinsics(path: &Path, m: &[f32; 16]) -> Result<Extrinsics, CliError> {
    Extrinsics::from_row_major(m).map_err(|e| CliError::file(path, format!("`T_BS`: {e}")))
}

fn surface_kind(name: &str) -> Option<SurfaceKind> {
    match name {
        "wood" | "floor" | "laminate" => Some(SurfaceKind::Wood),
        "carpet" | "rug" => Some(SurfaceKind::Carpet),
        "tile" => Some(SurfaceKind::Tile),
        "concrete" => Some(SurfaceKind::Concrete),
        "threshold" => Some(SurfaceKind::Threshold),
        _ => None,
    }
}

fn wheel_type(name: &str) -> WheelType {
    match name {
        "hard_rubber" => WheelType::HardRubber,
        "omni" => WheelType::Omni,
        _ => WheelType::SoftTreaded,
    }
}

fn counts_json(c: &SampleCounts) -> Value {
    let mut rejected = serde_json::Map::new();
    for (r, n) in c.by_reason() {
        if n > 0 {
            rejected.insert(r.name().to_string(), json!(n));
        }
    }
    json!({"seen": c.seen(), "fused": c.fused(), "gated": c.gated(), "rejected": rejected})
}

/// `counts` of `report.json`: every stream of the registry by its name,
/// zeros for a stream the run did not have.
fn stream_counts_json(c: &StreamCounts) -> Value {
    Value::Object(
        c.iter()
            .map(|(s, c)| (s.name().to_string(), counts_json(c)))
            .collect(),
    )
}

fn decision_json(t: Timestamp, d: &FrameDecision) -> Value {
    let (scale, source, why) = match &d.scale {
        Ok(s) => (
            json!(s.scale),
            json!(format!("{:?}", s.source).to_lowercase()),
            Value::Null,
        ),
        Err(e) => (Value::Null, Value::Null, json!(format!("{e:?}"))),
    };
    json!({
        "t": t.0,
        "method": format!("{:?}", d.method),
        "baseline": d.baseline,
        "camera_confidence": d.camera_confidence,
        "wheel_m": d.wheel.metres, "wheel_confidence": d.wheel.confidence,
        "flow_m": d.flow.metres, "flow_confidence": d.flow.confidence,
        "slip": d.slip.amount, "slip_exceeded": d.slip.exceeded, "slip_cause": format!("{:?}", d.slip.cause),
        "wheel_outlier": d.wheel_outlier,
        "scale": scale, "source": source, "no_scale": why,
        "applied_scale": d.applied_scale,
    })
}

fn pose(t: Timestamp, p: Vec3, q: &traction::vslam_core::geometry::Quat) -> TumPose {
    TumPose {
        t,
        p: [p.x as f64, p.y as f64, p.z as f64],
        q_xyzw: [q.i as f64, q.j as f64, q.k as f64, q.w as f64],
    }
}

enum Next {
    Sample(Event),
    Failed(usize),
    Camera(usize),
    Labels(usize),
}

/// How a replay is run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReplayOptions {
    /// Use the segmentation maps (when the dataset has them) for the
    /// surface-aware grip and jolt judgement; `false` keeps the filter's fixed
    /// grip and one fixed jolt threshold, for comparison.
    pub surface_model: bool,
    /// The camera path's [`FrontEndConfig::redetect_below`] (fewest inliers
    /// carried into the next frame before corners are detected afresh);
    /// `None` for its default.
    pub redetect_below: Option<usize>,
}

impl Default for ReplayOptions {
    /// The surface model on, the camera path's defaults.
    fn default() -> Self {
        ReplayOptions {
            surface_model: true,
            redetect_below: None,
        }
    }
}

/// The robot a dataset describes: its `sensor.yaml` files (wheel geometry and
/// encoders, IMU noise, every `T_BS`, the flow optics), and for what they do
/// not say the robot-vacuum preset ([`RobotDescription::robot_vacuum`]: rim
/// speed, wheel path noise, flow noise; its wheels when `wheel0` is absent)
/// and, without `imu0`, an identity mounting with [`ImuNoise::default`]. A
/// description that does not validate is refused with the file to blame.
pub fn robot_description(ds: &Dataset, root: &Path) -> Result<RobotDescription, CliError> {
    let yaml = |s: &str| root.join("mav0").join(s).join("sensor.yaml");
    let preset = RobotDescription::robot_vacuum();
    let imu = match &ds.imu {
        Some((m, _)) => ImuDescription {
            mount: extrinsics(&yaml("imu0"), &m.t_bs)?,
            noise: ImuNoise {
                accel_density: m.accelerometer_noise_density as f32,
                gyro_density: m.gyroscope_noise_density as f32,
                accel_random_walk: m.accelerometer_random_walk as f32,
                gyro_random_walk: m.gyroscope_random_walk as f32,
            },
        },
        None => ImuDescription {
            mount: Extrinsics::identity(),
            noise: ImuNoise::default(),
        },
    };
    let wheels = match &ds.wheel {
        Some((m, _)) => Wheels {
            radius_left: m.wheel_radius_left as f32,
            radius_right: m.wheel_radius_right as f32,
            track: m.wheel_base as f32,
            track_factor: 1.0,
            counts_per_revolution: m.ticks_per_revolution.round() as u32,
            ..preset.wheels
        },
        None => preset.wheels,
    };
    let flow = match (&ds.flow, preset.flow) {
        (Some((m, _)), Some(flow)) => Some(FlowDescription {
            mount: extrinsics(&yaml("flow0"), &m.t_bs)?,
            height: m.height as f32,
            counts_per_radian: m.counts_per_radian as f32,
            ..flow
        }),
        _ => None,
    };
    let camera = match &ds.cam {
        Some((m, _)) => Some(extrinsics(&yaml("cam0"), &m.t_bs)?),
        None => None,
    };
    let robot = RobotDescription {
        wheels,
        imu,
        flow,
        camera,
    };
    robot.validate().map_err(|e| {
        let folder = match e {
            RobotError::NonFiniteMount(s) | RobotError::NotARotation(s) => sensor_folder(s),
            RobotError::BadNoise(Some(s)) => sensor_folder(s),
            RobotError::FlowBelowFloor | RobotError::BadFlowResolution => "flow0",
            _ => "wheel0",
        };
        CliError::file(&yaml(folder), e.to_string())
    })?;
    Ok(robot)
}

fn sensor_folder(s: MountedSensor) -> &'static str {
    match s {
        MountedSensor::Imu => "imu0",
        MountedSensor::Flow => "flow0",
        MountedSensor::Camera => "cam0",
    }
}

/// The surface model's configuration from `seg0/sensor.yaml`: the class
/// table, and the ground geometry of the camera that took the maps
/// (intrinsics, resolution and `T_BS`).
fn surface_config(
    m: &SegMeta,
    wheel_type_name: &str,
    path: &Path,
) -> Result<SurfaceConfig, CliError> {
    let pairs: Vec<(u8, SurfaceKind)> = m
        .classes
        .iter()
        .filter_map(|(id, name)| surface_kind(name).map(|k| (*id, k)))
        .collect();
    let ground: Vec<u8> = m
        .ground_classes
        .iter()
        .copied()
        .filter(|g| pairs.iter().any(|(id, _)| id == g))
        .collect();
    let mount = extrinsics(path, &m.t_bs)?;
    let camera = GroundCamera::from_mount(
        m.intrinsics[1] as f32,
        m.intrinsics[3] as f32,
        m.resolution[1] as f32,
        &mount,
    )
    .map_err(|e| CliError::file(path, format!("segmentation camera: {e}")))?;
    Ok(SurfaceConfig::for_camera(
        wheel_type(wheel_type_name),
        ClassConfig::from_lists(&pairs, &ground),
        camera,
    ))
}

/// Replays `ds` (read from `root`) through the estimator.
pub fn replay(ds: &Dataset, root: &Path, progress: bool) -> Result<ReplayOutput, CliError> {
    replay_with(ds, root, progress, ReplayOptions::default())
}

/// Replays `ds` (read from `root`) through the estimator, run as `options` say.
pub fn replay_with(
    ds: &Dataset,
    root: &Path,
    progress: bool,
    options: ReplayOptions,
) -> Result<ReplayOutput, CliError> {
    replay_feed(ds, root, progress, options, None)
}

/// [`replay_with`], with the sample streams replaced by `feed` when given
/// (the dataset's images, metadata and truth stay).
pub fn replay_feed(
    ds: &Dataset,
    root: &Path,
    progress: bool,
    options: ReplayOptions,
    feed: Option<&Feed>,
) -> Result<ReplayOutput, CliError> {
    let missing = ds.missing();
    // Any sensor may be absent: what is missing simply never arrives, and the
    // report's `missing_sensors` says so. Without an IMU the EKF never starts
    // (ekf.tum stays empty); without wheels the EKF runs on IMU and flow.
    let no_imu = Vec::new();
    let no_wheels = Vec::new();
    let imu = ds.imu.as_ref().map(|(_, v)| v).unwrap_or(&no_imu);
    let wheels = ds.wheel.as_ref().map(|(_, v)| v).unwrap_or(&no_wheels);
    let yaml = |s: &str| root.join("mav0").join(s).join("sensor.yaml");
    let robot = robot_description(ds, root)?;
    let mut config = EstimatorConfig::from_robot(&robot)
        .map_err(|e| CliError::file(root, format!("configuration: {e}")))?;
    let wheel_type_name = ds.wheel.as_ref().map_or("", |(m, _)| m.wheel_type.as_str());
    config.surface = match &ds.seg {
        Some((m, _)) if options.surface_model => {
            Some(surface_config(m, wheel_type_name, &yaml("seg0"))?)
        }
        _ => None,
    };
    let camera_mount = config.scale.camera;
    let odometry = config.odometry;

    // The camera path's memory, borrowed by the estimator.
    let cam = ds.cam.as_ref();
    let (w, h) = cam
        .map(|(m, _)| (m.resolution[0] as usize, m.resolution[1] as usize))
        .unwrap_or((1, 1));
    let fe_config = cam
        .map(|(m, _)| {
            let [fu, fv, cu, cv] = m.intrinsics.map(|v| v as f32);
            PinholeIntrinsics::new(fu, fv, cu, cv)
                .map(|k| {
                    let mut c = FrontEndConfig::new(w, h, k, camera_mount);
                    if let Some(n) = options.redetect_below {
                        c.redetect_below = n;
                    }
                    c
                })
                .map_err(|e| CliError::file(&yaml("cam0"), format!("`intrinsics`: {e:?}")))
        })
        .transpose()?;
    let sizes = fe_config
        .map(|c| FrontEndBuffers::sizes(w, h, c.levels, c.corners.block_size))
        .unwrap_or([0; 4]);
    let (mut b0, mut b1, mut b2) = (
        vec![0u8; sizes[0]],
        vec![0u8; sizes[1]],
        vec![0u8; sizes[2]],
    );
    let mut b3 = vec![0f32; sizes[3]];
    let frontend = match fe_config {
        Some(c) => Some(
            FrontEnd::new(
                c,
                FrontEndBuffers {
                    previous_frame: &mut b0,
                    previous_pyramid: &mut b1,
                    current_pyramid: &mut b2,
                    corner_scratch: &mut b3,
                },
            )
            .map_err(|e| CliError::file(&yaml("cam0"), e.to_string()))?,
        ),
        None => None,
    };
    let mut est = Box::new(
        Estimator::new(&config, frontend)
            .map_err(|e| CliError::file(root, format!("configuration: {e}")))?,
    );

    // Every stream in time order; images after the samples of the same time stamp.
    let mut items: Vec<(Timestamp, u8, Next)> = Vec::new();
    match feed {
        None => {
            items.extend(imu.iter().map(|s| (s.t, 0, Next::Sample(Event::Imu(*s)))));
            items.extend(
                wheels
                    .iter()
                    .map(|s| (s.t, 0, Next::Sample(Event::Wheel(*s)))),
            );
            if let Some((_, f)) = &ds.flow {
                items.extend(f.iter().map(|s| (s.t, 0, Next::Sample(Event::Flow(*s)))));
            }
        }
        Some(feed) => {
            items.extend(feed.samples.iter().map(|(a, e)| (*a, 0, Next::Sample(*e))));
            items.extend(
                feed.failed
                    .iter()
                    .enumerate()
                    .map(|(i, f)| (f.t, 0, Next::Failed(i))),
            );
        }
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
    }
    items.sort_by_key(|(t, k, _)| (*t, *k));

    let bar = progress.then(|| {
        let b = indicatif::ProgressBar::new(items.len() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "replay {bar:40} {percent:>3}% {pos}/{len} samples, eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });

    let mut ekf_poses = Vec::new();
    let mut decisions = Vec::new();
    let mut vslam = Vec::new();
    let mut surfaces = Vec::new();
    let mut camera_rejections: Vec<Value> = Vec::new();
    // Frames given to the camera path (the first of a run is no pair, so
    // the camera counts' `seen` is one fewer).
    let mut camera_frames = 0u64;
    // Every jolt as it is judged: the monitor's own log keeps only the last
    // few, a report keeps them all.
    let mut jolt_events: Vec<JoltEvent> = Vec::new();
    let mut outcomes: Outcomes = Vec::new();
    let mut health = Health::default();
    let check_health = feed.is_some();
    let mut handle =
        |p: Processed,
         est: &Estimator<'_>,
         (out, jolts, outcomes): (&mut Vec<TumPose>, &mut Vec<JoltEvent>, &mut Outcomes)| {
            outcomes.push(processed_outcome(&p));
            if check_health && matches!(p, Processed::Imu { .. }) {
                health.check(est.ekf());
            }
            if let Processed::Imu { jolt: Some(e), .. } = p {
                jolts.push(e);
            }
            if let Processed::Imu {
                t, outcome: Ok(_), ..
            } = p
                && est.ekf().is_initialised()
            {
                out.push(pose(t, est.ekf().position(), &est.ekf().attitude()));
            }
        };
    for (i, (t, _, next)) in items.iter().enumerate() {
        match next {
            Next::Sample(e) => {
                est.offer(*e);
                while let Some(p) = est.poll() {
                    handle(p, &est, (&mut ekf_poses, &mut jolt_events, &mut outcomes));
                }
            }
            Next::Failed(k) => {
                let Some(f) = feed.and_then(|f| f.failed.get(*k)) else {
                    continue;
                };
                est.reject_read(f.stream, f.reason);
                outcomes.push((f.stream, f.t, f.reason.name()));
            }
            Next::Camera(k) => {
                while let Some(p) = est.poll_until(*t) {
                    handle(p, &est, (&mut ekf_poses, &mut jolt_events, &mut outcomes));
                }
                let Some((_, frames)) = &ds.cam else { continue };
                let Some(entry) = frames.get(*k) else {
                    continue;
                };
                let img = load_gray(&entry.path)?;
                let view = img
                    .view()
                    .map_err(|e| CliError::file(&entry.path, e.to_string()))?;
                let outcome = est.process_camera(*t, &view);
                camera_frames += 1;
                outcomes.push((
                    Stream::Camera,
                    *t,
                    match &outcome {
                        Ok(None) => "first",
                        o => outcome_name(o),
                    },
                ));
                match outcome {
                    Ok(Some(d)) => {
                        decisions.push(decision_json(*t, &d));
                        let b = est.scale().body_pose();
                        vslam.push(pose(*t, b.translation.vector, &b.rotation));
                    }
                    Ok(None) => {
                        let b = est.scale().body_pose();
                        vslam.push(pose(*t, b.translation.vector, &b.rotation));
                    }
                    Err(r) => camera_rejections.push(json!({"t": t.0, "reason": r.name()})),
                }
            }
            Next::Labels(k) => {
                while let Some(p) = est.poll_until(*t) {
                    handle(p, &est, (&mut ekf_poses, &mut jolt_events, &mut outcomes));
                }
                let Some((_, maps)) = &ds.seg else { continue };
                let Some(entry) = maps.get(*k) else { continue };
                let img = load_gray(&entry.path)?;
                let labels = LabelView::new(&img.data, img.width, img.height, img.width)
                    .map_err(|e| CliError::file(&entry.path, e.to_string()))?;
                let outcome = est.process_segmentation(*t, &labels);
                outcomes.push((Stream::Segmentation, *t, outcome_name(&outcome)));
                let state = est.surface().map(|s| s.state_at(*t));
                let grip = est.surface().map(|s| s.grip_params(*t));
                surfaces.push(json!({
                    "t": t.0,
                    "outcome": match outcome { Ok(()) => "used".to_string(), Err(r) => r.name().to_string() },
                    "surface": state.and_then(|s| s.dominant()).map(|k| k.name()),
                    "grip": grip.map(|g| g.grip()),
                    "forward_std": grip.map(|g| g.forward_std()),
                }));
            }
        }
        if let Some(b) = &bar
            && i % 256 == 0
        {
            b.set_position(i as u64);
        }
    }
    est.finish();
    while let Some(p) = est.poll() {
        handle(p, &est, (&mut ekf_poses, &mut jolt_events, &mut outcomes));
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }

    let wheel_only = wheel_only(&odometry, wheels);
    let jolts: Vec<Value> = jolt_events
        .iter()
        .map(|e| {
            json!({"t": e.t.0, "kind": format!("{:?}", e.kind), "magnitude": e.magnitude,
                   "explained": e.explained, "surface": e.surface.map(|s| s.name())})
        })
        .collect();
    let c = est.counts();
    let ekf = est.ekf();
    let report = json!({
        "missing_sensors": missing,
        "counts": stream_counts_json(&c),
        "filter_counts": {
            "imu": counts_json(ekf.imu_counts()),
            "wheel": counts_json(ekf.wheel_counts()),
            "flow": counts_json(ekf.flow_counts()),
            "zupt": counts_json(ekf.zupt_counts()),
        },
        "frames": decisions,
        "camera_rejections": camera_rejections,
        "camera_path": {
            "frames": camera_frames,
            "corner_detections": est.frontend().map(|f| f.corner_detections()),
        },
        "surface_timeline": surfaces,
        "events": jolts,
        "final": {
            "wheel_radii": ekf.wheel_radii(),
            "flow_velocity_resets": ekf.flow_resets(),
            "wheel_lockout": {
                "resets_to_flow": ekf.recovery().resets_to_flow,
                "resets_to_wheels": ekf.recovery().resets_to_wheels,
                "kept_gating_wheels_slip": ekf.recovery().wheels_slip,
                "kept_gating_no_trusted_source": ekf.recovery().no_trusted_source,
            },
            "imu_gaps_bridged": ekf.gaps().bridged,
            "wheel_radius_std": ekf.wheel_radius_std(),
            "gyro_bias": [ekf.gyro_bias().x, ekf.gyro_bias().y, ekf.gyro_bias().z],
            "accel_bias": [ekf.accel_bias().x, ekf.accel_bias().y, ekf.accel_bias().z],
            "running_scale": est.scale().running_scale().map(|r| r.scale),
        },
    });
    let mut errors = Vec::new();
    if let Some(gt) = &ds.groundtruth {
        let truth = truth_points(gt);
        for (name, traj) in [
            ("ekf", &ekf_poses),
            ("vslam", &vslam),
            ("wheel_only", &wheel_only),
        ] {
            if let Some(e) = trajectory_error(traj, &truth) {
                errors.push((name, e));
            }
        }
    }
    Ok(ReplayOutput {
        ekf: ekf_poses,
        vslam,
        wheel_only,
        report,
        errors,
        outcomes,
        health,
    })
}

fn truth_points(gt: &[GroundTruth]) -> Vec<(u64, [f64; 3])> {
    gt.iter().map(|g| (g.t.0, g.p)).collect()
}

/// Dead reckoning from the wheels alone: the baseline every estimate must beat.
fn wheel_only(
    params: &DiffDriveParams,
    wheels: &[traction::vslam_core::sensors::WheelTicks],
) -> Vec<TumPose> {
    let mut odo = DiffDriveOdometry::new(*params);
    let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
    let mut out = Vec::with_capacity(wheels.len());
    for w in wheels {
        if let Ok(Some(step)) = odo.update(*w) {
            let d = step.delta.translation;
            let (s, c) = yaw.sin_cos();
            x += c * d.x as f64 - s * d.y as f64;
            y += s * d.x as f64 + c * d.y as f64;
            yaw += step.delta.dyaw as f64;
        }
        let (s, c) = (0.5 * yaw).sin_cos();
        out.push(TumPose {
            t: w.t,
            p: [x, y, 0.0],
            q_xyzw: [0.0, 0.0, s, c],
        });
    }
    out
}

/// Writes the replay's files into `out`.
pub fn write_outputs(
    out_dir: &Path,
    r: &ReplayOutput,
    truth: Option<&[GroundTruth]>,
) -> Result<(), CliError> {
    std::fs::create_dir_all(out_dir)
        .map_err(|e| CliError::file(out_dir, format!("cannot create: {e}")))?;
    write_tum(&out_dir.join("ekf.tum"), &r.ekf)?;
    write_tum(&out_dir.join("vslam.tum"), &r.vslam)?;
    write_tum(&out_dir.join("wheel_only.tum"), &r.wheel_only)?;
    let mut report = r.report.clone();
    if !r.errors.is_empty() {
        let errs: serde_json::Map<String, Value> = r
            .errors
            .iter()
            .map(|(n, e)| {
                ((*n).to_string(), json!({"ate_rmse_m": e.ate_rmse, "final_error_m": e.final_error,
                    "final_error_pct_of_path": 100.0 * e.final_relative(), "path_length_m": e.path_length}))
            })
            .collect();
        report["errors"] = Value::Object(errs);
    }
    let text = serde_json::to_string_pretty(&report)
        .map_err(|e| CliError::file(out_dir, e.to_string()))?;
    let p = out_dir.join("report.json");
    std::fs::write(&p, text).map_err(|e| CliError::file(&p, format!("cannot write: {e}")))?;
    let xy = |v: &[TumPose]| v.iter().map(|p| (p.p[0], p.p[1])).collect::<Vec<_>>();
    let (e, v, w) = (xy(&r.ekf), xy(&r.vslam), xy(&r.wheel_only));
    let t: Vec<(f64, f64)> = truth
        .map(|g| g.iter().map(|g| (g.p[0], g.p[1])).collect())
        .unwrap_or_default();
    let mut series = vec![
        Series {
            label: "EKF",
            colour: "#d62728",
            points: &e,
        },
        Series {
            label: "VSLAM (metric scale)",
            colour: "#1f77b4",
            points: &v,
        },
        Series {
            label: "wheel only",
            colour: "#ff7f0e",
            points: &w,
        },
    ];
    if !t.is_empty() {
        series.insert(
            0,
            Series {
                label: "truth",
                colour: "black",
                points: &t,
            },
        );
    }
    let p = out_dir.join("trajectory.svg");
    std::fs::write(&p, top_view("traction: top view", &series))
        .map_err(|e| CliError::file(&p, format!("cannot write: {e}")))
}

/// The summary table printed after a run with ground truth.
pub fn summary_table(r: &ReplayOutput) -> String {
    let mut s = String::new();
    s += "trajectory   ATE RMSE [m]  final error [m]  final / path\n";
    for (n, e) in &r.errors {
        s += &format!(
            "{n:<12} {:>12.3}  {:>15.3}  {:>11.2} %\n",
            e.ate_rmse,
            e.final_error,
            100.0 * e.final_relative()
        );
    }
    let frames = r.report["frames"].as_array().map(Vec::len).unwrap_or(0);
    let mut by_source = std::collections::BTreeMap::new();
    let mut slips = 0usize;
    for f in r.report["frames"].as_array().into_iter().flatten() {
        let key = f["source"]
            .as_str()
            .map(str::to_string)
            .unwrap_or_else(|| "no scale".into());
        *by_source.entry(key).or_insert(0usize) += 1;
        if f["slip_exceeded"].as_bool() == Some(true) {
            slips += 1;
        }
    }
    s += &format!("scale decisions over {frames} frame pairs: ");
    s += &by_source
        .iter()
        .map(|(k, v)| format!("{k} {v}"))
        .collect::<Vec<_>>()
        .join(", ");
    s += &format!("\nframe pairs with slip: {slips}\n");
    if let Some(n) = r.report["camera_path"]["corner_detections"].as_u64() {
        s += &format!(
            "corners detected on {n} of {} frames (the others carry the last pair's inliers)\n",
            r.report["camera_path"]["frames"]
        );
    }
    let c = &r.report["counts"];
    s += &format!(
        "gated samples: wheel {}, flow {}; rejected: imu {}, wheel {}, flow {}, camera {}\n",
        c["wheel"]["gated"],
        c["flow"]["gated"],
        c["imu"]["seen"]
            .as_u64()
            .unwrap_or(0)
            .saturating_sub(c["imu"]["fused"].as_u64().unwrap_or(0)),
        c["wheel"]["seen"].as_u64().unwrap_or(0).saturating_sub(
            c["wheel"]["fused"].as_u64().unwrap_or(0) + c["wheel"]["gated"].as_u64().unwrap_or(0)
        ),
        c["flow"]["seen"].as_u64().unwrap_or(0).saturating_sub(
            c["flow"]["fused"].as_u64().unwrap_or(0) + c["flow"]["gated"].as_u64().unwrap_or(0)
        ),
        c["camera"]["seen"]
            .as_u64()
            .unwrap_or(0)
            .saturating_sub(c["camera"]["fused"].as_u64().unwrap_or(0)),
    );
    let events = r.report["events"]
        .as_array()
        .map(|v| v.as_slice())
        .unwrap_or(&[]);
    let count = |k: &str| events.iter().filter(|e| e["kind"] == k).count();
    s += &format!(
        "events: suspected obstacles {}, threshold strips {}, surface noise {}\n",
        count("SuspectedObstacle"),
        count("ThresholdStrip"),
        count("SurfaceNoise")
    );
    s
}

/// Reads, replays and writes: the `replay` command's work.
pub fn run_replay(dataset: &Path, out: &Path, progress: bool) -> Result<ReplayOutput, CliError> {
    run_replay_with(dataset, out, progress, ReplayOptions::default())
}

/// [`run_replay`], run as `options` say.
pub fn run_replay_with(
    dataset: &Path,
    out: &Path,
    progress: bool,
    options: ReplayOptions,
) -> Result<ReplayOutput, CliError> {
    let ds = crate::asl::read_dataset(dataset)?;
    let r = replay_with(&ds, dataset, progress, options)?;
    write_outputs(out, &r, ds.groundtruth.as_deref())?;
    Ok(r)
}

/// Rejection reason names, for reports and tests.
pub fn reason_names() -> Vec<&'static str> {
    Reject::ALL.iter().map(|r| r.name()).collect()
}
