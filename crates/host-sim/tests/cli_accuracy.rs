//! `host-sim accuracy` end to end on one short run: one table row per run,
//! read from that run's own report.json, and the goals line.

use std::process::Command;

mod common;

#[test]
fn accuracy_prints_one_row_per_run_from_its_report() {
    let out = common::scratch("host-sim-accuracy", "short");
    let run = Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(["accuracy", "--scenarios", "short", "--seeds", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    // Exit 0 when every goal is met, 1 when one is missed; never 2.
    assert!(matches!(run.status.code(), Some(0 | 1)), "{run:?}");
    let rows: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("| short |"))
        .collect();
    assert_eq!(rows.len(), 1, "{stdout}");
    assert!(stdout.contains("goals met on "), "{stdout}");
    // The row's fused ATE is the run's report.json figure.
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("short-2/report.json")).unwrap())
            .unwrap();
    let ate = report["errors"]["ekf"]["ate_rmse_m"].as_f64().unwrap();
    let cell = rows[0].split('|').nth(3).unwrap().trim();
    assert_eq!(cell, format!("{ate:.3}"), "{stdout}");
    // The dataset (images) is not kept without --keep.
    assert!(!out.join("short-2/dataset").exists());
}
