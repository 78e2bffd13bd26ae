//! Sensor faults in a recorded log reach the estimator: a simulated log
//! (the `short` scenario, 10 s, without the camera) is written clean and
//! again with bad rows injected into its `data.csv` files, one of each kind
//! per stream: a NaN and an infinite IMU value, a duplicated row, a row out
//! of order (a copy of an earlier row, later than the ordering window), and
//! a wheel counter jump. Replayed, the faulty log's rejection counts grow by
//! exactly what was injected, its EKF trajectory stays within 1.2x (+1 cm)
//! of the clean log's ATE, and `--strict` refuses it with exit 2.

mod common;

use host_sim::asl::write_dataset;
use host_sim::replay::{ReplayOptions, run_replay_with};
use host_sim::sim::scenario::{Scenario, generate};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-logf", name)
}

/// Index of the first data row (0-based among all lines) at or after `t_ns`.
fn row_at(lines: &[String], t_ns: u64) -> usize {
    lines
        .iter()
        .position(|l| {
            !l.starts_with('#') && l.split(',').next().unwrap().parse::<u64>().unwrap() >= t_ns
        })
        .unwrap()
}

/// Rewrites `mav0/<sensor>/data.csv` with `edit`.
fn edit(dataset: &Path, sensor: &str, edit: impl FnOnce(&mut Vec<String>)) {
    let p = dataset.join("mav0").join(sensor).join("data.csv");
    let mut lines: Vec<String> = std::fs::read_to_string(&p)
        .unwrap()
        .lines()
        .map(str::to_owned)
        .collect();
    edit(&mut lines);
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
}

/// Sets column `col` (0: the time stamp) of line `k` to `value`.
fn set(lines: &mut [String], k: usize, col: usize, value: &str) {
    let mut f: Vec<String> = lines[k].split(',').map(str::to_owned).collect();
    f[col] = value.to_owned();
    lines[k] = f.join(",");
}

/// Duplicates the row at `t`, and inserts a copy of the row 0.2 s before
/// `t + 1 s` right after the row at `t + 1 s` (out of order by 0.2 s).
fn duplicate_and_disorder(lines: &mut Vec<String>, t: u64) {
    let k = row_at(lines, t);
    lines.insert(k + 1, lines[k].clone());
    let late = row_at(lines, t + 1_000_000_000);
    let early = row_at(lines, t + 800_000_000);
    lines.insert(late + 1, lines[early].clone());
}

/// Rejections by stream and reason (without `gated`, which follows the
/// trajectory and may differ by a sample between two runs).
fn rejections(report: &Value) -> BTreeMap<(String, String), u64> {
    let mut m = BTreeMap::new();
    for s in ["imu", "wheel", "flow"] {
        for (r, n) in report["counts"][s]["rejected"].as_object().unwrap() {
            if r != "gated" {
                m.insert((s.to_string(), r.clone()), n.as_u64().unwrap());
            }
        }
    }
    m
}

fn ekf_ate(r: &host_sim::replay::ReplayOutput) -> f64 {
    r.errors
        .iter()
        .find(|(n, _)| *n == "ekf")
        .unwrap()
        .1
        .ate_rmse
}

