//! The `sensor.yaml` of each sensor folder: the keys traction reads and writes.

use super::yaml::{SensorYaml, format_matrix4};
use crate::error::CliError;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use vslam_core::geometry::Extrinsics;
use vslam_core::robot::Steering;

fn write_file(path: &Path, text: &str) -> Result<(), CliError> {
    std::fs::write(path, text).map_err(|e| CliError::file(path, format!("cannot write: {e}")))
}

fn extrinsics(y: &SensorYaml) -> Result<[f32; 16], CliError> {
    let m = y.matrix4("T_BS")?;
    Extrinsics::from_row_major(&m).map_err(|e| CliError::file(y.path(), format!("`T_BS`: {e}")))?;
    Ok(m)
}

fn resolution(y: &SensorYaml) -> Result<[u32; 2], CliError> {
    let r = y.numbers("resolution", Some(2))?;
    let ok = |x: f64| (1.0..=65_535.0).contains(&x) && x.fract() == 0.0;
    match r.as_slice() {
        [w, h] if ok(*w) && ok(*h) => Ok([*w as u32, *h as u32]),
        _ => Err(CliError::file(
            y.path(),
            "`resolution`: expected [width, height] in pixels",
        )),
    }
}

fn intrinsics(y: &SensorYaml) -> Result<[f64; 4], CliError> {
    let v = y.numbers("intrinsics", Some(4))?;
    match v.as_slice() {
        [fu, fv, cu, cv] if *fu > 0.0 && *fv > 0.0 => Ok([*fu, *fv, *cu, *cv]),
        _ => Err(CliError::file(
            y.path(),
            "`intrinsics`: expected [fu, fv, cu, cv] with fu, fv > 0",
        )),
    }
}

/// `imu0/sensor.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuMeta {
    /// Mounting `T_BS`, row-major.
    pub t_bs: [f32; 16],
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Gyroscope white noise, rad/s/sqrt(Hz).
    pub gyroscope_noise_density: f64,
    /// Gyroscope bias random walk, rad/s^2/sqrt(Hz).
    pub gyroscope_random_walk: f64,
    /// Accelerometer white noise, m/s^2/sqrt(Hz).
    pub accelerometer_noise_density: f64,
    /// Accelerometer bias random walk, m/s^3/sqrt(Hz).
    pub accelerometer_random_walk: f64,
}

impl ImuMeta {
    /// Reads the file.
    pub fn read(path: &Path) -> Result<Self, CliError> {
        let y = SensorYaml::load(path)?;
        Ok(ImuMeta {
            t_bs: extrinsics(&y)?,
            rate_hz: y.positive("rate_hz")?,
            gyroscope_noise_density: y.positive("gyroscope_noise_density")?,
            gyroscope_random_walk: y.positive("gyroscope_random_walk")?,
            accelerometer_noise_density: y.positive("accelerometer_noise_density")?,
            accelerometer_random_walk: y.positive("accelerometer_random_walk")?,
        })
    }

    /// Writes the file.
    pub fn write(&self, path: &Path) -> Result<(), CliError> {
        let mut s = String::from("sensor_type: imu\ncomment: traction host-sim\n");
        s += &format_matrix4("T_BS", &self.t_bs);
        let _ = write!(
            s,
            "rate_hz: {}\ngyroscope_noise_density: {:e}\ngyroscope_random_walk: {:e}\naccelerometer_noise_density: {:e}\naccelerometer_random_walk: {:e}\n",
            self.rate_hz,
            self.gyroscope_noise_density,
            self.gyroscope_random_walk,
            self.accelerometer_noise_density,
            self.accelerometer_random_walk
        );
        write_file(path, &s)
    }
}

/// `wheel0/sensor.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub struct WheelMeta {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Encoder counts per wheel revolution (`None` for a log of wheel
    /// angular rates, which has no encoder counts).
    pub ticks_per_revolution: Option<f64>,
    /// Nominal left wheel radius, metres.
    pub wheel_radius_left: f64,
    /// Nominal right wheel radius, metres.
    pub wheel_radius_right: f64,
    /// Distance between the wheels' contact points, metres.
    pub wheel_base: f64,
    /// Effective over physical track (`track_factor`, optional, default 1):
    /// above 1 for a skid steer, whose turn rate from the wheel speeds is as
    /// if the wheels were this much further apart.
    pub track_factor: f64,
    /// `steering` (optional, default `differential`): `skid` for a skid
    /// steer, whose effective track the estimator learns per floor.
    pub steering: Steering,
    /// Wheel type name (for the grip table).
    pub wheel_type: String,
}

