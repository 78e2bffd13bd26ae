//! `host-sim simulate --memory FILE` end to end: the adverse-event memory
//! lasts across runs. Two runs of the `slip` scenario's first 12 s (a 3 s
//! wheel-spin episode from 8 s on) share one memory file: the first starts
//! empty and writes what it learned, the second restores it and trusts the
//! wheels less at the slippery place from its first frame there on. A
//! corrupt file is refused on stderr, kept aside, and the run goes on with
//! an empty memory (its decisions equal the first run's).

mod common;

use serde_json::Value;
use std::path::Path;
use std::process::Output;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-cli-memory", name)
}

/// `simulate --scenario slip --duration 12 --seed 1 --memory memory` into `out`.
fn simulate(out: &Path, memory: &Path) -> (Value, Output) {
    let o = common::simulate_slip_12s()
        .arg("--out")
        .arg(out)
        .arg("--memory")
        .arg(memory)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    (report, o)
}

fn frames(report: &Value) -> &Vec<Value> {
    report["frames"].as_array().unwrap()
}

fn weights(report: &Value) -> Vec<f64> {
    frames(report)
        .iter()
        .map(|f| f["wheel_weight"].as_f64().unwrap())
        .collect()
}

/// Index of the first frame pair of the wheel-spin episode (slip exceeded
/// after 7 s).
fn first_slip_frame(report: &Value) -> usize {
    frames(report)
        .iter()
        .position(|f| f["t"].as_u64().unwrap() > 7_000_000_000 && f["slip_exceeded"] == true)
        .expect("the slip episode is detected")
}

#[test]
fn a_second_run_trusts_the_wheels_less_at_the_slippery_place_from_the_start() {
    let root = tmp("twice");
    let memory = root.join("memory.bin");
    let (first, _) = simulate(&root.join("first"), &memory);
    assert_eq!(first["memory"]["at_start"], "absent");
    assert_eq!(first["memory"]["cells_at_start"], 0);
    let learned = first["memory"]["cells_at_end"].as_u64().unwrap();
    assert!(learned > 0, "{}", first["memory"]);
    assert!(memory.is_file());

    let (second, out) = simulate(&root.join("second"), &memory);
    assert_eq!(second["memory"]["at_start"], "restored");
    assert_eq!(second["memory"]["cells_at_start"], learned);
    assert!(String::from_utf8_lossy(&out.stdout).contains("restored with"));

    let k = first_slip_frame(&first);
    assert_eq!(k, first_slip_frame(&second), "the same drive");
    let (w1, w2) = (weights(&first), weights(&second));
    // The first run meets the place fresh: full weight at its first slip
    // frame. The second remembers it: the wheels' weight is low there at once.
    assert_eq!(w1[k], 1.0, "the first run has not seen this place");
    assert!(w2[k] < 0.5, "remembered slip lowers the weight: {}", w2[k]);
    assert!(
        frames(&second)[k]["wheel_confidence"].as_f64().unwrap()
            < frames(&first)[k]["wheel_confidence"].as_f64().unwrap()
    );
    // Over the whole episode the second run trusts the wheels less ...
    let episode: Vec<usize> = (k..w1.len())
        .take_while(|&i| frames(&first)[i]["slip_exceeded"] == true)
        .collect();
    assert!(episode.len() >= 10, "{}", episode.len());
    for &i in &episode {
        assert!(w2[i] < w1[i], "frame {i}: {} vs {}", w2[i], w1[i]);
    }
    // ... and nowhere more than the first run.
    for (i, (a, b)) in w1.iter().zip(&w2).enumerate() {
        assert!(b <= a, "frame {i}: {b} > {a}");
    }
}

#[test]
fn a_corrupt_memory_file_is_refused_and_the_run_starts_empty() {
    let root = tmp("corrupt");
    let memory = root.join("memory.bin");
    let (first, _) = simulate(&root.join("first"), &memory);
    let mut bytes = std::fs::read(&memory).unwrap();
    bytes[70] ^= 0x5a;
    std::fs::write(&memory, &bytes).unwrap();

    let (again, out) = simulate(&root.join("again"), &memory);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("memory file")
            && stderr.contains("refused (record checksum mismatch)")
            && stderr.contains("empty"),
        "{stderr}"
    );
    assert_eq!(again["memory"]["at_start"], "refused");
    assert_eq!(
        again["memory"]["refused_because"],
        "record checksum mismatch"
    );
    assert_eq!(again["memory"]["cells_at_start"], 0);
    // An empty memory: the same weights as the first run, which started empty.
    assert_eq!(weights(&again), weights(&first));
    // The refused file is kept aside as it was; a sound record replaces it.
    let aside = root.join("memory.bin.refused");
    assert_eq!(std::fs::read(&aside).unwrap(), bytes);
    assert_eq!(
        again["memory"]["refused_file_kept_as"],
        aside.display().to_string()
    );
    let (third, _) = simulate(&root.join("third"), &memory);
    assert_eq!(third["memory"]["at_start"], "restored");

    // Not a record at all: refused the same way.
    std::fs::write(&memory, b"not a memory").unwrap();
    let (junk, out) = simulate(&root.join("junk"), &memory);
    assert_eq!(junk["memory"]["at_start"], "refused");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("refused (record magic mismatch)"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
