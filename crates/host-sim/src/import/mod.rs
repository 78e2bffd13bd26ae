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

pub mod borealtc;
pub mod enu;
pub mod optiodom;
pub mod ros_msg;
pub mod rosbag;

use crate::asl::{Dataset, write_dataset};
use crate::error::CliError;
use std::path::Path;
use vslam_core::Timestamp;

/// Seconds (a decimal text field) to integer nanoseconds, rounded to the
/// nearest nanosecond; `None` for negative, non-finite or too large values.
pub fn seconds_to_ns(s: f64) -> Option<u64> {
    let ns = (s * 1e9).round();
    (s.is_finite() && ns >= 0.0 && ns < u64::MAX as f64).then_some(ns as u64)
}

/// One row of a CSV file with a header: line, time stamp, the asked columns.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadedRow {
    /// 1-based line in the file.
    pub line: u64,
    /// The `time` column (seconds) as a time stamp.
    pub t: Timestamp,
    /// The asked columns' values, in the order asked (finite).
    pub values: Vec<f64>,
}

/// Reads CSV text whose first line names its columns: a `time` column in
/// seconds from 0 (strictly increasing) and `columns` (any order, other
/// columns ignored), every value a finite number. `path` names the file in
/// errors.
pub fn read_headed_csv(
    path: &Path,
    text: &str,
    columns: &[&str],
) -> Result<Vec<HeadedRow>, CliError> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes())
        .into_records();
    let line_of = |r: &Result<csv::StringRecord, csv::Error>| match r {
        Ok(r) => r.position().map_or(0, |p| p.line()),
        Err(e) => e.position().map_or(0, |p| p.line()),
    };
    let header = match rdr.next() {
        Some(r) => {
            let line = line_of(&r);
            r.map_err(|e| CliError::line(path, line, format!("malformed CSV: {e}")))?
        }
        None => return Err(CliError::file(path, "empty file: expected a header line")),
    };
    let index = |name: &str| -> Result<usize, CliError> {
        header.iter().position(|h| h == name).ok_or_else(|| {
            CliError::line(
                path,
                1,
                format!(
                    "header has no column `{name}` (expected {})",
                    columns.join(", ")
                ),
            )
        })
    };
    let t_col = index("time")?;
    let cols: Vec<usize> = columns.iter().map(|c| index(c)).collect::<Result<_, _>>()?;
    let mut out: Vec<HeadedRow> = Vec::new();
    for rec in rdr {
        let line = line_of(&rec);
        let rec = rec.map_err(|e| CliError::line(path, line, format!("malformed CSV: {e}")))?;
        if rec.len() == 1 && rec.get(0) == Some("") {
            continue;
        }
        if rec.len() != header.len() {
            return Err(CliError::line(
                path,
                line,
                format!("expected {} columns, found {}", header.len(), rec.len()),
            ));
        }
        let num = |i: usize, name: &str| -> Result<f64, CliError> {
            let s = rec.get(i).unwrap_or("");
            let x: f64 = s.parse().map_err(|_| {
                CliError::line(path, line, format!("{name}: `{s}` is not a number"))
            })?;
            if x.is_finite() {
                Ok(x)
            } else {
                Err(CliError::line(
                    path,
                    line,
                    format!("{name}: `{s}` is not finite"),
                ))
            }
        };
        let secs = num(t_col, "time")?;
        let t = seconds_to_ns(secs).map(Timestamp).ok_or_else(|| {
            CliError::line(path, line, format!("time: `{secs}` s is not a time from 0"))
        })?;
        if let Some(prev) = out.last().filter(|p| t <= p.t) {
            return Err(CliError::line(
                path,
                line,
                format!(
                    "time does not increase (line {} is the same or later)",
                    prev.line
                ),
            ));
        }
        let values = cols
            .iter()
            .zip(columns)
            .map(|(&i, name)| num(i, name))
            .collect::<Result<_, _>>()?;
        out.push(HeadedRow { line, t, values });
    }
    if out.len() < 2 {
        return Err(CliError::file(path, "needs at least two rows of data"));
    }
    Ok(out)
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

    #[test]
    fn headed_csv_finds_columns_by_name_and_names_bad_lines() {
        let p = Path::new("f.csv");
        let rows = read_headed_csv(p, "b,time,a\n1,0.0,2\n3,0.5,4\n", &["a", "b"]).unwrap();
        assert_eq!(rows[1].t, Timestamp(500_000_000));
        assert_eq!(rows[1].values, vec![4.0, 3.0]);
        for (text, want) in [
            ("time,x\n0,1\n", "f.csv:1: header has no column `a`"),
            (
                "time,a\n0,1\n1,1,3\n",
                "f.csv:3: expected 2 columns, found 3",
            ),
            ("time,a\n0,1\n1,inf\n", "f.csv:3: a: `inf` is not finite"),
            ("time,a\n0,1\n0,2\n", "f.csv:3: time does not increase"),
            ("time,a\n0,1\n", "f.csv: needs at least two rows"),
            ("", "f.csv: empty file"),
        ] {
            let e = read_headed_csv(p, text, &["a"]).unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
        }
    }
}