impl WheelMeta {
    /// Reads the file.
    pub fn read(path: &Path) -> Result<Self, CliError> {
        let y = SensorYaml::load(path)?;
        Ok(WheelMeta {
            rate_hz: y.positive("rate_hz")?,
            ticks_per_revolution: if y.has("ticks_per_revolution") {
                Some(y.positive("ticks_per_revolution")?)
            } else {
                None
            },
            wheel_radius_left: y.positive("wheel_radius_left")?,
            wheel_radius_right: y.positive("wheel_radius_right")?,
            wheel_base: y.positive("wheel_base")?,
            track_factor: if y.has("track_factor") {
                y.positive("track_factor")?
            } else {
                1.0
            },
            steering: if y.has("steering") {
                match y.string("steering")?.as_str() {
                    "differential" => Steering::Differential,
                    "skid" => Steering::Skid,
                    _ => return Err(y.bad("steering", "expected `differential` or `skid`")),
                }
            } else {
                Steering::Differential
            },
            wheel_type: y.string("wheel_type")?,
        })
    }

    /// Writes the file (`ticks_per_revolution` when there is one,
    /// `track_factor` when it is not 1, `steering` for a skid steer).
    pub fn write(&self, path: &Path) -> Result<(), CliError> {
        let mut s = format!(
            "sensor_type: wheel_encoders\ncomment: traction host-sim\nrate_hz: {}\n",
            self.rate_hz
        );
        if let Some(t) = self.ticks_per_revolution {
            let _ = writeln!(s, "ticks_per_revolution: {t}");
        }
        let _ = write!(
            s,
            "wheel_radius_left: {}\nwheel_radius_right: {}\nwheel_base: {}\n",
            self.wheel_radius_left, self.wheel_radius_right, self.wheel_base
        );
        if self.track_factor != 1.0 {
            let _ = writeln!(s, "track_factor: {}", self.track_factor);
        }
        if self.steering != Steering::Differential {
            let _ = writeln!(s, "steering: {}", self.steering.name());
        }
        let _ = writeln!(s, "wheel_type: {}", self.wheel_type);
        write_file(path, &s)
    }
}

/// `flow0/sensor.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub struct FlowMeta {
    /// Report rate, Hz.
    pub rate_hz: f64,
    /// Mounting `T_BS`, row-major.
    pub t_bs: [f32; 16],
    /// Height of the sensor above the floor, metres.
    pub height: f64,
    /// Counts per radian of angular flow.
    pub counts_per_radian: f64,
}

impl FlowMeta {
    /// Reads the file.
    pub fn read(path: &Path) -> Result<Self, CliError> {
        let y = SensorYaml::load(path)?;
        Ok(FlowMeta {
            rate_hz: y.positive("rate_hz")?,
            t_bs: extrinsics(&y)?,
            height: y.positive("height")?,
            counts_per_radian: y.positive("counts_per_radian")?,
        })
    }

    /// Writes the file.
    pub fn write(&self, path: &Path) -> Result<(), CliError> {
        let mut s = String::from("sensor_type: optical_flow\ncomment: traction host-sim\n");
        let _ = writeln!(s, "rate_hz: {}", self.rate_hz);
        s += &format_matrix4("T_BS", &self.t_bs);
        let _ = write!(
            s,
            "height: {}\ncounts_per_radian: {}\n",
            self.height, self.counts_per_radian
        );
        write_file(path, &s)
    }
}

/// `cam0/sensor.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraMeta {
    /// Frame rate, Hz.
    pub rate_hz: f64,
    /// Mounting `T_BS`, row-major.
    pub t_bs: [f32; 16],
    /// `[width, height]`, pixels.
    pub resolution: [u32; 2],
    /// `[fu, fv, cu, cv]`, pixels (pinhole).
    pub intrinsics: [f64; 4],
    /// Distortion model name.
    pub distortion_model: String,
    /// Distortion coefficients.
    pub distortion_coefficients: Vec<f64>,
}

