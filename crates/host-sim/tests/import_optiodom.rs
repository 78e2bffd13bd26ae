//! `host-sim import optiodom` on the committed excerpt (`data/real/optiodom`:
//! the first 20 s of an OptiOdom square run, MIT), then `replay`.

mod common;
use common::host_sim;

use std::path::PathBuf;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-import-oo", name)
}

fn excerpt() -> PathBuf {
    common::repo_data("real/optiodom")
}

/// Dead reckoning by the midpoint rule straight from the run file (right
/// ticks first), as the dataset's README checks it: the end pose.
fn midpoint_dead_reckoning(run: &str) -> (f64, f64, f64) {
    let per_tick = std::f64::consts::PI * 0.084 / (43.7 * 64.0);
    let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
    for line in run.lines() {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        let (dr, dl) = (f[4] * per_tick, f[5] * per_tick);
        let (ds, dth) = (0.5 * (dr + dl), (dr - dl) / 0.2);
        x += ds * (th + 0.5 * dth).cos();
        y += ds * (th + 0.5 * dth).sin();
        th += dth;
    }
    (x, y, th)
}

#[test]
fn the_excerpt_replays_to_the_wheels_dead_reckoning() {
    let d = tmp("ok");
    let run = excerpt().join("231220200029_run-01.csv");
    let imp = host_sim()
        .args(["import", "optiodom"])
        .arg(&run)
        .arg("--out")
        .arg(d.join("ds"))
        .output()
        .unwrap();
    common::assert_ok(&imp);
    let csv = std::fs::read_to_string(d.join("ds/mav0/wheel0/data.csv")).unwrap();
    assert!(csv.starts_with("#timestamp [ns],left [ticks],right [ticks]\n"));
    // Row 3 of the run has odoR 6, odoL 5 (right first): cumulative left 5, right 6.
    assert_eq!(csv.lines().nth(3), Some("100000000,5,6"));

    let text = common::replay(&d.join("ds"), &d.join("out"), &[]);
    assert!(text.contains("reference: optitrack"), "{text}");
    assert!(
        text.contains("the wheel-only trajectory is the estimate"),
        "{text}"
    );

    // The wheel-only trajectory ends where the README's midpoint rule does.
    let (x, y, th) = midpoint_dead_reckoning(&std::fs::read_to_string(&run).unwrap());
    let tum = std::fs::read_to_string(d.join("out/wheel_only.tum")).unwrap();
    let last: Vec<f64> = tum
        .lines()
        .last()
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(last[0], 19.95);
    assert!(
        (last[1] - x).abs() < 1e-3 && (last[2] - y).abs() < 1e-3,
        "{last:?} vs {x} {y}"
    );
    let yaw = 2.0 * last[6].atan2(last[7]);
    let dyaw = (yaw - th).sin().abs();
    assert!(dyaw < 1e-3, "yaw {yaw} vs {th}");

    // Against OptiTrack over these 20 s (measured: ATE 0.011 m, final 0.012 m).
    let report = common::report(&d.join("out"));
    let e = &report["errors"]["wheel_only"];
    let ate = e["ate_rmse_m"].as_f64().unwrap();
    let fin = e["final_error_m"].as_f64().unwrap();
    assert!((ate - 0.0112).abs() < 0.0005, "ATE {ate}");
    assert!((fin - 0.0122).abs() < 0.0005, "final {fin}");
    assert_eq!(report["labels"]["reference"], "optitrack");
}

#[test]
fn malformed_runs_exit_2_naming_file_and_line() {
    let d = tmp("bad");
    let text = std::fs::read_to_string(excerpt().join("231220200029_run-01.csv")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[6] = "0.3,0.1,0.2,0.3,4";
    let run = d.join("231220200029_run-01.csv");
    std::fs::write(&run, lines.join("\n")).unwrap();
    std::fs::copy(
        excerpt().join("231220200029_metadata.csv"),
        d.join("231220200029_metadata.csv"),
    )
    .unwrap();
    let out = host_sim()
        .args(["import", "optiodom"])
        .arg(&run)
        .arg("--out")
        .arg(d.join("ds"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("231220200029_run-01.csv:7: expected 6 columns"),
        "{err}"
    );
    assert!(!d.join("ds").exists(), "nothing is written for bad input");

    // Without a metadata file beside the run, the error says how to give one.
    std::fs::remove_file(d.join("231220200029_metadata.csv")).unwrap();
    let out = host_sim()
        .args(["import", "optiodom"])
        .arg(
            excerpt()
                .join("231220200029_run-01.csv")
                .with_file_name("nope_run-01.csv"),
        )
        .arg("--out")
        .arg(d.join("ds"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--metadata"));
}
