//! BorealTC logs (Husky A200; "Proprioception Is All You Need: Terrain
//! Classification for Boreal Forests", IROS 2024; data CC0 1.0): one
//! sequence is an IMU file and a "pro" file, both with a header and `time`
//! in seconds from 0, in a folder named for the terrain (`ASPHALT`, `ICE`,
//! ...).
//!
//! - `imu_NN.csv`: `time,wx,wy,wz,ax,ay,az` [rad/s, m/s^2], body axes
//!   (x forward, y left, z up; specific force, +9.8 on z at rest; wz > 0
//!   counter-clockwise), 100 Hz: written to `imu0` as it is, `T_BS`
//!   identity.
//! - `pro_NN.csv`: `time,curL,curR,velL,velR`: motor currents [A] (not
//!   imported) and wheel speeds [m/s], 6.5 Hz: written to the `wheel0`
//!   rates variant as `vel / radius` rad/s, radius 0.13 m as the upstream
//!   code divides by.
//!
//! The Husky skid-steers: its physical track is 0.555 m, but its turn rate
//! from the wheel speeds is as if the wheels were about 1.0 m apart
//! (`(velR - velL) / wz`: 0.8 m on ice, 1.0 m on sandy loam per the data's
//! README; the upstream code uses 1.1 m). `wheel0/sensor.yaml` says
//! `wheel_base` 0.555 and `track_factor` = effective / physical. The IMU's
//! noise figures are not given: a consumer MEMS IMU's
//! ([`ImuNoise::default`](vslam_core::robot::ImuNoise)) are written, and
//! `labels.yaml` says so, with the terrain.

use super::{HeadedRow, median_rate_hz, read_headed_csv};
use crate::asl::{Dataset, ImuMeta, Labels, WheelMeta};
use crate::error::CliError;
use std::path::Path;
use vslam_core::robot::ImuNoise;
use vslam_core::sensors::{RawImuSample, RawWheelRates};

/// The Husky's geometry as the importer writes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HuskyGeometry {
    /// Wheel radius, m (0.13, as the upstream code).
    pub wheel_radius: f64,
    /// Physical track, m (0.555).
    pub track: f64,
    /// Effective (kinematic) track of the skid steer, m (1.0).
    pub effective_track: f64,
}

impl Default for HuskyGeometry {
    fn default() -> Self {
        HuskyGeometry {
            wheel_radius: 0.13,
            track: 0.555,
            effective_track: 1.0,
        }
    }
}

/// Column names of the IMU file.
pub const IMU_COLUMNS: [&str; 6] = ["wx", "wy", "wz", "ax", "ay", "az"];
/// Column names of the wheel-speed file that are imported.
pub const PRO_COLUMNS: [&str; 2] = ["velL", "velR"];

/// The IMU file's samples.
pub fn parse_imu(path: &Path, text: &str) -> Result<Vec<RawImuSample>, CliError> {
    let rows = read_headed_csv(path, text, &IMU_COLUMNS)?;
    Ok(rows
        .iter()
        .map(|r| {
            let v = |i: usize| r.values.get(i).copied().unwrap_or(0.0) as f32;
            RawImuSample {
                t: r.t,
                gyro: [v(0), v(1), v(2)],
                accel: [v(3), v(4), v(5)],
            }
        })
        .collect())
}

/// The wheel-speed file's rows: time and `velL`, `velR` in m/s.
pub fn parse_pro(path: &Path, text: &str) -> Result<Vec<HeadedRow>, CliError> {
    read_headed_csv(path, text, &PRO_COLUMNS)
}