impl CameraMeta {
    /// Reads the file; only the pinhole camera model is accepted.
    pub fn read(path: &Path) -> Result<Self, CliError> {
        let y = SensorYaml::load(path)?;
        let model = y.string("camera_model")?;
        if model != "pinhole" {
            return Err(CliError::file(
                path,
                format!("`camera_model`: `{model}` is not supported (pinhole)"),
            ));
        }
        Ok(CameraMeta {
            rate_hz: y.positive("rate_hz")?,
            t_bs: extrinsics(&y)?,
            resolution: resolution(&y)?,
            intrinsics: intrinsics(&y)?,
            distortion_model: if y.has("distortion_model") {
                y.string("distortion_model")?
            } else {
                "none".into()
            },
            distortion_coefficients: if y.has("distortion_coefficients") {
                y.numbers("distortion_coefficients", None)?
            } else {
                Vec::new()
            },
        })
    }

    /// Writes the file.
    pub fn write(&self, path: &Path) -> Result<(), CliError> {
        let mut s =
            String::from("sensor_type: camera\ncomment: traction host-sim, upward camera\n");
        let _ = writeln!(s, "rate_hz: {}", self.rate_hz);
        s += &format_matrix4("T_BS", &self.t_bs);
        let d: Vec<String> = self
            .distortion_coefficients
            .iter()
            .map(|x| x.to_string())
            .collect();
        let [fu, fv, cu, cv] = self.intrinsics;
        let _ = write!(
            s,
            "resolution: [{}, {}]\ncamera_model: pinhole\nintrinsics: [{fu}, {fv}, {cu}, {cv}]\ndistortion_model: {}\ndistortion_coefficients: [{}]\n",
            self.resolution[0],
            self.resolution[1],
            self.distortion_model,
            d.join(", ")
        );
        write_file(path, &s)
    }
}

/// `seg0/sensor.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub struct SegMeta {
    /// Map rate, Hz.
    pub rate_hz: f64,
    /// Mounting `T_BS` of the forward camera, row-major.
    pub t_bs: [f32; 16],
    /// `[width, height]`, pixels.
    pub resolution: [u32; 2],
    /// `[fu, fv, cu, cv]`, pixels.
    pub intrinsics: [f64; 4],
    /// Class id to name.
    pub classes: BTreeMap<u8, String>,
    /// The class ids that are ground surfaces.
    pub ground_classes: Vec<u8>,
}

impl SegMeta {
    /// Reads the file; every ground class must be a named class.
    pub fn read(path: &Path) -> Result<Self, CliError> {
        let y = SensorYaml::load(path)?;
        let classes = y.id_names("classes")?;
        let ground_classes = y.ids("ground_classes")?;
        if let Some(g) = ground_classes.iter().find(|g| !classes.contains_key(g)) {
            return Err(CliError::file(
                path,
                format!("`ground_classes`: class {g} is not in `classes`"),
            ));
        }
        Ok(SegMeta {
            rate_hz: y.positive("rate_hz")?,
            t_bs: extrinsics(&y)?,
            resolution: resolution(&y)?,
            intrinsics: intrinsics(&y)?,
            classes,
            ground_classes,
        })
    }

    /// Writes the file.
    pub fn write(&self, path: &Path) -> Result<(), CliError> {
        let mut s = String::from(
            "sensor_type: segmentation\ncomment: traction host-sim, forward camera labels\n",
        );
        let _ = writeln!(s, "rate_hz: {}", self.rate_hz);
        s += &format_matrix4("T_BS", &self.t_bs);
        let [fu, fv, cu, cv] = self.intrinsics;
        let classes: Vec<String> = self
            .classes
            .iter()
            .map(|(k, v)| format!("{k}: {v}"))
            .collect();
        let ground: Vec<String> = self.ground_classes.iter().map(|g| g.to_string()).collect();
        let _ = write!(
            s,
            "resolution: [{}, {}]\nintrinsics: [{fu}, {fv}, {cu}, {cv}]\nclasses: {{{}}}\nground_classes: [{}]\n",
            self.resolution[0],
            self.resolution[1],
            classes.join(", "),
            ground.join(", ")
        );
        write_file(path, &s)
    }
}
