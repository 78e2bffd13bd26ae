//! ASL/EuRoC dataset folders: `mav0/<sensor>/data.csv` + `sensor.yaml`.
//!
//! The exact columns (integer nanosecond time stamps; body frame x forward,
//! y left, z up; `T_BS` with `p_B = R_BS p_S + t_BS`; Hamilton quaternions):
//!
//! | folder | columns |
//! |---|---|
//! | `imu0` | `#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]` |
//! | `wheel0` | `#timestamp [ns],left [ticks],right [ticks]` (cumulative) |
//! | `wheel0`, rates | `#timestamp [ns],left [rad s^-1],right [rad s^-1]` (wheel angular rates at the time stamp, positive forward; `sensor.yaml` without `ticks_per_revolution`) |
//! | `flow0` | `#timestamp [ns],delta_x [counts],delta_y [counts],squal,shutter` |
//! | `flowraw0` | `#timestamp [ns],filename,shutter` (the flow sensor's raw 35x35 frames, one 8-bit gray PNG per grab in `data/`; the shutter register at the grab; `sensor.yaml` as `flow0`'s, `rate_hz` the grab rate) |
//! | `cam0`, `seg0`, `cam1` | `#timestamp [ns],filename` (images in `data/`) |
//! | `state_groundtruth_estimate0` | the 17 EuRoC ground-truth columns |
//! | `imu0`, `wheel0`, `flow0`: `failed.csv` (optional, beside `data.csv`) | `#timestamp [ns],reason`: reads that failed before they produced a sample (`bus`, `integrity`, any [`Reject`] name), as the driver reported them |
//!
//! Any sensor folder may be absent; [`Dataset::missing`] names what is.
//! A failed read leaves no row in `data.csv`. A wheel read whose counter
//! extension refused a jump (`out_of_range`) breaks the count stream: the
//! next row's counts are anchored afresh, not a step from the row before
//! the failure; across a missed one (`bus`, `integrity`) the counts
//! continue, and the next row is a step across it when it continues the
//! previous one. `failed.csv` keeps those reads, so that a replay counts
//! them and hands them to the odometry as the recording robot did
//! ([`Dataset::failed`]).
//!
//! Syntax errors (a wrong column count, text that is not a number, a
//! missing file) are errors naming the file and line. Sample values that
//! parse but are bad (NaN or infinite numbers, duplicated or out-of-order
//! time stamps in `imu0`, `wheel0`, `flow0`) are kept in file order for the
//! estimator to reject and count, as on a robot ([`BadSamples::PassOn`]), or
//! refused like syntax errors ([`BadSamples::Refuse`], `replay --strict`).
//! Ground truth and image lists must always be finite and strictly
//! increasing in time.
//! Beside `mav0/`, an optional `labels.yaml` ([`Labels`]) says where the
//! data came from and what it lacks.

pub(crate) mod csvio;
mod labels;
mod meta;
pub(crate) mod yaml;

pub use labels::{LABELS_FILE, Labels};
pub use meta::{CameraMeta, FlowMeta, ImuMeta, SegMeta, WheelMeta};

use crate::error::CliError;
use std::path::{Path, PathBuf};
use vslam_core::sensors::{FlowSample, RawImuSample, RawWheelRates, WheelTicks};
use vslam_core::{Reject, Stream, Timestamp};

/// Header of `imu0/data.csv`.
pub const IMU_HEADER: &str = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]";
/// Header of `wheel0/data.csv`.
pub const WHEEL_HEADER: &str = "#timestamp [ns],left [ticks],right [ticks]";
/// Header of `wheel0/data.csv` holding wheel angular rates (the variant for
/// robots that report rates, not counts; told apart by this header).
pub const WHEEL_RATES_HEADER: &str = "#timestamp [ns],left [rad s^-1],right [rad s^-1]";
/// Header of `flow0/data.csv`.
pub const FLOW_HEADER: &str = "#timestamp [ns],delta_x [counts],delta_y [counts],squal,shutter";
/// Header of `flowraw0/data.csv`.
pub const FLOWRAW_HEADER: &str = "#timestamp [ns],filename,shutter";
/// Header of `cam0/data.csv` and `seg0/data.csv`.
pub const IMAGE_HEADER: &str = "#timestamp [ns],filename";
/// Header of a sensor folder's `failed.csv` (reads that failed).
pub const FAILED_HEADER: &str = "#timestamp [ns],reason";
/// The sensor folders that may hold a `failed.csv`, with their streams.
pub const FAILED_STREAMS: [(&str, Stream); 3] = [
    ("imu0", Stream::Imu),
    ("wheel0", Stream::Wheel),
    ("flow0", Stream::Flow),
];

