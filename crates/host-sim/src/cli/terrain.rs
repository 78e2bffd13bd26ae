//! `host-sim terrain-stats DATASET...`: replays each log and prints, per
//! log and per terrain label, the statistics of [`crate::terrain`] as
//! Markdown tables (the README's "Real data" BorealTC tables).

use crate::asl::read_dataset;
use crate::error::CliError;
use crate::replay::{ReplayOptions, replay_with};
use crate::terrain::log_stats;
use clap::Args;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Arguments of `host-sim terrain-stats`.
#[derive(Debug, Args)]
#[command(
    about = "Per-terrain statistics of replayed logs without ground truth",
    long_about = "Replays each ASL dataset (e.g. `host-sim import borealtc` of a BorealTC \
                  sequence; the terrain is labels.yaml `terrain`) and prints per log: the wheels' \
                  yaw rate against the gyroscope's (residual mean, std, RMS and the gain of gyro on \
                  wheels), the mean NIS of each aid against its degrees of freedom and the fraction \
                  gated, what the filter learned (gyro and accelerometer biases, wheel radii, a skid \
                  steer's track factor), and \
                  the forward wheel noise the per-floor noise learner settles on; then the terrains \
                  ranked by that noise."
)]
pub struct TerrainStatsArgs {
    /// The dataset folders.
    #[arg(required = true)]
    pub datasets: Vec<PathBuf>,
    /// Also write every statistic as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

fn f(v: &Value, scale: f64, digits: usize) -> String {
    v.as_f64()
        .map_or_else(|| "-".into(), |x| format!("{:.*}", digits, x * scale))
}

fn triple(v: &Value, scale: f64, digits: usize) -> String {
    let a: Vec<String> = (0..3).map(|i| f(&v[i], scale, digits)).collect();
    a.join(", ")
}

/// Runs `terrain-stats`.
pub fn run(a: TerrainStatsArgs) -> Result<(), CliError> {
    let mut logs = Vec::new();
    for d in &a.datasets {
        let ds = read_dataset(d)?;
        let r = replay_with(&ds, d, false, ReplayOptions::default())?;
        let name = d
            .file_name()
            .map_or_else(|| d.display().to_string(), |n| n.to_string_lossy().into());
        logs.push(log_stats(&name, &ds, &r));
    }
    let mut s = String::new();
    outln!(
        s,
        "| terrain | log | s | yaw residual mean / std / RMS [mrad/s] | gain | wheel NIS fwd / diff (1) | wheel gated | ZUPT NIS (9) | floor NIS (1) | forward noise used -> learned (unbounded) [m/s] |"
    );
    outln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for l in &logs {
        let y = &l["yaw_residual"];
        let w = &l["aids"]["wheel"];
        let comp = |name: &str| {
            w["components"]
                .as_array()
                .and_then(|c| c.iter().find(|c| c["name"] == name))
                .map_or_else(|| "-".into(), |c| f(&c["nis_mean"], 1.0, 2))
        };
        let n = &l["forward_noise"];
        outln!(
            s,
            "| {} | {} | {} | {} / {} / {} | {} | {} / {} | {} % | {} | {} | {} -> {} ({}) |",
            l["terrain"].as_str().unwrap_or("-"),
            l["log"].as_str().unwrap_or("-"),
            f(&l["duration_s"], 1.0, 1),
            f(&y["mean"], 1e3, 1),
            f(&y["std"], 1e3, 1),
            f(&y["rms"], 1e3, 1),
            f(&y["gain"], 1.0, 2),
            comp("forward"),
            comp("differential"),
            f(&w["gated_fraction"], 100.0, 1),
            f(&l["aids"]["zupt"]["nis_mean"], 1.0, 2),
            f(&l["aids"]["floor"]["nis_mean"], 1.0, 2),
            f(&n["filter_std"], 1.0, 3),
            f(&n["learned_std"], 1.0, 3),
            f(&n["unbounded_std"], 1.0, 3),
        );
    }
    outln!(s, "");
    outln!(
        s,
        "| terrain | log | path EKF / wheels [m] | gyro bias [mrad/s] | accel bias [m/s^2] | wheel radii L, R [m] (std) | track factor chi (std, updates) | learner's gyro z offset [mrad/s] |"
    );
    outln!(s, "|---|---|---|---|---|---|---|---|");
    for l in &logs {
        let g = &l["learned"];
        outln!(
            s,
            "| {} | {} | {} / {} | {} | {} | {}, {} ({}, {}) | {} ({}, {}) | {} |",
            l["terrain"].as_str().unwrap_or("-"),
            l["log"].as_str().unwrap_or("-"),
            f(&l["ekf_path_m"], 1.0, 1),
            f(&l["wheel_path_m"], 1.0, 1),
            triple(&g["gyro_bias"], 1e3, 2),
            triple(&g["accel_bias"], 1.0, 3),
            f(&g["wheel_radii"][0], 1.0, 4),
            f(&g["wheel_radii"][1], 1.0, 4),
            f(&g["wheel_radius_std"][0], 1.0, 4),
            f(&g["wheel_radius_std"][1], 1.0, 4),
            f(&g["track_factor"]["chi"], 1.0, 3),
            f(&g["track_factor"]["chi_std"], 1.0, 3),
            g["track_factor"]["updates"]
                .as_u64()
                .map_or_else(|| "-".into(), |u| u.to_string()),
            f(&g["track_factor"]["gyro_offset"], 1e3, 2),
        );
    }
    outln!(s, "");
    let noise = |key: &'static str| move |l: &Value| l["forward_noise"][key].as_f64();
    outln!(
        s,
        "{}",
        ranking(&logs, noise("learned_std"), "learned forward noise")
    );
    outln!(
        s,
        "{}",
        ranking(&logs, noise("unbounded_std"), "unbounded forward noise")
    );
    let yaw = |l: &Value| l["yaw_residual"]["rms"].as_f64();
    outln!(s, "{}", ranking(&logs, yaw, "yaw-rate residual RMS"));
    let chi = |l: &Value| l["learned"]["track_factor"]["chi"].as_f64();
    outln!(s, "{}", ranking(&logs, chi, "learned track factor chi"));
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&Value::Array(logs))
            .map_err(|e| CliError::file(p, e.to_string()))?;
        std::fs::write(p, text).map_err(|e| CliError::file(p, format!("cannot write: {e}")))?;
        outln!(s, "wrote {}", p.display());
    }
    super::write_stdout(&s)
}

/// Terrains by their logs' mean of `get`, least first.
fn ranking(logs: &[Value], get: impl Fn(&Value) -> Option<f64>, what: &str) -> String {
    let mut by_terrain: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for l in logs {
        if let Some(x) = get(l) {
            by_terrain
                .entry(l["terrain"].as_str().unwrap_or("unknown").to_string())
                .or_default()
                .push(x);
        }
    }
    let mut ranked: Vec<(String, f64)> = by_terrain
        .into_iter()
        .map(|(t, v)| (t, v.iter().sum::<f64>() / v.len() as f64))
        .collect();
    ranked.sort_by(|a, b| a.1.total_cmp(&b.1));
    format!(
        "terrains by {what} (least first): {}",
        ranked
            .iter()
            .map(|(t, x)| format!("{t} {x:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    )
}