/// The dataset of a parsed sequence. `imu_path` and `pro_path` name the
/// files in the labels.
pub fn to_dataset(
    imu_path: &Path,
    imu: Vec<RawImuSample>,
    pro_path: &Path,
    pro: &[HeadedRow],
    terrain: &str,
    g: HuskyGeometry,
) -> Result<Dataset, CliError> {
    let bad_geometry =
        |what: &str| CliError::Usage(format!("{what}: must be a positive number of metres"));
    if !(g.wheel_radius.is_finite() && g.wheel_radius > 0.0) {
        return Err(bad_geometry("--wheel-radius"));
    }
    if !(g.track.is_finite() && g.track > 0.0) {
        return Err(bad_geometry("--track"));
    }
    if !(g.effective_track.is_finite() && g.effective_track > 0.0) {
        return Err(bad_geometry("--effective-track"));
    }
    let imu_rate = median_rate_hz(imu.iter().map(|s| s.t.0))
        .ok_or_else(|| CliError::file(imu_path, "needs at least two rows of data"))?;
    let pro_rate = median_rate_hz(pro.iter().map(|r| r.t.0))
        .ok_or_else(|| CliError::file(pro_path, "needs at least two rows of data"))?;
    let rates = pro
        .iter()
        .map(|r| {
            let v = |i: usize| r.values.get(i).copied().unwrap_or(0.0);
            RawWheelRates {
                t: r.t,
                left: (v(0) / g.wheel_radius) as f32,
                right: (v(1) / g.wheel_radius) as f32,
            }
        })
        .collect();
    let noise = ImuNoise::default();
    let identity = [
        1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
    ];
    let imu_meta = ImuMeta {
        t_bs: identity,
        rate_hz: imu_rate,
        gyroscope_noise_density: f64::from(noise.gyro_density),
        gyroscope_random_walk: f64::from(noise.gyro_random_walk),
        accelerometer_noise_density: f64::from(noise.accel_density),
        accelerometer_random_walk: f64::from(noise.accel_random_walk),
    };
    let wheel_meta = WheelMeta {
        rate_hz: pro_rate,
        ticks_per_revolution: None,
        wheel_radius_left: g.wheel_radius,
        wheel_radius_right: g.wheel_radius,
        wheel_base: g.track,
        track_factor: g.effective_track / g.track,
        steering: vslam_core::robot::Steering::Skid,
        wheel_type: "soft_rubber".into(),
    };
    let name = |p: &Path| {
        p.file_name().map_or_else(
            || p.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
    };
    let mut labels = Labels::default();
    labels
        .set("source", format!("borealtc {terrain}/{} + {}", name(imu_path), name(pro_path)))
        .set("reference", "none")
        .set("terrain", terrain)
        .note(format!(
            "wheel0 holds velL, velR (m/s) over a {} m wheel radius; the dataset's speeds take only values k/127 m/s and may be set-points",
            g.wheel_radius
        ))
        .note(format!(
            "skid steer: physical track {} m, effective {} m (track_factor {:.3})",
            g.track,
            g.effective_track,
            g.effective_track / g.track
        ))
        .note("IMU noise figures are not in the dataset: a consumer MEMS IMU's are written");
    Ok(Dataset {
        imu: Some((imu_meta, imu)),
        wheel_rates: Some((wheel_meta, rates)),
        labels: Some(labels),
        ..Dataset::default()
    })
}

/// The terrain label of a sequence: the name of the folder holding the IMU
/// file (`ASPHALT` for `.../ASPHALT/imu_00.csv`).
pub fn terrain_of(imu_path: &Path) -> Option<String> {
    let dir = imu_path.canonicalize().ok()?;
    dir.parent()?
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
}

fn read_text(path: &Path) -> Result<String, CliError> {
    std::fs::read_to_string(path).map_err(|e| CliError::file(path, format!("cannot read: {e}")))
}

/// Reads a sequence into a dataset; `terrain` defaults to the IMU file's
/// folder name.
pub fn read(
    imu_path: &Path,
    pro_path: &Path,
    terrain: Option<&str>,
    g: HuskyGeometry,
) -> Result<Dataset, CliError> {
    let imu = parse_imu(imu_path, &read_text(imu_path)?)?;
    let pro = parse_pro(pro_path, &read_text(pro_path)?)?;
    let terrain = match terrain {
        Some(t) => t.to_string(),
        None => terrain_of(imu_path).unwrap_or_else(|| "unknown".into()),
    };
    to_dataset(imu_path, imu, pro_path, &pro, &terrain, g)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn speeds_become_wheel_rates_and_the_track_a_factor() {
        let imu = parse_imu(
            Path::new("imu_00.csv"),
            "time,wx,wy,wz,ax,ay,az\n0.0,0,0,0.1,0,0,9.8\n0.01,0,0,0.2,0.1,0,9.81\n",
        )
        .unwrap();
        assert_eq!(imu[1].gyro, [0.0, 0.0, 0.2]);
        assert_eq!(imu[1].accel, [0.1, 0.0, 9.81]);
        let pro = parse_pro(
            Path::new("pro_00.csv"),
            "time,curL,curR,velL,velR\n0.0,1,2,0.26,0.13\n0.15384615384615385,1,2,-0.13,0\n",
        )
        .unwrap();
        let ds = to_dataset(
            Path::new("imu_00.csv"),
            imu,
            Path::new("pro_00.csv"),
            &pro,
            "ICE",
            HuskyGeometry::default(),
        )
        .unwrap();
        let (meta, rates) = ds.wheel_rates.unwrap();
        assert_eq!((rates[0].left, rates[0].right), (2.0, 1.0));
        assert_eq!((rates[1].left, rates[1].right), (-1.0, 0.0));
        assert_eq!(rates[1].t.0, 153_846_154);
        assert!((meta.rate_hz - 6.5).abs() < 1e-6);
        assert!((meta.track_factor * meta.wheel_base - 1.0).abs() < 1e-12);
        assert_eq!(meta.ticks_per_revolution, None);
        assert!((ds.imu.unwrap().0.rate_hz - 100.0).abs() < 1e-9);
        assert_eq!(ds.labels.unwrap().get("terrain"), Some("ICE"));
    }

    #[test]
    fn malformed_files_name_the_line() {
        let e = parse_pro(Path::new("pro.csv"), "time,curL,curR,velL\n0,1,2,3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("pro.csv:1: header has no column `velR`"), "{e}");
        let e = parse_imu(
            Path::new("imu.csv"),
            "time,wx,wy,wz,ax,ay,az\n0,0,0,0,0,0,9.8\n0.01,0,0,0,0,0,x\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("imu.csv:3: az: `x` is not a number"), "{e}");
    }
}
