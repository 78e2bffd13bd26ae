//! `host-sim simulate|replay --compose pair|running` and `--scale-method
//! METHOD` end to end: the simulated `short` run, and the `slip` run's first
//! 12 s (a 3 s wheel-slip episode from 8 s on), with each setting, checked
//! in `report.json` (every frame pair's decision names the method, the
//! sources follow the method's rule, the applied scale is the pair's own or
//! the running one) and for a sane camera-path ATE.

mod common;
use common::host_sim;

use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-cli-scale", name)
}

fn run(cmd: &mut Command) {
    let o = cmd.output().unwrap();
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `simulate --scenario short --seed 1` with `args` into a fresh folder.
fn simulate(name: &str, args: &[&str]) -> (common::Scratch, Value) {
    simulate_in(name, &["--scenario", "short"], args)
}

/// `simulate --seed 1` of `scenario` with `args` into a fresh folder.
fn simulate_in(name: &str, scenario: &[&str], args: &[&str]) -> (common::Scratch, Value) {
    let out = tmp(name);
    run(host_sim()
        .args(["simulate", "--seed", "1"])
        .args(scenario)
        .arg("--out")
        .arg(&out)
        .args(args));
    let report = read_report(&out);
    (out, report)
}

fn read_report(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

fn frames(report: &Value) -> &Vec<Value> {
    report["frames"].as_array().unwrap()
}

fn vslam_ate(report: &Value) -> f64 {
    report["errors"]["vslam"]["ate_rmse_m"].as_f64().unwrap()
}

/// Frames with a scale, and how many of each source.
fn sources(report: &Value) -> std::collections::BTreeMap<String, usize> {
    let mut m = std::collections::BTreeMap::new();
    for f in frames(report) {
        if let Some(s) = f["source"].as_str() {
            *m.entry(s.to_string()).or_insert(0) += 1;
        }
    }
    m
}

/// Runs `--scale-method cli` on the first 12 s of `slip`, checks that every
/// decision names `debug`, that 70 % of the pairs got a scale and that the camera
/// path stays within 10 cm.
fn method_run(cli: &str, debug: &str) -> Value {
    method_run_within(cli, debug, 0.10)
}

/// [`method_run`] with the camera path's ATE bound `max_ate` (metres).
fn method_run_within(cli: &str, debug: &str, max_ate: f64) -> Value {
    let (_, report) = simulate_in(
        cli,
        &["--scenario", "slip", "--duration", "12"],
        &["--scale-method", cli],
    );
    let fs = frames(&report);
    assert!(fs.len() > 100, "{cli}: {} frame pairs", fs.len());
    for f in fs {
        assert_eq!(f["method"], debug, "{cli}: {f}");
    }
    let scaled = fs.iter().filter(|f| f["scale"].is_number()).count();
    // Wheel-only has no scale while the wheels slip (confidence too low).
    assert!(
        scaled * 10 >= fs.len() * 7,
        "{cli}: {scaled} of {}",
        fs.len()
    );
    let ate = vslam_ate(&report);
    println!(
        "{cli}: vslam ATE {ate:.4} m, sources {:?}",
        sources(&report)
    );
    assert!(ate < max_ate, "{cli}: vslam ATE {ate} m");
    report
}

/// Flow-only and wheel-only take their one source; the slipping wheels'
/// scale stretches the camera path (the baseline every gated method beats).
#[test]
fn flow_only_and_wheel_only_use_their_one_source() {
    let flow = method_run("flow-only", "FlowOnly");
    assert_eq!(sources(&flow).keys().collect::<Vec<_>>(), ["flow"]);
    let wheel = method_run_within("wheel-only", "WheelOnly", 0.3);
    assert_eq!(sources(&wheel).keys().collect::<Vec<_>>(), ["wheel"]);
    assert!(vslam_ate(&wheel) > 2.0 * vslam_ate(&flow));
}

#[test]
fn fusion_fuses_and_gates_slipping_wheels() {
    let r = method_run("fusion", "Fusion");
    assert!(sources(&r).get("fused").is_some_and(|n| *n > 50));
    for f in frames(&r) {
        if f["slip_exceeded"] == true || f["wheel_outlier"] == true {
            assert_ne!(f["source"], "fused", "{f}");
            assert_ne!(f["source"], "wheel", "{f}");
        }
    }
}

/// Slip threshold and wheel outlier: the wheels unless the method's gate
/// fired, then the flow sensor.
fn gated_method(cli: &str, debug: &str, gate: &str) {
    let r = method_run(cli, debug);
    let mut gated = 0;
    for f in frames(&r).iter().filter(|f| f["source"].is_string()) {
        if f[gate] == true {
            gated += 1;
            assert_eq!(f["source"], "flow", "{cli}: {f}");
        } else if f["wheel_m"].as_f64().unwrap() > 0.001
            && f["wheel_confidence"].as_f64() > Some(0.05)
        {
            assert_eq!(f["source"], "wheel", "{cli}: {f}");
        }
    }
    println!("{cli}: {gated} pairs gated");
    assert!(gated >= 10, "{cli}: the slip episode gated {gated} pairs");
    assert!(sources(&r).get("wheel").is_some_and(|n| *n > 50), "{cli}");
}

#[test]
fn slip_threshold_takes_the_flow_only_on_slip() {
    gated_method("slip-threshold", "SlipThreshold", "slip_exceeded");
}

#[test]
fn wheel_outlier_takes_the_flow_only_on_outliers() {
    gated_method("wheel-outlier", "Outlier", "wheel_outlier");
}

#[test]
fn source_confidence_takes_the_more_confident_source() {
    let r = method_run("source-confidence", "SourceConfidence");
    for f in frames(&r).iter().filter(|f| f["source"].is_string()) {
        let (w, o) = (
            f["wheel_confidence"].as_f64().unwrap(),
            f["flow_confidence"].as_f64().unwrap(),
        );
        if f["source"] == "wheel" {
            let flow_unusable = o < 0.05 || f["flow_m"].as_f64().unwrap() < 0.001;
            assert!(w > o || flow_unusable, "{f}");
        }
        assert_ne!(f["source"], "fused", "{f}");
    }
}

#[test]
fn scale_confidence_picks_one_source_per_pair() {
    let r = method_run("scale-confidence", "ScaleConfidence");
    let s = sources(&r);
    assert!(!s.contains_key("fused"), "{s:?}");
}

/// `pair`: every pair with a scale is composed with exactly that scale;
/// `running`: with the running median, which differs from the pair's own on
/// most pairs. Both paths stay within 10 cm; `replay` takes the flag too.
#[test]
fn compose_pair_and_running_end_to_end() {
    let (out, pair) = simulate("pair", &["--compose", "pair"]);
    let mut own = 0;
    for f in frames(&pair) {
        if let Some(s) = f["scale"].as_f64() {
            assert_eq!(f["applied_scale"].as_f64(), Some(s), "{f}");
            own += 1;
        }
    }
    assert!(own > 100, "{own}");
    let again = out.join("running");
    run(host_sim()
        .arg("replay")
        .arg(out.join("dataset"))
        .args(["--compose", "running", "--out"])
        .arg(&again));
    let running = read_report(&again);
    let differ = frames(&running)
        .iter()
        .filter(|f| {
            f["scale"]
                .as_f64()
                .zip(f["applied_scale"].as_f64())
                .is_some_and(|(s, a)| (s - a).abs() > 1e-6)
        })
        .count();
    assert!(differ > 50, "running scale applied on {differ} pairs");
    let (a, b) = (vslam_ate(&pair), vslam_ate(&running));
    println!("vslam ATE: pair {a:.4} m, running {b:.4} m");
    assert!(a < 0.10 && b < 0.10, "pair {a}, running {b}");
    assert_ne!(
        std::fs::read(out.join("vslam.tum")).unwrap(),
        std::fs::read(again.join("vslam.tum")).unwrap()
    );
}

#[test]
fn unknown_names_are_usage_errors() {
    for args in [["--scale-method", "best"], ["--compose", "frame"]] {
        let bad = tmp("bad");
        let o = host_sim()
            .args(["simulate", "--scenario", "short", "--out"])
            .arg(&bad)
            .args(args)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
    }
}