/// A read that failed before it produced a sample, as the log recorded it
/// (`mav0/<sensor>/failed.csv`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoggedFailure {
    /// When the read was made.
    pub t: Timestamp,
    /// The stream that lost the sample.
    pub stream: Stream,
    /// The driver's error, as its reason.
    pub reason: Reject,
}

/// Header of `state_groundtruth_estimate0/data.csv`.
pub const GROUNDTRUTH_HEADER: &str = "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]";

/// One image of a camera or segmentation stream.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageEntry {
    /// When the image was taken.
    pub t: Timestamp,
    /// Path of the image file (absolute or relative to the working directory).
    pub path: PathBuf,
}

/// One ground-truth row (EuRoC columns).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundTruth {
    /// Time stamp.
    pub t: Timestamp,
    /// Position of the body in the world, metres.
    pub p: [f64; 3],
    /// Attitude, Hamilton quaternion `w, x, y, z`.
    pub q_wxyz: [f64; 4],
    /// Velocity in the world, m/s.
    pub v: [f64; 3],
    /// Gyroscope bias, rad/s.
    pub bias_gyro: [f64; 3],
    /// Accelerometer bias, m/s^2.
    pub bias_accel: [f64; 3],
}

/// One raw frame of the flow sensor (`flowraw0`).
#[derive(Clone, Debug, PartialEq)]
pub struct FlowFrameEntry {
    /// When the frame was grabbed.
    pub t: Timestamp,
    /// Path of the PNG (absolute or relative to the working directory).
    pub path: PathBuf,
    /// The shutter register at the grab.
    pub shutter: u16,
}

/// A whole dataset in memory (images stay on disk, by path).
#[derive(Clone, Debug, Default)]
pub struct Dataset {
    /// IMU stream.
    pub imu: Option<(ImuMeta, Vec<RawImuSample>)>,
    /// Wheel encoder stream.
    pub wheel: Option<(WheelMeta, Vec<WheelTicks>)>,
    /// Wheel angular rates (the `wheel0` variant; never with `wheel`).
    pub wheel_rates: Option<(WheelMeta, Vec<RawWheelRates>)>,
    /// Optical-flow stream.
    pub flow: Option<(FlowMeta, Vec<FlowSample>)>,
    /// The flow sensor's raw frames.
    pub flowraw: Option<(FlowMeta, Vec<FlowFrameEntry>)>,
    /// Upward camera frames.
    pub cam: Option<(CameraMeta, Vec<ImageEntry>)>,
    /// Segmentation label maps.
    pub seg: Option<(SegMeta, Vec<ImageEntry>)>,
    /// Forward camera frames (`cam1`) a segmentation model labels when
    /// there are no maps (`seg0`).
    pub cam1: Option<(CameraMeta, Vec<ImageEntry>)>,
    /// Ground truth, when recorded.
    pub groundtruth: Option<Vec<GroundTruth>>,
    /// `labels.yaml`, when present.
    pub labels: Option<Labels>,
    /// Reads that failed (the sensor folders' `failed.csv`), by stream in
    /// [`FAILED_STREAMS`] order, each in file order.
    pub failed: Vec<LoggedFailure>,
}

impl Dataset {
    /// Names of the sensor folders that are absent.
    pub fn missing(&self) -> Vec<&'static str> {
        let mut m = Vec::new();
        if self.imu.is_none() {
            m.push("imu0");
        }
        if self.wheel.is_none() && self.wheel_rates.is_none() {
            m.push("wheel0");
        }
        if self.flow.is_none() {
            m.push("flow0");
        }
        if self.cam.is_none() {
            m.push("cam0");
        }
        if self.seg.is_none() {
            m.push("seg0");
        }
        if self.groundtruth.is_none() {
            m.push("state_groundtruth_estimate0");
        }
        m
    }
}

