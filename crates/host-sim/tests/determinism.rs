//! Determinism and a change indicator for the whole chain (simulator, drivers,
//! ASL files, estimator, writers).
//!
//! One short run, the `short` scenario cut to [`SECONDS`] s with seed
//! [`SEED`], is simulated into an ASL log and replayed twice: both replays must
//! write byte-identical files, and those files must equal the committed
//! reference in `crates/host-sim/tests/reference/short_seed1/` (the simulated log's
//! `wheel0/data.csv` and `flow0/data.csv`, and the replay's `ekf.tum`,
//! `vslam.tum`, `wheel_only.tum`, `groundtruth.tum` and `report.json`; not the images or the
//! plot). A mismatch names the file, the first differing line and both
//! versions of it.
//!
//! Any change to the maths or the simulator that moves a single bit of the
//! output trips this test. That is its job: when the change is intended,
//! regenerate the reference on purpose and commit it with the change:
//!
//! ```text
//! UPDATE_REFERENCE=1 cargo test -p host-sim --test determinism
//! git add crates/host-sim/tests/reference/short_seed1
//! ```
//!
//! The reference is bit-exact only for one platform and toolchain family (the
//! simulator uses the host's `f64` `sin`/`cos`); it was written on
//! x86_64-unknown-linux-gnu, where CI runs.

mod common;

use host_sim::asl::write_dataset;
use host_sim::replay::run_replay;
use host_sim::sim::scenario::{Scenario, generate};
use std::path::{Path, PathBuf};

/// Simulated seconds of the reference run.
const SECONDS: f64 = 5.0;
/// Seed of the reference run.
const SEED: u64 = 1;
/// Where the reference lives, relative to this crate (`crates/host-sim`).
const REFERENCE: &str = "tests/reference/short_seed1";
/// Files of the simulated log compared (relative to the dataset's `mav0/`).
const LOG_FILES: [&str; 2] = ["wheel0/data.csv", "flow0/data.csv"];
/// Files of the replay compared.
const REPLAY_FILES: [&str; 5] = [
    "ekf.tum",
    "vslam.tum",
    "wheel_only.tum",
    "groundtruth.tum",
    "report.json",
];

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-det", name)
}

/// The first line where `a` and `b` differ (1-based), with both versions.
fn first_difference(a: &str, b: &str) -> Option<(usize, String, String)> {
    let (mut la, mut lb) = (a.lines(), b.lines());
    for n in 1.. {
        match (la.next(), lb.next()) {
            (None, None) => return None,
            (x, y) if x == y => {}
            (x, y) => {
                let show = |l: Option<&str>| l.unwrap_or("<end of file>").to_string();
                return Some((n, show(x), show(y)));
            }
        }
    }
    None
}

/// The (reference name, produced file) pairs of one run.
fn produced(dataset: &Path, out: &Path) -> Vec<(String, PathBuf)> {
    let log = LOG_FILES
        .iter()
        .map(|f| (format!("log/{f}"), dataset.join("mav0").join(f)));
    let replay = REPLAY_FILES
        .iter()
        .map(|f| (format!("replay/{f}"), out.join(f)));
    log.chain(replay).collect()
}

#[test]
fn short_run_is_deterministic_and_matches_the_reference() {
    let root = tmp("short");
    let dataset = root.join("dataset");
    let mut sc = Scenario::by_name("short").unwrap();
    sc.script.duration = SECONDS;
    let (ds, _) = generate(&sc, SEED, &dataset).unwrap();
    write_dataset(&dataset, &ds).unwrap();
    run_replay(&dataset, &root.join("a"), false).unwrap();
    run_replay(&dataset, &root.join("b"), false).unwrap();

    // Replaying the same log twice writes byte-identical files.
    for f in REPLAY_FILES.iter().chain(["trajectory.svg"].iter()) {
        let (x, y) = (
            std::fs::read(root.join("a").join(f)).unwrap(),
            std::fs::read(root.join("b").join(f)).unwrap(),
        );
        assert!(!x.is_empty(), "{f} is empty");
        assert!(x == y, "{f} differs between two replays of the same log");
    }

    let reference = Path::new(env!("CARGO_MANIFEST_DIR")).join(REFERENCE);
    let files = produced(&dataset, &root.join("a"));
    if std::env::var_os("UPDATE_REFERENCE").is_some() {
        for (name, path) in &files {
            let dst = reference.join(name);
            std::fs::create_dir_all(dst.parent().unwrap()).unwrap();
            std::fs::copy(path, &dst).unwrap();
        }
        println!("reference rewritten in {}", reference.display());
        let _ = std::fs::remove_dir_all(&root);
        return;
    }
    let how = "if the change is intended, regenerate on purpose with\n  \
               UPDATE_REFERENCE=1 cargo test -p host-sim --test determinism\n\
               and commit crates/host-sim/tests/reference/short_seed1 with the change";
    let mut mismatches = Vec::new();
    for (name, path) in &files {
        let want_path = reference.join(name);
        let Ok(want) = std::fs::read_to_string(&want_path) else {
            mismatches.push(format!("{}: missing reference file", want_path.display()));
            continue;
        };
        let got = std::fs::read_to_string(path).unwrap();
        if let Some((line, w, g)) = first_difference(&want, &got) {
            mismatches.push(format!(
                "{name}: first difference at line {line}\n  reference: {w}\n  now:       {g}"
            ));
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    assert!(
        mismatches.is_empty(),
        "the short run (seed {SEED}, {SECONDS} s) no longer matches {REFERENCE}:\n{}\n{how}",
        mismatches.join("\n")
    );
}

#[test]
fn first_difference_names_the_line() {
    assert_eq!(first_difference("a\nb\nc\n", "a\nb\nc\n"), None);
    assert_eq!(
        first_difference("a\nb\nc\n", "a\nx\nc\n"),
        Some((2, "b".into(), "x".into()))
    );
    assert_eq!(
        first_difference("a\nb\n", "a\n"),
        Some((2, "b".into(), "<end of file>".into()))
    );
}
