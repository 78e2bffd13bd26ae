//! The estimator's and the camera path's configuration for a replay, read
//! from the dataset's `sensor.yaml` files (ASL/EuRoC layout: one folder per
//! sensor under `mav0/`, each with its noise figures and `T_BS`).

use super::ReplayOptions;
use crate::asl::{Dataset, SegMeta, WheelMeta};
use crate::error::CliError;
use std::path::{Path, PathBuf};
use traction::ego_ekf::events::JoltConfig;
use traction::ego_ekf::surface::{
    ClassConfig, GroundCamera, SurfaceConfig, SurfaceKind, WheelType,
};
use traction::ego_ekf::{FilterConfig, FlowConfig};
use traction::estimator::EstimatorConfig;
use traction::frontend::FrontEndConfig;
use traction::vslam_core::decompose::PinholeIntrinsics;
use traction::vslam_core::geometry::{Extrinsics, Vec3};
use traction::vslam_core::scale::PipelineConfig;
use traction::vslam_core::sensors::FlowOptics;
use traction::wheel_odom::odometry::DiffDriveParams;

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

/// The surface model's configuration from `seg0/sensor.yaml`: the class
/// table, and the ground geometry of the camera that took the maps
/// (intrinsics, resolution and `T_BS`).
fn surface_config(
    m: &SegMeta,
    wheel_meta: &WheelMeta,
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
        wheel_type(&wheel_meta.wheel_type),
        ClassConfig::from_lists(&pairs, &ground),
        camera,
    ))
}

/// The estimator's configuration from the dataset's metadata: IMU noise,
/// wheel geometry (defaults when there are no wheels), flow optics, the
/// camera's and the IMU's mountings and the surface model.
pub(super) fn estimator_config(
    ds: &Dataset,
    root: &Path,
    options: ReplayOptions,
) -> Result<EstimatorConfig, CliError> {
    let mut filter = FilterConfig::default();
    if let Some((m, _)) = &ds.imu {
        filter.imu_noise.accel_density = m.accelerometer_noise_density as f32;
        filter.imu_noise.gyro_density = m.gyroscope_noise_density as f32;
        filter.imu_noise.accel_random_walk = m.accelerometer_random_walk as f32;
        filter.imu_noise.gyro_random_walk = m.gyroscope_random_walk as f32;
    }
    let default_wheels = WheelMeta {
        rate_hz: 50.0,
        ticks_per_revolution: 1024.0,
        wheel_radius_left: filter.robot.radius as f64,
        wheel_radius_right: filter.robot.radius as f64,
        wheel_base: 0.23,
        wheel_type: String::new(),
    };
    let wheel_meta = ds.wheel.as_ref().map(|(m, _)| m).unwrap_or(&default_wheels);
    let half = 0.5 * wheel_meta.wheel_base as f32;
    filter.robot.p_bl = Vec3::new(0.0, half, 0.0);
    filter.robot.p_br = Vec3::new(0.0, -half, 0.0);
    filter.robot.radius =
        (0.5 * (wheel_meta.wheel_radius_left + wheel_meta.wheel_radius_right)) as f32;
    let yaml = |s: &str| root.join("mav0").join(s).join("sensor.yaml");
    let flow_optics = match &ds.flow {
        Some((m, _)) => Some(
            FlowOptics::new(
                m.counts_per_radian as f32,
                m.height as f32,
                extrinsics(&yaml("flow0"), &m.t_bs)?,
            )
            .map_err(|e| CliError::file(&yaml("flow0"), e.to_string()))?,
        ),
        None => None,
    };
    filter.flow = flow_optics.map(FlowConfig::new);
    let odometry = DiffDriveParams::new(
        wheel_meta.ticks_per_revolution.round() as u32,
        wheel_meta.wheel_radius_left as f32,
        wheel_meta.wheel_radius_right as f32,
        wheel_meta.wheel_base as f32,
        3.0,
        500_000_000,
    )
    .map_err(|e| CliError::file(&yaml("wheel0"), format!("{e:?}")))?;
    let camera_mount = match &ds.cam {
        Some((m, _)) => extrinsics(&yaml("cam0"), &m.t_bs)?,
        None => Extrinsics::identity(),
    };
    let scale = PipelineConfig {
        camera: camera_mount,
        imu: match &ds.imu {
            Some((m, _)) => extrinsics(&yaml("imu0"), &m.t_bs)?,
            None => Extrinsics::identity(),
        },
        flow_optics,
        ..PipelineConfig::default()
    };
    let surface = match &ds.seg {
        Some((m, _)) if options.surface_model => {
            Some(surface_config(m, wheel_meta, &yaml("seg0"))?)
        }
        _ => None,
    };
    let config = EstimatorConfig {
        filter,
        odometry,
        scale,
        surface,
        jolts: JoltConfig::default(),
        reorder_window_ns: 20_000_000,
    };
    Ok(config)
}

/// The camera path's configuration from `cam0/sensor.yaml` (resolution and
/// intrinsics) and the camera's mounting; `None` without a camera.
pub(super) fn frontend_config(
    ds: &Dataset,
    root: &Path,
    camera_mount: Extrinsics,
    options: ReplayOptions,
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