/// What [`read_dataset_with`] does with sample values that parse but are
/// bad: NaN or infinite numbers, duplicated or out-of-order time stamps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BadSamples {
    /// Kept, in file order, for the estimator to reject and count.
    #[default]
    PassOn,
    /// Refused with an error naming the file and line.
    Refuse,
}

impl BadSamples {
    fn rows(self, path: &Path, columns: usize) -> Result<Vec<csvio::Row>, CliError> {
        match self {
            BadSamples::PassOn => csvio::read_rows_any_order(path, columns),
            BadSamples::Refuse => csvio::read_rows(path, columns),
        }
    }

    /// Field `i` as the `f32` the estimator takes. Refused, a value that is
    /// finite as text but overflows `f32` (`5e51`) is an error like `inf`.
    fn value(self, r: &csvio::Row, path: &Path, i: usize, name: &str) -> Result<f32, CliError> {
        match self {
            BadSamples::PassOn => Ok(r.number(path, i, name)? as f32),
            BadSamples::Refuse => r.f32(path, i, name),
        }
    }
}

fn sensor_dir(root: &Path, name: &str) -> Option<PathBuf> {
    let d = root.join("mav0").join(name);
    d.is_dir().then_some(d)
}

/// Reads a dataset folder (the folder that contains `mav0/`), passing bad
/// sample values on ([`BadSamples::PassOn`]).
pub fn read_dataset(root: &Path) -> Result<Dataset, CliError> {
    read_dataset_with(root, BadSamples::PassOn)
}

/// Reads a dataset folder (the folder that contains `mav0/`), bad sample
/// values treated as `bad` says.
pub fn read_dataset_with(root: &Path, bad: BadSamples) -> Result<Dataset, CliError> {
    let mut ds = read_streams(root, bad)?;
    ds.failed = read_failed(root, bad)?;
    Ok(ds)
}

/// The sensor folders' `failed.csv` ([`FAILED_HEADER`]), where present.
fn read_failed(root: &Path, bad: BadSamples) -> Result<Vec<LoggedFailure>, CliError> {
    let mut out = Vec::new();
    for (name, stream) in FAILED_STREAMS {
        let p = root.join("mav0").join(name).join("failed.csv");
        if !p.is_file() {
            continue;
        }
        for r in bad.rows(&p, 2)? {
            let text = r.field(&p, 0, "reason")?;
            let reason = Reject::ALL
                .into_iter()
                .find(|x| x.name() == text)
                .ok_or_else(|| {
                    CliError::line(
                        &p,
                        r.line,
                        format!("reason: `{text}` is not a reject reason"),
                    )
                })?;
            out.push(LoggedFailure {
                t: r.t,
                stream,
                reason,
            });
        }
    }
    Ok(out)
}

