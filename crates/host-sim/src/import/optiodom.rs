//! OptiOdom runs (Sousa et al., "OptiOdom: a Generic Approach for Odometry
//! Calibration of Wheeled Mobile Robots", J. Intell. Robot. Syst. 105, 39,
//! 2022; data format in the upstream README, "Data format"), differential
//! drive only.
//!
//! - Run file `<id>_run-NN.csv`, no header, 6 columns: `t` [s], `x_gt`,
//!   `y_gt` [m], `th_gt` [rad] (OptiTrack, synchronised to the odometry
//!   clock, in the run's start frame, unwrapped), `odoR`, `odoL` [encoder
//!   ticks during the cycle: **right first**, increments, not cumulative].
//! - Metadata `<id>_metadata.csv`: rows `key,value[,value...]` with empty
//!   trailing fields: `type` (`diff`), `ngear` (gear ratio), `encRes` (ticks
//!   per motor revolution), `Li` (track, m), `Di` (wheel diameters, m, in the
//!   order of the run's tick columns: right, then left; one value for both).
//!   Other keys (`Thi`, `N`, `L`, `imarkers`, sync windows) are not needed.
//!
//! The dataset written: `wheel0` with the running sum of the ticks
//! (`left`, `right` columns, cumulative, from 0 before the first row),
//! `ngear * encRes` ticks per wheel revolution, radii `Di / 2`, track `Li`;
//! `state_groundtruth_estimate0` with the OptiTrack pose (z = 0, yaw about
//! z) and the velocity by central differences; no IMU (noted in
//! `labels.yaml`: the replay's result is the wheel-only trajectory).

use super::{median_rate_hz, seconds_to_ns, yaw_quaternion};
use crate::asl::{Dataset, GroundTruth, Labels, WheelMeta};
use crate::error::CliError;
use std::path::{Path, PathBuf};
use vslam_core::Timestamp;
use vslam_core::sensors::WheelTicks;

/// What the metadata file says about a differential-drive robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OptiOdomMeta {
    /// Gear ratio motor : wheel.
    pub ngear: f64,
    /// Encoder ticks per motor revolution.
    pub enc_res: f64,
    /// Track (distance between the wheels), m.
    pub track: f64,
    /// Right wheel diameter, m.
    pub diameter_right: f64,
    /// Left wheel diameter, m.
    pub diameter_left: f64,
}

impl OptiOdomMeta {
    /// Encoder ticks per wheel revolution.
    pub fn ticks_per_revolution(&self) -> f64 {
        self.ngear * self.enc_res
    }
}

/// One row of a run file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunRow {
    /// 1-based line in the file.
    pub line: u64,
    /// Time stamp.
    pub t: Timestamp,
    /// Ground-truth x, y (m) and heading (rad, unwrapped).
    pub pose: [f64; 3],
    /// Right wheel ticks during the cycle.
    pub ticks_right: i64,
    /// Left wheel ticks during the cycle.
    pub ticks_left: i64,
}

fn records(text: &str) -> csv::StringRecordsIntoIter<&[u8]> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes())
        .into_records()
}

fn record_line(rec: &Result<csv::StringRecord, csv::Error>) -> u64 {
    match rec {
        Ok(r) => r.position().map_or(0, |p| p.line()),
        Err(e) => e.position().map_or(0, |p| p.line()),
    }
}

fn number(path: &Path, line: u64, name: &str, s: &str) -> Result<f64, CliError> {
    let x: f64 = s
        .parse()
        .map_err(|_| CliError::line(path, line, format!("{name}: `{s}` is not a number")))?;
    if !x.is_finite() {
        return Err(CliError::line(
            path,
            line,
            format!("{name}: `{s}` is not finite"),
        ));
    }
    Ok(x)
}

fn positive(path: &Path, line: u64, name: &str, s: &str) -> Result<f64, CliError> {
    let x = number(path, line, name, s)?;
    if x <= 0.0 {
        return Err(CliError::line(
            path,
            line,
            format!("{name}: `{s}` must be positive"),
        ));
    }
    Ok(x)
}

