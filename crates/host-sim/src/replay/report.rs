//! The replay's report: `report.json` (sample counts with their reason
//! names, scale decisions, surface timeline, jolt events, the filter's final
//! state, the trajectory errors of [`crate::metrics`]), the files a replay
//! writes (the trajectories `ekf.tum`, `vslam.tum`, `wheel_only.tum` and,
//! with ground truth, `groundtruth.tum`: all poses of the body frame B; none
//! written empty), and the summary printed after a run (the error table
//! when there is ground truth).

use super::ReplayOutput;
use super::run::Collected;
use crate::asl::GroundTruth;
use crate::error::CliError;
use crate::metrics::ALIGNMENT;
use crate::plot::{
    PlotInputs, Scene, errors::errors_svg, html::report_html, trajectory::trajectory_svg,
};
use crate::tum::{truth_poses, write_tum};
use serde_json::{Value, json};
use std::path::Path;
use traction::estimator::Estimator;
use traction::vslam_core::scale::FrameDecision;
use traction::vslam_core::{SampleCounts, StreamCounts, Timestamp};

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

/// One scale decision of the camera path, for the report's `frames`.
pub(super) fn decision_json(t: Timestamp, d: &FrameDecision) -> Value {
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
        "t0": d.t0.0,
        "method": format!("{:?}", d.method),
        "baseline": d.baseline,
        "camera_confidence": d.camera_confidence,
        "wheel_m": d.wheel.metres, "wheel_confidence": d.wheel.confidence,
        "flow_m": d.flow.metres, "flow_confidence": d.flow.confidence,
        "slip": d.slip.amount, "slip_exceeded": d.slip.exceeded, "slip_cause": format!("{:?}", d.slip.cause),
        "wheel_weight": d.wheel_weight, "flow_weight": d.flow_weight,
        "camera_weight": d.camera_weight, "imu_weight": d.imu_weight,
        "wheel_outlier": d.wheel_outlier,
        "scale": scale, "source": source, "no_scale": why,
        "applied_scale": d.applied_scale,
    })
}

/// The filter's state at the end of the run.
fn final_json(est: &Estimator<'_>) -> Value {
    let ekf = est.ekf();
    let mut out = json!({
        "wheel_radii": ekf.wheel_radii(),
        "flow_velocity_resets": ekf.flow_resets(),
        "wheel_lockout": {
            "resets_to_flow": ekf.recovery().resets_to_flow,
            "resets_to_wheels": ekf.recovery().resets_to_wheels,
            "kept_gating_wheels_slip": ekf.recovery().wheels_slip,
            "kept_gating_no_trusted_source": ekf.recovery().no_trusted_source,
        },
        "imu_gaps_bridged": ekf.gaps().bridged,
        "wheel_distrusted": counts_json(ekf.wheel_distrust_counts()),
        "wheel_radius_std": ekf.wheel_radius_std(),
        "sensor_weights": {
            "imu": ekf.sensor_weights().imu,
            "wheel": ekf.sensor_weights().wheel,
            "flow": ekf.sensor_weights().flow,
        },
        "gyro_bias": [ekf.gyro_bias().x, ekf.gyro_bias().y, ekf.gyro_bias().z],
        "gyro_scale": ekf.gyro_scale(),
        "gyro_scale_std": ekf.gyro_scale_std(),
        "accel_bias": [ekf.accel_bias().x, ekf.accel_bias().y, ekf.accel_bias().z],
        "running_scale": est.scale().running_scale().map(|r| r.scale),
        "expected_slip": est.surface().map(slip_json),
    });
    // A skid steer's learned effective track (absent for a differential drive).
    if let (Some(t), Some(o)) = (ekf.track_estimate(), out.as_object_mut()) {
        o.insert(
            "track_factor".into(),
            json!({
                "chi": t.chi, "chi_std": t.chi_std, "gyro_offset": t.gyro_offset,
                "updates": t.updates, "downweighted": t.downweighted,
            }),
        );
    }
    out
}

/// The surface model's expected slip per floor (prior plus learned) and
/// the slip learner's tally.
fn slip_json(s: &traction::ego_ekf::surface::SurfaceModel) -> Value {
    use traction::ego_ekf::surface::SurfaceKind;
    let floors: serde_json::Map<String, Value> = SurfaceKind::ALL
        .iter()
        .map(|k| (k.name().to_string(), json!(s.expected_slip(*k))))
        .collect();
    json!({
        "floors": floors,
        "learning": counts_json(s.slip_learner().counts()),
    })
}