/// The sample, image and ground-truth streams of the folder at `root`.
fn read_streams(root: &Path, bad: BadSamples) -> Result<Dataset, CliError> {
    let mav0 = root.join("mav0");
    if !mav0.is_dir() {
        return Err(CliError::file(
            root,
            "not an ASL dataset folder: no `mav0/` inside",
        ));
    }
    let mut ds = Dataset::default();
    if let Some(d) = sensor_dir(root, "imu0") {
        let meta = ImuMeta::read(&d.join("sensor.yaml"))?;
        let p = d.join("data.csv");
        let mut v = Vec::new();
        for r in bad.rows(&p, 7)? {
            let mut x = [0f32; 6];
            for (i, slot) in x.iter_mut().enumerate() {
                *slot = bad.value(&r, &p, i, IMU_COLUMNS[i])?;
            }
            v.push(RawImuSample {
                t: r.t,
                gyro: [x[0], x[1], x[2]],
                accel: [x[3], x[4], x[5]],
            });
        }
        ds.imu = Some((meta, v));
    }
    if let Some(d) = sensor_dir(root, "wheel0") {
        let yaml = d.join("sensor.yaml");
        let meta = WheelMeta::read(&yaml)?;
        let p = d.join("data.csv");
        if csvio::first_line(&p)?.trim() == WHEEL_RATES_HEADER {
            let mut v = Vec::new();
            for r in bad.rows(&p, 3)? {
                v.push(RawWheelRates {
                    t: r.t,
                    left: bad.value(&r, &p, 0, "left")?,
                    right: bad.value(&r, &p, 1, "right")?,
                });
            }
            ds.wheel_rates = Some((meta, v));
        } else {
            if meta.ticks_per_revolution.is_none() {
                return Err(CliError::file(
                    &yaml,
                    "missing key `ticks_per_revolution` (data.csv holds ticks)",
                ));
            }
            let mut v = Vec::new();
            for r in bad.rows(&p, 3)? {
                v.push(WheelTicks {
                    t: r.t,
                    left: r.int(&p, 0, "left")?,
                    right: r.int(&p, 1, "right")?,
                });
            }
            ds.wheel = Some((meta, v));
        }
    }
    if let Some(d) = sensor_dir(root, "flow0") {
        let meta = FlowMeta::read(&d.join("sensor.yaml"))?;
        let p = d.join("data.csv");
        let mut v = Vec::new();
        for r in bad.rows(&p, 5)? {
            let (dx, dy) = (r.int(&p, 0, "delta_x")?, r.int(&p, 1, "delta_y")?);
            v.push(FlowSample {
                t: r.t,
                dx,
                dy,
                squal: r.int(&p, 2, "squal")?,
                shutter: r.int(&p, 3, "shutter")?,
                // The log has no motion column: motion is counts that moved.
                motion: dx != 0 || dy != 0,
                ..FlowSample::default()
            });
        }
        ds.flow = Some((meta, v));
    }
    if let Some(d) = sensor_dir(root, "flowraw0") {
        let meta = FlowMeta::read(&d.join("sensor.yaml"))?;
        ds.flowraw = Some((meta, read_flow_frames(&d)?));
    }
    if let Some(d) = sensor_dir(root, "cam0") {
        let meta = CameraMeta::read(&d.join("sensor.yaml"))?;
        ds.cam = Some((meta, read_images(&d)?));
    }
    if let Some(d) = sensor_dir(root, "seg0") {
        let meta = SegMeta::read(&d.join("sensor.yaml"))?;
        ds.seg = Some((meta, read_images(&d)?));
    }
    if let Some(d) = sensor_dir(root, "cam1") {
        let meta = CameraMeta::read(&d.join("sensor.yaml"))?;
        ds.cam1 = Some((meta, read_images(&d)?));
    }
    if let Some(d) = sensor_dir(root, "state_groundtruth_estimate0") {
        let p = d.join("data.csv");
        let mut v = Vec::new();
        for r in csvio::read_rows(&p, 17)? {
            let mut x = [0f64; 16];
            for (i, slot) in x.iter_mut().enumerate() {
                *slot = r.f64(&p, i, "ground truth")?;
            }
            v.push(GroundTruth {
                t: r.t,
                p: [x[0], x[1], x[2]],
                q_wxyz: [x[3], x[4], x[5], x[6]],
                v: [x[7], x[8], x[9]],
                bias_gyro: [x[10], x[11], x[12]],
                bias_accel: [x[13], x[14], x[15]],
            });
        }
        ds.groundtruth = Some(v);
    }
    ds.labels = Labels::read(root)?;
    Ok(ds)
}

const IMU_COLUMNS: [&str; 6] = [
    "w_RS_S_x", "w_RS_S_y", "w_RS_S_z", "a_RS_S_x", "a_RS_S_y", "a_RS_S_z",
];

/// The file a row's `filename` column names under `dir/data/`; a missing
/// one is an error naming the `data.csv` line (`what` says what it is).
fn existing_file(dir: &Path, csv: &Path, r: &csvio::Row, what: &str) -> Result<PathBuf, CliError> {
    let name = r.field(csv, 0, "filename")?;
    let file = dir.join("data").join(name);
    if !file.is_file() {
        return Err(CliError::line(
            csv,
            r.line,
            format!("{what} `{}` does not exist", file.display()),
        ));
    }
    Ok(file)
}

fn read_images(dir: &Path) -> Result<Vec<ImageEntry>, CliError> {
    let p = dir.join("data.csv");
    let mut v = Vec::new();
    for r in csvio::read_rows(&p, 2)? {
        let img = existing_file(dir, &p, &r, "image")?;
        v.push(ImageEntry { t: r.t, path: img });
    }
    Ok(v)
}

