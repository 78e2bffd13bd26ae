//! Importers: recorded robot logs in their own formats turned into ASL
//! dataset folders that `host-sim replay` reads ([`crate::asl`]).
//!
//! - [`optiodom`]: OptiOdom runs (Sousa et al. 2022): per-cycle encoder
//!   ticks of a differential drive with OptiTrack ground truth, and the
//!   session's metadata file for geometry and encoder resolution.
//! - [`borealtc`]: BorealTC (IROS 2024) Husky logs: IMU and wheel speeds on
//!   labelled terrain.
//! - [`rosbag`]: ROS 1 bag files (`sensor_msgs/Imu`, `nav_msgs/Odometry`,
//!   `sensor_msgs/NavSatFix`, static transforms).
//!
//! Every importer reads its input completely before it writes anything, and
//! refuses malformed input with an error naming the file and line (exit 2).
//! What a dataset lacks (no IMU, no ground truth) is written into its
//! `labels.yaml` ([`crate::asl::Labels`]) and printed by the replay.

pub mod optiodom;

use crate::asl::{Dataset, write_dataset};
use crate::error::CliError;
use std::path::Path;

/// Seconds (a decimal text field) to integer nanoseconds, rounded to the
/// nearest nanosecond; `None` for negative, non-finite or too large values.
pub fn seconds_to_ns(s: f64) -> Option<u64> {
    let ns = (s * 1e9).round();
    (s.is_finite() && ns >= 0.0 && ns < u64::MAX as f64).then_some(ns as u64)
}

/// Writes an imported dataset into `out` (created if needed; a folder that
/// already holds a `mav0/` is refused so nothing is mixed).
pub fn write_imported(out: &Path, ds: &Dataset) -> Result<(), CliError> {
    if out.join("mav0").exists() {
        return Err(CliError::file(
            out,
            "already holds a dataset (`mav0/`): choose an empty output folder",
        ));
    }
    write_dataset(out, ds)
}

/// The median time step of increasing time stamps, as a rate in Hz
/// (`None` with fewer than two stamps).
pub fn median_rate_hz(ts: impl Iterator<Item = u64>) -> Option<f64> {
    let ts: Vec<u64> = ts.collect();
    let mut steps: Vec<u64> = ts.windows(2).map(|w| w[1].saturating_sub(w[0])).collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_unstable();
    let mid = steps[steps.len() / 2];
    (mid > 0).then(|| 1e9 / mid as f64)
}

/// A planar pose (yaw about z) as the EuRoC ground-truth quaternion `w, x, y, z`.
pub fn yaw_quaternion(yaw: f64) -> [f64; 4] {
    let (s, c) = (0.5 * yaw).sin_cos();
    [c, 0.0, 0.0, s]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_round_to_nanoseconds() {
        assert_eq!(seconds_to_ns(0.0500000000000007), Some(50_000_000));
        assert_eq!(seconds_to_ns(47.58), Some(47_580_000_000));
        assert_eq!(seconds_to_ns(-0.1), None);
        assert_eq!(seconds_to_ns(f64::NAN), None);
        assert_eq!(median_rate_hz([0u64, 50, 100, 160].into_iter()), Some(2e7));
    }
}
