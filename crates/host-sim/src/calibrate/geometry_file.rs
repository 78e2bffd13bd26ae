//! The calibrated wheel geometry file `host-sim calibrate --out FILE`
//! writes and `host-sim replay --wheels FILE` reads: YAML with the keys of
//! `wheel0/sensor.yaml` it replaces (`wheel_radius_left`,
//! `wheel_radius_right`, `wheel_base`, metres), `#` comments saying where it
//! came from.

use crate::asl::yaml::SensorYaml;
use crate::error::CliError;
use std::path::Path;

/// A differential drive's wheel geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelGeometry {
    /// Left wheel radius, m.
    pub radius_left: f64,
    /// Right wheel radius, m.
    pub radius_right: f64,
    /// Track (distance between the wheels' contact points), m.
    pub track: f64,
}

impl WheelGeometry {
    /// Reads the file; every key must be a positive number.
    pub fn read(path: &Path) -> Result<Self, CliError> {
        let y = SensorYaml::load(path)?;
        Ok(WheelGeometry {
            radius_left: y.positive("wheel_radius_left")?,
            radius_right: y.positive("wheel_radius_right")?,
            track: y.positive("wheel_base")?,
        })
    }

    /// The file's text, `comments` first (one `#` line each).
    pub fn to_yaml(&self, comments: &[String]) -> String {
        let mut s: String = comments.iter().map(|c| format!("# {c}\n")).collect();
        s += &format!(
            "wheel_radius_left: {:.7}\nwheel_radius_right: {:.7}\nwheel_base: {:.7}\n",
            self.radius_left, self.radius_right, self.track
        );
        s
    }

    /// Writes the file.
    pub fn write(&self, path: &Path, comments: &[String]) -> Result<(), CliError> {
        std::fs::write(path, self.to_yaml(comments))
            .map_err(|e| CliError::file(path, format!("cannot write: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_file_reads_back_and_refuses_bad_values() {
        let scratch = tempfile::tempdir().unwrap();
        let d = scratch.path();
        let p = d.join("wheels.yaml");
        let g = WheelGeometry {
            radius_left: 0.0419,
            radius_right: 0.04213,
            track: 0.2031,
        };
        g.write(&p, &["from a test".into()]).unwrap();
        assert_eq!(WheelGeometry::read(&p).unwrap(), g);
        std::fs::write(
            &p,
            "wheel_radius_left: 0.04\nwheel_radius_right: -1\nwheel_base: 0.2\n",
        )
        .unwrap();
        let e = WheelGeometry::read(&p).unwrap_err();
        assert!(e.to_string().contains("wheel_radius_right"), "{e}");
    }
}