fn read_flow_frames(dir: &Path) -> Result<Vec<FlowFrameEntry>, CliError> {
    let p = dir.join("data.csv");
    let mut v = Vec::new();
    for r in csvio::read_rows(&p, 3)? {
        let img = existing_file(dir, &p, &r, "frame")?;
        v.push(FlowFrameEntry {
            t: r.t,
            path: img,
            shutter: r.int(&p, 1, "shutter")?,
        });
    }
    Ok(v)
}

/// Writes a dataset folder. Image entries are copied into `mav0/<cam>/data/`
/// unless they already live there.
pub fn write_dataset(root: &Path, ds: &Dataset) -> Result<(), CliError> {
    let mk = |name: &str| -> Result<PathBuf, CliError> {
        let d = root.join("mav0").join(name);
        std::fs::create_dir_all(&d)
            .map_err(|e| CliError::file(&d, format!("cannot create: {e}")))?;
        Ok(d)
    };
    if let Some((meta, v)) = &ds.imu {
        let d = mk("imu0")?;
        meta.write(&d.join("sensor.yaml"))?;
        csvio::write_rows(
            &d.join("data.csv"),
            IMU_HEADER,
            v.iter().map(|s| {
                let [g0, g1, g2] = s.gyro;
                let [a0, a1, a2] = s.accel;
                format!("{},{g0:e},{g1:e},{g2:e},{a0:e},{a1:e},{a2:e}", s.t.0)
            }),
        )?;
    }
    if let Some((meta, v)) = &ds.wheel {
        let d = mk("wheel0")?;
        meta.write(&d.join("sensor.yaml"))?;
        csvio::write_rows(
            &d.join("data.csv"),
            WHEEL_HEADER,
            v.iter()
                .map(|s| format!("{},{},{}", s.t.0, s.left, s.right)),
        )?;
    }
    if let Some((meta, v)) = &ds.wheel_rates {
        let d = mk("wheel0")?;
        meta.write(&d.join("sensor.yaml"))?;
        csvio::write_rows(
            &d.join("data.csv"),
            WHEEL_RATES_HEADER,
            v.iter()
                .map(|s| format!("{},{:e},{:e}", s.t.0, s.left, s.right)),
        )?;
    }
    if let Some((meta, v)) = &ds.flow {
        let d = mk("flow0")?;
        meta.write(&d.join("sensor.yaml"))?;
        csvio::write_rows(
            &d.join("data.csv"),
            FLOW_HEADER,
            v.iter()
                .map(|s| format!("{},{},{},{},{}", s.t.0, s.dx, s.dy, s.squal, s.shutter)),
        )?;
    }
    if let Some((meta, v)) = &ds.flowraw {
        let d = mk("flowraw0")?;
        meta.write(&d.join("sensor.yaml"))?;
        let images: Vec<ImageEntry> = v
            .iter()
            .map(|e| ImageEntry {
                t: e.t,
                path: e.path.clone(),
            })
            .collect();
        copy_images(&d, &images)?;
        csvio::write_rows(
            &d.join("data.csv"),
            FLOWRAW_HEADER,
            v.iter()
                .map(|e| format!("{},{}.png,{}", e.t.0, e.t.0, e.shutter)),
        )?;
    }
    if let Some((meta, v)) = &ds.cam {
        let d = mk("cam0")?;
        meta.write(&d.join("sensor.yaml"))?;
        write_images(&d, v)?;
    }
    if let Some((meta, v)) = &ds.seg {
        let d = mk("seg0")?;
        meta.write(&d.join("sensor.yaml"))?;
        write_images(&d, v)?;
    }
    if let Some((meta, v)) = &ds.cam1 {
        let d = mk("cam1")?;
        meta.write(&d.join("sensor.yaml"))?;
        write_images(&d, v)?;
    }
    if let Some(v) = &ds.groundtruth {
        let d = mk("state_groundtruth_estimate0")?;
        csvio::write_rows(
            &d.join("data.csv"),
            GROUNDTRUTH_HEADER,
            v.iter().map(|g| {
                let nums: Vec<String> =
                    g.p.iter()
                        .chain(&g.q_wxyz)
                        .chain(&g.v)
                        .chain(&g.bias_gyro)
                        .chain(&g.bias_accel)
                        .map(|x| format!("{x:.9}"))
                        .collect();
                format!("{},{}", g.t.0, nums.join(","))
            }),
        )?;
    }
    if let Some(l) = &ds.labels {
        l.write(root)?;
    }
    for (name, stream) in FAILED_STREAMS {
        let rows: Vec<String> = ds
            .failed
            .iter()
            .filter(|f| f.stream == stream)
            .map(|f| format!("{},{}", f.t.0, f.reason.name()))
            .collect();
        if !rows.is_empty() {
            let d = mk(name)?;
            csvio::write_rows(&d.join("failed.csv"), FAILED_HEADER, rows)?;
        }
    }
    Ok(())
}