/// The report of a run: what was missing, what `c` collected and the
/// estimator's counts and final state.
pub(super) fn report_json(missing: &[&'static str], c: &Collected, est: &Estimator<'_>) -> Value {
    let jolts: Vec<Value> = c
        .jolts
        .iter()
        .map(|e| {
            json!({"t": e.t.0, "kind": format!("{:?}", e.kind), "magnitude": e.magnitude,
                   "explained": e.explained, "surface": e.surface.map(|s| s.name())})
        })
        .collect();
    let counts = est.counts();
    let ekf = est.ekf();
    json!({
        "missing_sensors": missing,
        "counts": stream_counts_json(&counts),
        "filter_counts": {
            "imu": counts_json(ekf.imu_counts()),
            "wheel": counts_json(ekf.wheel_counts()),
            "flow": counts_json(ekf.flow_counts()),
            "zupt": counts_json(ekf.zupt_counts()),
            "floor": counts_json(ekf.floor_counts()),
            "camera": counts_json(ekf.camera_counts()),
        },
        "frames": c.decisions,
        "camera_rejections": c.camera_rejections,
        "camera_path": {
            "frames": c.camera_frames,
            "corner_detections": est.frontend().map(|f| f.corner_detections()),
        },
        "surface_timeline": c.surfaces,
        "events": jolts,
        "aids": c.aids.to_json(),
        "flow_power": c.flow_power.to_json(),
        "disagreement": super::disagreement::report(est),
        "final": final_json(est),
    })
}

/// The report with the trajectory errors, when there are any.
fn report_with_errors(r: &ReplayOutput) -> Value {
    let mut report = r.report.clone();
    if !r.errors.is_empty() {
        let errs: serde_json::Map<String, Value> = r
            .errors
            .iter()
            .map(|(n, e)| {
                ((*n).to_string(), json!({"ate_rmse_m": e.ate_rmse, "ate_se2_rmse_m": e.ate_se2_rmse,
                    "final_error_m": e.final_error,
                    "final_error_pct_of_path": 100.0 * e.final_relative(), "path_length_m": e.path_length,
                    "max_height_error_m": e.max_height_error, "yaw_rmse_deg": e.yaw_rmse_deg,
                    "final_yaw_error_deg": e.final_yaw_error_deg, "matched_poses": e.matched}))
            })
            .collect();
        report["errors"] = Value::Object(errs);
        report["errors_alignment"] = json!(ALIGNMENT);
    }
    report
}

/// Writes the replay's files into `out`.
pub fn write_outputs(
    out_dir: &Path,
    r: &ReplayOutput,
    truth: Option<&[GroundTruth]>,
    scene: Option<&Scene>,
) -> Result<(), CliError> {
    std::fs::create_dir_all(out_dir)
        .map_err(|e| CliError::file(out_dir, format!("cannot create: {e}")))?;
    write_tum(&out_dir.join("ekf.tum"), &r.ekf)?;
    write_tum(&out_dir.join("vslam.tum"), &r.vslam)?;
    write_tum(&out_dir.join("wheel_only.tum"), &r.wheel_only)?;
    write_tum(
        &out_dir.join("groundtruth.tum"),
        &truth.map(truth_poses).unwrap_or_default(),
    )?;
    let report = report_with_errors(r);
    let text = serde_json::to_string_pretty(&report)
        .map_err(|e| CliError::file(out_dir, e.to_string()))?;
    write(&out_dir.join("report.json"), &text)?;
    let inputs = PlotInputs {
        ekf: &r.ekf,
        vslam: &r.vslam,
        wheel_only: &r.wheel_only,
        truth,
        scene,
        report: &report,
    };
    let trajectory = trajectory_svg(&inputs);
    let errors = errors_svg(&inputs);
    write(&out_dir.join("trajectory.svg"), &trajectory)?;
    write(&out_dir.join("errors.svg"), &errors)?;
    let summary = summary_table(r);
    write(
        &out_dir.join("report.html"),
        &report_html(&inputs, &trajectory, &errors, &summary),
    )
}

fn write(p: &Path, text: &str) -> Result<(), CliError> {
    std::fs::write(p, text).map_err(|e| CliError::file(p, format!("cannot write: {e}")))
}

/// The error table: the alignment, then one line per trajectory.
fn errors_table(r: &ReplayOutput) -> String {
    let mut s = format!("{ALIGNMENT}\n");
    s += "trajectory   ATE first [m]  ATE SE(2) [m]  final [m]  final / path  height max [m]  yaw RMSE [deg]  yaw final [deg]\n";
    for (n, e) in &r.errors {
        s += &format!(
            "{n:<12} {:>13.3}  {:>13.3}  {:>9.3}  {:>10.2} %  {:>14.3}  {:>14.2}  {:>15.2}\n",
            e.ate_rmse,
            e.ate_se2_rmse,
            e.final_error,
            100.0 * e.final_relative(),
            e.max_height_error,
            e.yaw_rmse_deg,
            e.final_yaw_error_deg,
        );
    }
    s
}

/// Scale decisions by source, pairs with slip, and the corner detections.
fn decisions_summary(report: &Value) -> String {
    let mut s = String::new();
    if report["camera_path"]["frames"].as_u64() == Some(0) {
        return "no camera frames: no scale decisions\n".into();
    }
    let frames = report["frames"].as_array().map(Vec::len).unwrap_or(0);
    let mut by_source = std::collections::BTreeMap::new();
    let mut slips = 0usize;
    for f in report["frames"].as_array().into_iter().flatten() {
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
    if let Some(n) = report["camera_path"]["corner_detections"].as_u64() {
        s += &format!(
            "corners detected on {n} of {} frames (the others carry the last pair's inliers)\n",
            report["camera_path"]["frames"]
        );
    }
    s
}

/// Gated and rejected samples per stream.
fn counts_summary(report: &Value) -> String {
    let c = &report["counts"];
    let n = |v: &Value| v.as_u64().unwrap_or(0);
    format!(
        "gated samples: wheel {}, flow {}; rejected: imu {}, wheel {}, flow {}, camera {}\n",
        c["wheel"]["gated"],
        c["flow"]["gated"],
        n(&c["imu"]["seen"]).saturating_sub(n(&c["imu"]["fused"])),
        n(&c["wheel"]["seen"]).saturating_sub(n(&c["wheel"]["fused"]) + n(&c["wheel"]["gated"])),
        n(&c["flow"]["seen"]).saturating_sub(n(&c["flow"]["fused"]) + n(&c["flow"]["gated"])),
        n(&c["camera"]["seen"]).saturating_sub(n(&c["camera"]["fused"])),
    )
}

/// Rejected samples of the sensor streams by reason, e.g. `imu: non_finite
/// 2, duplicate 1`; empty when none was rejected.
fn reasons_summary(report: &Value) -> String {
    let c = &report["counts"];
    let streams: Vec<String> = ["imu", "wheel", "flow"]
        .iter()
        .filter_map(|s| {
            let reasons: Vec<String> = c[*s]["rejected"]
                .as_object()?
                .iter()
                .filter(|(r, _)| r.as_str() != "gated")
                .map(|(r, n)| format!("{r} {n}"))
                .collect();
            (!reasons.is_empty()).then(|| format!("{s}: {}", reasons.join(", ")))
        })
        .collect();
    if streams.is_empty() {
        String::new()
    } else {
        format!("rejected by reason: {}\n", streams.join("; "))
    }
}

/// The IMU's rate and when the EKF started (its first pose), from the
/// IMU's first sample; empty without an IMU.
fn start_summary(r: &ReplayOutput) -> String {
    let Some((hz, t0)) = r.imu else {
        return String::new();
    };
    let start = match r.ekf.first().and_then(|p| p.t.nanos_since(t0)) {
        Some(ns) => format!(
            "started {:.2} s after the first IMU sample",
            ns as f64 * 1e-9
        ),
        None => "never started".to_string(),
    };
    format!("EKF: IMU at {hz:.1} Hz; {start}\n")
}

/// Jolt events by kind.
fn events_summary(report: &Value) -> String {
    let events = report["events"]
        .as_array()
        .map(|v| v.as_slice())
        .unwrap_or(&[]);
    let count = |k: &str| events.iter().filter(|e| e["kind"] == k).count();
    format!(
        "events: suspected obstacles {}, threshold strips {}, surface noise {}\n",
        count("SuspectedObstacle"),
        count("ThresholdStrip"),
        count("SurfaceNoise")
    )
}

/// The summary printed after a run: the error table when there is ground
/// truth, then what does not need it (scale decisions, counts, rejections
/// by reason, events).
pub fn summary_table(r: &ReplayOutput) -> String {
    let errors = if r.errors.is_empty() {
        String::new()
    } else {
        errors_table(r)
    };
    errors
        + &decisions_summary(&r.report)
        + &counts_summary(&r.report)
        + &reasons_summary(&r.report)
        + &start_summary(r)
        + &events_summary(&r.report)
        + &super::disagreement::summary(&r.report)
        + &super::memory::summary(&r.report)
}
