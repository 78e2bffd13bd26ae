//! The estimator's and the camera path's configuration for a replay, read
//! from the dataset's `sensor.yaml` files (ASL/EuRoC layout: one folder per
//! sensor under `mav0/`, each with its noise figures and `T_BS`).

use super::ReplayOptions;
use crate::asl::{CameraMeta, Dataset, SegMeta, WheelMeta};
use crate::calibrate::WheelGeometry;
use crate::error::CliError;
use std::path::{Path, PathBuf};
use traction::ego_ekf::ImuPlausibility;
use traction::ego_ekf::surface::floor_model::{CELL, CLASS_NAMES};
use traction::ego_ekf::surface::{
    ClassConfig, GripModel, GripTable, GroundCamera, SlipConfig, SurfaceConfig, SurfaceKind,
    WheelType,
};
use traction::estimator::EstimatorConfig;
use traction::frontend::FrontEndConfig;
use traction::vslam_core::decompose::PinholeIntrinsics;
use traction::vslam_core::geometry::Extrinsics;
use traction::vslam_core::robot::{
    FlowDescription, ImuDescription, ImuNoise, MountedSensor, RobotDescription, RobotError, Wheels,
};

/// `mav0/<sensor>/sensor.yaml` under the dataset's root.
pub(super) fn sensor_yaml(root: &Path, sensor: &str) -> PathBuf {
    root.join("mav0").join(sensor).join("sensor.yaml")
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

/// `table` without the expected slip: no prior slip on any floor, and the
/// wheel radii learning on every floor.
fn without_slip(table: GripTable) -> GripTable {
    let model = GripModel {
        slip_gain: 0.0,
        radius_min_grip: 0.0,
        ..*table.model()
    };
    table.with_model(model).unwrap_or(table)
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

/// What the reference floor model's maps of `cam1` frames are: the
/// camera's pose, its geometry at the map's resolution (one cell per
/// [`CELL`] x [`CELL`] pixels) and the model's class table.
pub(super) fn model_map_meta(cam1: &CameraMeta) -> SegMeta {
    let cell = CELL as f64;
    let [fu, fv, cu, cv] = cam1.intrinsics;
    let offset = 0.5 * (cell - 1.0);
    SegMeta {
        rate_hz: cam1.rate_hz,
        t_bs: cam1.t_bs,
        resolution: cam1.resolution.map(|r| r / CELL as u32),
        intrinsics: [
            fu / cell,
            fv / cell,
            (cu - offset) / cell,
            (cv - offset) / cell,
        ],
        classes: CLASS_NAMES
            .iter()
            .enumerate()
            .map(|(id, name)| (id as u8, (*name).to_string()))
            .collect(),
        ground_classes: vec![2, 3, 4, 5, 6],
    }
}

/// The robot a dataset describes: its `sensor.yaml` files (wheel geometry and
/// encoders, IMU noise, every `T_BS`, the flow optics), and for what they do
/// not say the robot-vacuum preset ([`RobotDescription::robot_vacuum`]: rim
/// speed, wheel path noise, flow noise; its wheels when `wheel0` is absent)
/// and, without `imu0`, an identity mounting with [`ImuNoise::default`]. A
/// description that does not validate is refused with the file to blame.
pub fn robot_description(ds: &Dataset, root: &Path) -> Result<RobotDescription, CliError> {
    robot_description_with(ds, root, None)
}

/// [`robot_description`] with the wheel radii and track of `wheels` in place
/// of `wheel0/sensor.yaml`'s (`replay --wheels FILE`, from `calibrate`).
pub fn robot_description_with(
    ds: &Dataset,
    root: &Path,
    wheels: Option<WheelGeometry>,
) -> Result<RobotDescription, CliError> {
    let yaml = |s: &str| sensor_yaml(root, s);
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
    let wheels = match wheel_meta(ds) {
        Some(m) => {
            // The odometry counts whole ticks per revolution; a fractional
            // resolution (a geared motor's encoder: 43.7 x 64 = 2796.8) is
            // rounded and the radii scaled so that a tick is the same
            // distance as before (exactly 1 for a whole resolution). A log
            // of wheel rates has no counts: the preset's stand, unused.
            let (counts, k) = match m.ticks_per_revolution {
                Some(t) => {
                    let counts = t.round().max(1.0);
                    (counts as u32, counts / t)
                }
                None => (preset.wheels.counts_per_revolution, 1.0),
            };
            let g = wheels.unwrap_or(WheelGeometry {
                radius_left: m.wheel_radius_left,
                radius_right: m.wheel_radius_right,
                track: m.wheel_base,
            });
            Wheels {
                radius_left: (g.radius_left * k) as f32,
                radius_right: (g.radius_right * k) as f32,
                track: g.track as f32,
                track_factor: m.track_factor as f32,
                steering: m.steering,
                counts_per_revolution: counts,
                ..preset.wheels
            }
        }
        None => preset.wheels,
    };
    // The raw frames' sensor.yaml describes the same sensor when the counts are absent.
    let flow_meta = match (&ds.flow, &ds.flowraw) {
        (Some((m, _)), _) => Some((m, "flow0")),
        (None, Some((m, _))) => Some((m, "flowraw0")),
        (None, None) => None,
    };
    let flow = match (flow_meta, preset.flow) {
        (Some((m, folder)), Some(flow)) => Some(FlowDescription {
            mount: extrinsics(&yaml(folder), &m.t_bs)?,
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

/// `wheel0/sensor.yaml`, of ticks or of rates.
fn wheel_meta(ds: &Dataset) -> Option<&WheelMeta> {
    ds.wheel
        .as_ref()
        .map(|(m, _)| m)
        .or(ds.wheel_rates.as_ref().map(|(m, _)| m))
}

fn sensor_folder(s: MountedSensor) -> &'static str {
    match s {
        MountedSensor::Imu => "imu0",
        MountedSensor::Flow => "flow0",
        MountedSensor::Camera => "cam0",
    }
}

/// The IMU's sample rate, Hz: from the median step between consecutive
/// samples of `imu0` (what the log holds), or, with fewer than two
/// increasing samples, `rate_hz` of `imu0/sensor.yaml`; `None` without an IMU.
pub fn imu_rate_hz(ds: &Dataset) -> Option<f32> {
    let (meta, samples) = ds.imu.as_ref()?;
    let mut steps: Vec<u64> = samples
        .windows(2)
        .filter_map(|w| w[1].t.nanos_since(w[0].t))
        .filter(|&d| d > 0)
        .collect();
    if steps.is_empty() {
        return Some(meta.rate_hz as f32);
    }
    let mid = steps.len() / 2;
    let median = *steps.select_nth_unstable(mid).1;
    Some((1.0e9 / median as f64) as f32)
}

/// The wheels' sample rate, Hz: from the median step between consecutive
/// samples of `wheel0` (ticks or angular rates); `None` without wheels or
/// with fewer than two increasing samples.
pub fn wheel_rate_hz(ds: &Dataset) -> Option<f32> {
    let times: Vec<u64> = match (&ds.wheel, &ds.wheel_rates) {
        (Some((_, s)), _) => s.iter().map(|w| w.t.as_nanos()).collect(),
        (None, Some((_, s))) => s.iter().map(|w| w.t.as_nanos()).collect(),
        (None, None) => return None,
    };
    let mut steps: Vec<u64> = times
        .windows(2)
        .map(|w| w[1].saturating_sub(w[0]))
        .filter(|&d| d > 0)
        .collect();
    if steps.is_empty() {
        return None;
    }
    let mid = steps.len() / 2;
    let median = *steps.select_nth_unstable(mid).1;
    Some((1.0e9 / median as f64) as f32)
}

/// The estimator's configuration: [`EstimatorConfig::from_robot`] on the
/// dataset's [`robot_description`], the filter's sample counts and largest
/// IMU step for the IMU's rate ([`imu_rate_hz`],
/// [`FilterConfig::with_imu_rate`](traction::ego_ekf::FilterConfig::with_imu_rate)),
/// the wheels' re-examination count for their rate ([`wheel_rate_hz`],
/// [`FilterConfig::with_wheel_rate`](traction::ego_ekf::FilterConfig::with_wheel_rate)),
/// the IMU's readings judged as a real IMU's
/// ([`ImuPlausibility::FIELD`]: rate jumps and frozen outputs refused),
/// the surface model from `seg0`, and the scale pipeline's selection method,
/// composition and distance and the scale pipeline's distrust of the wheels
/// passed to the EKF as `options` say.
pub(crate) fn estimator_config(
    ds: &Dataset,
    root: &Path,
    options: &ReplayOptions,
) -> Result<EstimatorConfig, CliError> {
    let robot = robot_description_with(ds, root, options.wheels)?;
    let mut config = EstimatorConfig::from_robot(&robot)
        .map_err(|e| CliError::file(root, format!("configuration: {e}")))?;
    if let Some(hz) = imu_rate_hz(ds) {
        config.filter = config.filter.with_imu_rate(hz);
    }
    if let Some(hz) = wheel_rate_hz(ds) {
        config.filter = config.filter.with_wheel_rate(hz);
    }
    let wheel_type_name = wheel_meta(ds).map_or("", |m| m.wheel_type.as_str());
    config.surface = match (&ds.seg, &ds.cam1) {
        (Some((m, _)), _) if options.surface_model => Some(surface_config(
            m,
            wheel_type_name,
            &sensor_yaml(root, "seg0"),
        )?),
        (None, Some((c, _))) if options.surface_model => Some(surface_config(
            &model_map_meta(c),
            wheel_type_name,
            &sensor_yaml(root, "cam1"),
        )?),
        _ => None,
    };
    if let (Some(surface), false) = (config.surface.as_mut(), options.expected_slip) {
        surface.table = without_slip(surface.table);
        surface.slip = SlipConfig::off();
    }
    if !options.wheel_distrust {
        config.wheel_distrust = None;
    }
    config.filter.imu.estimate_gyro_scale = options.gyro_scale;
    // Simulated and recorded IMUs are noisy: a reading repeated bit for bit
    // is a frozen output.
    config.filter.imu.plausibility = Some(ImuPlausibility::FIELD);
    if let Some(m) = options.scale_method {
        config.scale.method = m;
    }
    if let Some(c) = options.compose {
        config.scale.compose = c;
    }
    if let Some(d) = options.distance {
        config.scale.distance = d;
    }
    Ok(config)
}

/// The camera path's configuration from `cam0/sensor.yaml` (resolution and
/// intrinsics) and the camera's mounting; `None` without a camera.
pub(crate) fn frontend_config(
    ds: &Dataset,
    root: &Path,
    camera_mount: Extrinsics,
    options: &ReplayOptions,
) -> Result<Option<FrontEndConfig>, CliError> {
    let cam = ds.cam.as_ref();
    let (w, h) = cam
        .map(|(m, _)| (m.resolution[0] as usize, m.resolution[1] as usize))
        .unwrap_or((1, 1));
    cam.map(|(m, _)| {
        let [fu, fv, cu, cv] = m.intrinsics.map(|v| v as f32);
        PinholeIntrinsics::new(fu, fv, cu, cv)
            .map(|k| {
                let mut c = FrontEndConfig::new(w, h, k, camera_mount);
                if let Some(n) = options.redetect_below {
                    c.redetect_below = n;
                }
                c
            })
            .map_err(|e| CliError::file(&sensor_yaml(root, "cam0"), format!("`intrinsics`: {e:?}")))
    })
    .transpose()
}