/// Parses a metadata file's text (`path` names it in errors).
pub fn parse_metadata(path: &Path, text: &str) -> Result<OptiOdomMeta, CliError> {
    let mut rows: Vec<(u64, String, Vec<String>)> = Vec::new();
    for rec in records(text) {
        let line = record_line(&rec);
        let rec = rec.map_err(|e| CliError::line(path, line, format!("malformed CSV: {e}")))?;
        let key = rec.get(0).unwrap_or("").to_string();
        if key.is_empty() {
            continue;
        }
        if let Some((l, ..)) = rows.iter().find(|(_, k, _)| *k == key) {
            return Err(CliError::line(
                path,
                line,
                format!("key `{key}` again (first on line {l})"),
            ));
        }
        let values = rec
            .iter()
            .skip(1)
            .filter(|v| !v.is_empty())
            .map(str::to_owned)
            .collect();
        rows.push((line, key, values));
    }
    let find = |key: &str| -> Result<(u64, &[String]), CliError> {
        rows.iter()
            .find(|(_, k, _)| k == key)
            .map(|(l, _, v)| (*l, v.as_slice()))
            .ok_or_else(|| CliError::file(path, format!("missing key `{key}`")))
    };
    let one = |key: &str| -> Result<f64, CliError> {
        match find(key)? {
            (l, [v]) => positive(path, l, key, v),
            (l, v) => Err(CliError::line(
                path,
                l,
                format!("{key}: expected one value, found {}", v.len()),
            )),
        }
    };
    match find("type")? {
        (_, [t]) if t == "diff" => {}
        (l, t) => {
            return Err(CliError::line(
                path,
                l,
                format!(
                    "type: only differential-drive runs (`diff`) are imported, found `{}`",
                    t.join(",")
                ),
            ));
        }
    }
    let (diameter_right, diameter_left) = match find("Di")? {
        (l, [d]) => {
            let d = positive(path, l, "Di", d)?;
            (d, d)
        }
        (l, [r, left]) => (positive(path, l, "Di", r)?, positive(path, l, "Di", left)?),
        (l, v) => {
            return Err(CliError::line(
                path,
                l,
                format!("Di: expected 1 or 2 wheel diameters, found {}", v.len()),
            ));
        }
    };
    Ok(OptiOdomMeta {
        ngear: one("ngear")?,
        enc_res: one("encRes")?,
        track: one("Li")?,
        diameter_right,
        diameter_left,
    })
}

/// Parses a run file's text (`path` names it in errors): six columns a row,
/// time stamps strictly increasing.
pub fn parse_run(path: &Path, text: &str) -> Result<Vec<RunRow>, CliError> {
    let mut out: Vec<RunRow> = Vec::new();
    for rec in records(text) {
        let line = record_line(&rec);
        let rec = rec.map_err(|e| CliError::line(path, line, format!("malformed CSV: {e}")))?;
        if rec.len() == 1 && rec.get(0) == Some("") {
            continue;
        }
        let f: Vec<&str> = rec.iter().collect();
        let [t, x, y, th, r, l] = f.as_slice() else {
            return Err(CliError::line(
                path,
                line,
                format!(
                    "expected 6 columns (t, x, y, th, odoR, odoL), found {}",
                    f.len()
                ),
            ));
        };
        let secs = number(path, line, "t", t)?;
        let t = seconds_to_ns(secs).map(Timestamp).ok_or_else(|| {
            CliError::line(path, line, format!("t: `{secs}` s is not a time from 0"))
        })?;
        if let Some(prev) = out.last().filter(|p| t <= p.t) {
            return Err(CliError::line(
                path,
                line,
                format!(
                    "t does not increase (line {} has the same or a later time)",
                    prev.line
                ),
            ));
        }
        let ticks = |name: &str, s: &str| -> Result<i64, CliError> {
            s.parse().map_err(|_| {
                CliError::line(
                    path,
                    line,
                    format!("{name}: `{s}` is not an integer tick count"),
                )
            })
        };
        out.push(RunRow {
            line,
            t,
            pose: [
                number(path, line, "x", x)?,
                number(path, line, "y", y)?,
                number(path, line, "th", th)?,
            ],
            ticks_right: ticks("odoR", r)?,
            ticks_left: ticks("odoL", l)?,
        });
    }
    if out.len() < 2 {
        return Err(CliError::file(path, "a run needs at least two rows"));
    }
    Ok(out)
}