/// Copies the images into `dir/data/` as `<t>.png` unless they are there.
fn copy_images(dir: &Path, v: &[ImageEntry]) -> Result<(), CliError> {
    let data = dir.join("data");
    std::fs::create_dir_all(&data)
        .map_err(|e| CliError::file(&data, format!("cannot create: {e}")))?;
    for e in v {
        let dst = data.join(format!("{}.png", e.t.0));
        if e.path != dst {
            std::fs::copy(&e.path, &dst)
                .map_err(|err| CliError::file(&e.path, format!("cannot copy image: {err}")))?;
        }
    }
    Ok(())
}

fn write_images(dir: &Path, v: &[ImageEntry]) -> Result<(), CliError> {
    copy_images(dir, v)?;
    let rows = v.iter().map(|e| format!("{},{}.png", e.t.0, e.t.0));
    csvio::write_rows(&dir.join("data.csv"), IMAGE_HEADER, rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An empty scratch folder, removed when the guard is dropped.
    fn tmp(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new()
            .prefix(&format!("host-sim-asl-{name}-"))
            .tempdir()
            .unwrap()
    }

    fn identity() -> [f32; 16] {
        [
            1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
        ]
    }

    fn sample_dataset() -> Dataset {
        let imu = (1..=3)
            .map(|i| RawImuSample {
                t: Timestamp(i * 4_000_000),
                gyro: [0.01, -0.02, 0.3],
                accel: [0.1, 0.0, 9.81],
            })
            .collect();
        let wheel = (1..=2)
            .map(|i| WheelTicks {
                t: Timestamp(i * 20_000_000),
                left: 10 * i as i64,
                right: -3,
            })
            .collect();
        let flow = vec![FlowSample {
            t: Timestamp(10_000_000),
            dx: -4,
            dy: 7,
            squal: 80,
            shutter: 300,
            motion: true,
            ..FlowSample::default()
        }];
        Dataset {
            imu: Some((
                ImuMeta {
                    t_bs: identity(),
                    rate_hz: 250.0,
                    gyroscope_noise_density: 1.7e-4,
                    gyroscope_random_walk: 1.9e-5,
                    accelerometer_noise_density: 2.0e-3,
                    accelerometer_random_walk: 3.0e-3,
                },
                imu,
            )),
            wheel: Some((
                WheelMeta {
                    rate_hz: 50.0,
                    ticks_per_revolution: Some(1024.0),
                    wheel_radius_left: 0.035,
                    wheel_radius_right: 0.035,
                    wheel_base: 0.23,
                    track_factor: 1.0,
                    steering: vslam_core::robot::Steering::Differential,
                    wheel_type: "soft_rubber".into(),
                },
                wheel,
            )),
            flow: Some((
                FlowMeta {
                    rate_hz: 100.0,
                    t_bs: identity(),
                    height: 0.03,
                    counts_per_radian: 573.0,
                },
                flow,
            )),
            cam: None,
            seg: None,
            cam1: None,
            flowraw: None,
            groundtruth: Some(vec![GroundTruth {
                t: Timestamp(4_000_000),
                p: [1.0, 2.0, 0.0],
                q_wxyz: [1.0, 0.0, 0.0, 0.0],
                v: [0.2, 0.0, 0.0],
                bias_gyro: [0.0; 3],
                bias_accel: [0.0; 3],
            }]),
            labels: None,
            ..Dataset::default()
        }
    }

    #[test]
    fn write_then_read_round_trips() {
        let scratch = tmp("rt");
        let d = scratch.path();
        let ds = sample_dataset();
        write_dataset(d, &ds).unwrap();
        let back = read_dataset(d).unwrap();
        assert_eq!(back.imu, ds.imu);
        assert_eq!(back.wheel, ds.wheel);
        assert_eq!(back.flow, ds.flow);
        assert_eq!(back.groundtruth, ds.groundtruth);
        assert_eq!(back.missing(), vec!["cam0", "seg0"]);
    }

    #[test]
    fn failed_reads_round_trip_and_bad_reasons_are_named() {
        let scratch = tmp("failed");
        let d = scratch.path();
        let mut ds = sample_dataset();
        ds.failed = vec![
            LoggedFailure {
                t: Timestamp(30),
                stream: Stream::Wheel,
                reason: Reject::Bus,
            },
            LoggedFailure {
                t: Timestamp(40),
                stream: Stream::Wheel,
                reason: Reject::OutOfRange,
            },
            LoggedFailure {
                t: Timestamp(35),
                stream: Stream::Flow,
                reason: Reject::Integrity,
            },
        ];
        write_dataset(d, &ds).unwrap();
        let wheel = d.join("mav0/wheel0/failed.csv");
        assert_eq!(
            std::fs::read_to_string(&wheel).unwrap(),
            "#timestamp [ns],reason\n30,bus\n40,out_of_range\n"
        );
        assert!(!d.join("mav0/imu0/failed.csv").exists());
        // Read back by stream: the wheels', then the flow's.
        let back = read_dataset(d).unwrap();
        assert_eq!(back.failed, [ds.failed[0], ds.failed[1], ds.failed[2]]);
        std::fs::write(&wheel, "#timestamp [ns],reason\n30,spi\n").unwrap();
        let e = read_dataset(d).unwrap_err();
        assert!(
            e.to_string()
                .contains("wheel0/failed.csv:2: reason: `spi` is not a reject reason"),
            "{e}"
        );
        assert_eq!(e.exit_code(), 2);
        // Without `failed.csv` a log has no failed reads.
        std::fs::remove_file(&wheel).unwrap();
        std::fs::remove_file(d.join("mav0/flow0/failed.csv")).unwrap();
        assert!(read_dataset(d).unwrap().failed.is_empty());
    }

    #[test]
    fn wheel_rates_round_trip_and_are_told_apart_by_the_header() {
        let scratch = tmp("rates");
        let d = scratch.path();
        let mut ds = sample_dataset();
        let (mut meta, _) = ds.wheel.take().unwrap();
        meta.ticks_per_revolution = None;
        meta.track_factor = 1.8;
        let rates = vec![
            RawWheelRates {
                t: Timestamp(10),
                left: 1.5,
                right: -0.25,
            },
            RawWheelRates {
                t: Timestamp(20),
                left: 3.0e-7,
                right: 0.0,
            },
        ];
        ds.wheel_rates = Some((meta, rates));
        write_dataset(d, &ds).unwrap();
        let back = read_dataset(d).unwrap();
        assert_eq!(back.wheel_rates, ds.wheel_rates);
        assert!(back.wheel.is_none());
        assert!(!back.missing().contains(&"wheel0"));
        // A ticks file needs the encoder resolution.
        let csv = d.join("mav0/wheel0/data.csv");
        std::fs::write(&csv, format!("{WHEEL_HEADER}\n10,1,2\n")).unwrap();
        let e = read_dataset(d).unwrap_err().to_string();
        assert!(
            e.contains("wheel0/sensor.yaml: missing key `ticks_per_revolution`"),
            "{e}"
        );
        std::fs::write(&csv, format!("{WHEEL_RATES_HEADER}\n10,1,x\n")).unwrap();
        let e = read_dataset(d).unwrap_err().to_string();
        assert!(
            e.contains("wheel0/data.csv:2: right: `x` is not a number"),
            "{e}"
        );
    }

    #[test]
    fn raw_flow_frames_round_trip_and_bad_rows_are_named() {
        let scratch = tmp("flowraw");
        let d = scratch.path();
        let src = d.join("src");
        std::fs::create_dir_all(&src).unwrap();
        let mut ds = sample_dataset();
        let meta = ds.flow.as_ref().unwrap().0.clone();
        let frames: Vec<FlowFrameEntry> = [(5_000_000u64, 512u16), (15_000_000, 640)]
            .iter()
            .map(|&(t, shutter)| {
                let path = src.join(format!("f{t}.png"));
                crate::pngio::save_gray(
                    &path,
                    &crate::pngio::GrayImage {
                        width: 35,
                        height: 35,
                        data: vec![(t / 1_000_000) as u8; 35 * 35],
                    },
                )
                .unwrap();
                FlowFrameEntry {
                    t: Timestamp(t),
                    path,
                    shutter,
                }
            })
            .collect();
        ds.flowraw = Some((meta, frames));
        let root = d.join("log");
        write_dataset(&root, &ds).unwrap();
        let csv = root.join("mav0/flowraw0/data.csv");
        assert_eq!(
            std::fs::read_to_string(&csv).unwrap(),
            format!("{FLOWRAW_HEADER}\n5000000,5000000.png,512\n15000000,15000000.png,640\n")
        );
        let back = read_dataset(&root).unwrap();
        let (m, v) = back.flowraw.unwrap();
        assert_eq!(m, ds.flowraw.as_ref().unwrap().0);
        assert_eq!(
            v.iter().map(|e| (e.t.0, e.shutter)).collect::<Vec<_>>(),
            [(5_000_000, 512), (15_000_000, 640)]
        );
        let img = crate::pngio::load_gray(&v[1].path).unwrap();
        assert_eq!((img.width, img.height, img.data[0]), (35, 35, 15));
        std::fs::write(&csv, format!("{FLOWRAW_HEADER}\n5000000,missing.png,512\n")).unwrap();
        let e = read_dataset(&root).unwrap_err().to_string();
        assert!(e.contains("flowraw0/data.csv:2:"), "{e}");
        std::fs::write(&csv, format!("{FLOWRAW_HEADER}\n5000000,5000000.png,x\n")).unwrap();
        let e = read_dataset(&root).unwrap_err().to_string();
        assert!(e.contains("flowraw0/data.csv:2: shutter"), "{e}");
    }

    #[test]
    fn malformed_files_are_named_with_their_line() {
        let scratch = tmp("bad");
        let d = scratch.path();
        write_dataset(d, &sample_dataset()).unwrap();
        let csv = d.join("mav0/wheel0/data.csv");
        std::fs::write(
            &csv,
            format!("{WHEEL_HEADER}\n20000000,1,2\n10000000,3,4\n"),
        )
        .unwrap();
        let e = read_dataset_with(d, BadSamples::Refuse).unwrap_err();
        assert!(e.to_string().contains("wheel0/data.csv:3:"), "{e}");
        assert_eq!(e.exit_code(), 2);
        // Passed on, the rows stay in file order for the estimator.
        let ds = read_dataset(d).unwrap();
        let t: Vec<u64> = ds.wheel.unwrap().1.iter().map(|s| s.t.0).collect();
        assert_eq!(t, [20_000_000, 10_000_000]);
        let imu = d.join("mav0/imu0/data.csv");
        std::fs::write(&imu, format!("{IMU_HEADER}\n4000000,nan,0,0,0,0,inf\n")).unwrap();
        let s = read_dataset(d).unwrap().imu.unwrap().1[0];
        assert!(s.gyro[0].is_nan() && s.accel[2] == f32::INFINITY);
        let e = read_dataset_with(d, BadSamples::Refuse)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("imu0/data.csv:2: w_RS_S_x: `nan` is not finite"),
            "{e}"
        );
        std::fs::write(&imu, format!("{IMU_HEADER}\n4000000,0,0,0,0,0\n")).unwrap();
        for bad in [BadSamples::PassOn, BadSamples::Refuse] {
            let e = read_dataset_with(d, bad).unwrap_err();
            assert!(
                e.to_string()
                    .contains("imu0/data.csv:2: expected 7 columns"),
                "{e}"
            );
            assert_eq!(e.exit_code(), 2);
        }

        let scratch = tmp("bad-yaml");
        let d = scratch.path();
        write_dataset(d, &sample_dataset()).unwrap();
        let y = d.join("mav0/flow0/sensor.yaml");
        let text = std::fs::read_to_string(&y)
            .unwrap()
            .replace("height: 0.03", "height: -0.03");
        std::fs::write(&y, text).unwrap();
        let e = read_dataset(d).unwrap_err().to_string();
        assert!(
            e.contains("flow0/sensor.yaml:") && e.contains("`height`: must be positive"),
            "{e}"
        );

        let e = read_dataset(tmp("empty").path()).unwrap_err().to_string();
        assert!(e.contains("no `mav0/`"), "{e}");
    }
}