#[test]
fn bad_rows_are_rejected_and_counted_by_reason_and_strict_refuses_them() {
    let root = tmp("run");
    let clean = root.join("clean");
    let mut sc = Scenario::by_name("short").unwrap();
    sc.script.duration = 10.0;
    let (mut ds, _) = generate(&sc, 1, &root.join("gen")).unwrap();
    ds.cam = None;
    ds.seg = None;
    write_dataset(&clean, &ds).unwrap();
    let faulty = root.join("faulty");
    write_dataset(&faulty, &ds).unwrap();

    // Well after the filter started, while driving.
    let t0 = ds.imu.as_ref().unwrap().1[0].t.0 + 5_000_000_000;
    edit(&faulty, "imu0", |l| {
        let k = row_at(l, t0);
        set(l, k, 1, "nan");
        set(l, k + 50, 6, "inf");
        duplicate_and_disorder(l, t0 + 500_000_000);
    });
    edit(&faulty, "wheel0", |l| {
        let k = row_at(l, t0 + 100_000_000);
        let left: i64 = l[k].split(',').nth(1).unwrap().parse().unwrap();
        set(l, k, 1, &(left + 1_000_000).to_string());
        duplicate_and_disorder(l, t0 + 700_000_000);
    });
    edit(&faulty, "flow0", |l| {
        duplicate_and_disorder(l, t0 + 900_000_000)
    });
    let injected: BTreeMap<(String, String), u64> = [
        ("imu", "non_finite", 2),
        ("imu", "duplicate", 1),
        ("imu", "out_of_order", 1),
        ("wheel", "out_of_range", 1),
        ("wheel", "duplicate", 1),
        ("wheel", "out_of_order", 1),
        ("flow", "duplicate", 1),
        ("flow", "out_of_order", 1),
    ]
    .into_iter()
    .map(|(s, r, n)| ((s.to_string(), r.to_string()), n))
    .collect();

    let a = run_replay_with(&clean, &root.join("a"), false, ReplayOptions::default()).unwrap();
    let b = run_replay_with(&faulty, &root.join("b"), false, ReplayOptions::default()).unwrap();
    let (ra, rb) = (rejections(&a.report), rejections(&b.report));
    let mut grown = BTreeMap::new();
    for (k, n) in &rb {
        let d = n - ra.get(k).copied().unwrap_or(0);
        if d > 0 {
            grown.insert(k.clone(), d);
        }
    }
    assert_eq!(
        grown, injected,
        "clean {ra:?}\nfaulty {rb:?}\nthe counts grew by what was injected"
    );
    for s in ["imu", "wheel", "flow"] {
        let seen = |r: &Value| r["counts"][s]["seen"].as_u64().unwrap();
        // Two rows added per stream (the duplicate and the disordered copy).
        assert_eq!(seen(&b.report), seen(&a.report) + 2, "{s}: rows added");
    }
    let (ate_a, ate_b) = (ekf_ate(&a), ekf_ate(&b));
    println!("EKF ATE clean {ate_a:.4} m, with bad rows {ate_b:.4} m");
    assert!(
        ate_b <= 1.2 * ate_a + 0.01,
        "ATE {ate_b} m with bad rows against {ate_a} m clean"
    );
    // The trajectories' time stamps increase despite the bad rows.
    for traj in [&b.ekf, &b.wheel_only] {
        assert!(traj.windows(2).all(|w| w[0].t < w[1].t));
    }

    // --strict keeps the refusal: exit 2 naming the first bad row.
    let strict = ReplayOptions {
        strict: true,
        ..ReplayOptions::default()
    };
    let Err(e) = run_replay_with(&faulty, &root.join("c"), false, strict) else {
        panic!("--strict replayed a log with bad rows");
    };
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().contains("imu0/data.csv:"), "{e}");

    // The command line: the summary names the rejections by reason.
    let host_sim = || Command::new(env!("CARGO_BIN_EXE_host-sim"));
    let r = host_sim()
        .args(["replay", "--strict", "--out"])
        .arg(root.join("d"))
        .arg(&faulty)
        .output()
        .unwrap();
    assert_eq!(r.status.code(), Some(2));
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("imu0/data.csv:"), "{err}");
    let r = host_sim()
        .args(["replay", "--out"])
        .arg(root.join("d"))
        .arg(&faulty)
        .output()
        .unwrap();
    assert!(r.status.success());
    let out = String::from_utf8_lossy(&r.stdout);
    let line = out
        .lines()
        .find(|l| l.starts_with("rejected by reason: imu: "))
        .unwrap_or_else(|| panic!("no rejections line in\n{out}"));
    for want in [
        "duplicate 1",
        "non_finite 2",
        "out_of_order 1",
        "; wheel: ",
        "; flow: ",
    ] {
        assert!(line.contains(want), "{want} not in {line}");
    }
    let _ = std::fs::remove_dir_all(&root);
}