/// The dataset of a parsed run: cumulative ticks, ground truth, labels.
/// `run` names the run file in errors and in the labels.
pub fn to_dataset(run: &Path, meta: &OptiOdomMeta, rows: &[RunRow]) -> Result<Dataset, CliError> {
    let mut wheel = Vec::with_capacity(rows.len());
    let (mut left, mut right) = (0i64, 0i64);
    for r in rows {
        let overflow = || CliError::line(run, r.line, "the running tick count overflows");
        left = left.checked_add(r.ticks_left).ok_or_else(overflow)?;
        right = right.checked_add(r.ticks_right).ok_or_else(overflow)?;
        wheel.push(WheelTicks {
            t: r.t,
            left,
            right,
        });
    }
    let rate_hz = median_rate_hz(rows.iter().map(|r| r.t.0))
        .ok_or_else(|| CliError::file(run, "a run needs at least two rows"))?;
    let wheel_meta = WheelMeta {
        rate_hz,
        ticks_per_revolution: Some(meta.ticks_per_revolution()),
        wheel_radius_left: 0.5 * meta.diameter_left,
        wheel_radius_right: 0.5 * meta.diameter_right,
        wheel_base: meta.track,
        track_factor: 1.0,
        steering: vslam_core::robot::Steering::Differential,
        wheel_type: "unknown".into(),
    };
    let mut labels = Labels::default();
    let name = run.file_name().map_or_else(
        || run.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    labels
        .set("source", format!("optiodom {name}"))
        .set("reference", "optitrack")
        .note("wheel0 holds the running sum of the run's per-cycle ticks (right and left swapped into left, right)");
    Ok(Dataset {
        wheel: Some((wheel_meta, wheel)),
        groundtruth: Some(ground_truth(rows)),
        labels: Some(labels),
        ..Dataset::default()
    })
}

/// The OptiTrack poses with velocities by central differences (one-sided at
/// the ends).
fn ground_truth(rows: &[RunRow]) -> Vec<GroundTruth> {
    let at = |i: usize| rows.get(i).map(|r| (r.t.0 as f64 * 1e-9, r.pose));
    (0..rows.len())
        .map(|i| {
            let a = at(i.saturating_sub(1)).or(at(i));
            let b = at(i + 1).or(at(i));
            let v = match (a, b) {
                (Some((ta, pa)), Some((tb, pb))) if tb > ta => [
                    (pb[0] - pa[0]) / (tb - ta),
                    (pb[1] - pa[1]) / (tb - ta),
                    0.0,
                ],
                _ => [0.0; 3],
            };
            let r = &rows[i];
            GroundTruth {
                t: r.t,
                p: [r.pose[0], r.pose[1], 0.0],
                q_wxyz: yaw_quaternion(r.pose[2]),
                v,
                bias_gyro: [0.0; 3],
                bias_accel: [0.0; 3],
            }
        })
        .collect()
}

/// The metadata file beside a run: `<id>_metadata.csv` for `<id>_run-NN.csv`.
pub fn metadata_beside(run: &Path) -> Result<PathBuf, CliError> {
    let name = run
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let id = name.rsplit_once("_run-").map(|(id, _)| id).ok_or_else(|| {
        CliError::file(
            run,
            "not named `<id>_run-NN.csv`: give the metadata file with --metadata FILE",
        )
    })?;
    let meta = run.with_file_name(format!("{id}_metadata.csv"));
    if meta.is_file() {
        Ok(meta)
    } else {
        Err(CliError::file(
            &meta,
            "no metadata file beside the run: give it with --metadata FILE",
        ))
    }
}

fn read_text(path: &Path) -> Result<String, CliError> {
    std::fs::read_to_string(path).map_err(|e| CliError::file(path, format!("cannot read: {e}")))
}

/// Reads a run (and its metadata: `metadata`, or the file beside the run)
/// into a dataset.
pub fn read(run: &Path, metadata: Option<&Path>) -> Result<Dataset, CliError> {
    let meta_path = match metadata {
        Some(m) => m.to_path_buf(),
        None => metadata_beside(run)?,
    };
    let meta = parse_metadata(&meta_path, &read_text(&meta_path)?)?;
    let rows = parse_run(run, &read_text(run)?)?;
    to_dataset(run, &meta, &rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    const META: &str = "type,diff,,,,,\nngear,43.7,,,,,\nencRes,64,,,,,\nLi,0.2,,,,,\nDi,0.084,0.085,,,,\nThi,,,,,,\nN,6,,,,,\n";

    #[test]
    fn metadata_gives_geometry_and_resolution() {
        let m = parse_metadata(Path::new("m.csv"), META).unwrap();
        assert!((m.ticks_per_revolution() - 2796.8).abs() < 1e-9);
        assert_eq!(
            (m.track, m.diameter_right, m.diameter_left),
            (0.2, 0.084, 0.085)
        );
        for (bad, want) in [
            (
                META.replace("diff", "omni3"),
                "m.csv:1: type: only differential-drive",
            ),
            (
                META.replace("Li,0.2", "Li,-0.2"),
                "m.csv:4: Li: `-0.2` must be positive",
            ),
            (
                META.replace("encRes,64", "encRes,x"),
                "m.csv:3: encRes: `x` is not a number",
            ),
            (
                META.replace("ngear,43.7,,,,,\n", ""),
                "m.csv: missing key `ngear`",
            ),
            (
                format!("{META}Li,0.3\n"),
                "m.csv:8: key `Li` again (first on line 4)",
            ),
        ] {
            let e = parse_metadata(Path::new("m.csv"), &bad).unwrap_err();
            assert!(e.to_string().contains(want), "{e}");
            assert_eq!(e.exit_code(), 2);
        }
    }

    #[test]
    fn ticks_are_summed_with_right_and_left_swapped() {
        let run = "0,0,0,0,0,0\n0.0500000000000007,0.001,0,0.01,6,5\n0.1,0.002,0.0001,0.02,-2,3\n";
        let rows = parse_run(Path::new("r.csv"), run).unwrap();
        let m = parse_metadata(Path::new("m.csv"), META).unwrap();
        let ds = to_dataset(Path::new("x_run-01.csv"), &m, &rows).unwrap();
        let (meta, w) = ds.wheel.unwrap();
        let lr: Vec<(u64, i64, i64)> = w.iter().map(|s| (s.t.0, s.left, s.right)).collect();
        assert_eq!(lr, vec![(0, 0, 0), (50_000_000, 5, 6), (100_000_000, 8, 4)]);
        assert_eq!(
            (meta.wheel_radius_right, meta.wheel_radius_left),
            (0.042, 0.0425)
        );
        assert!((meta.rate_hz - 20.0).abs() < 1e-9);
        let gt = ds.groundtruth.unwrap();
        assert!((gt[1].v[0] - 0.02).abs() < 1e-9, "{:?}", gt[1].v);
        assert!((gt[2].q_wxyz[3] - (0.01f64).sin()).abs() < 1e-12);
        assert!(ds.imu.is_none());
        assert_eq!(ds.labels.unwrap().get("reference"), Some("optitrack"));
    }

    #[test]
    fn malformed_runs_name_the_line() {
        for (run, want) in [
            ("0,0,0,0,0,0\n0.05,0,0,0,1\n", "r.csv:2: expected 6 columns"),
            (
                "0,0,0,0,0,0\n0.05,0,0,0,1.5,1\n",
                "r.csv:2: odoR: `1.5` is not an integer",
            ),
            (
                "0,0,0,0,0,0\n0.05,0,nan,0,1,1\n",
                "r.csv:2: y: `nan` is not finite",
            ),
            ("0,0,0,0,0,0\n0,0,0,0,1,1\n", "r.csv:2: t does not increase"),
            ("-1,0,0,0,0,0\n0,0,0,0,1,1\n", "r.csv:1: t: `-1` s"),
            ("0,0,0,0,0,0\n", "r.csv: a run needs at least two rows"),
        ] {
            let e = parse_run(Path::new("r.csv"), run).unwrap_err();
            assert!(e.to_string().contains(want), "{e}");
        }
    }

    #[test]
    fn metadata_is_found_beside_the_run() {
        let e = metadata_beside(Path::new("/nonexistent/abc_run-01.csv")).unwrap_err();
        assert!(e.to_string().contains("abc_metadata.csv"), "{e}");
        let e = metadata_beside(Path::new("run.csv")).unwrap_err();
        assert!(e.to_string().contains("--metadata"), "{e}");
    }
}
