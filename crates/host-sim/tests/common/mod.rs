//! What host-sim's integration tests share: the binary, scratch folders, a
//! run that must succeed, `replay` of a dataset, its `report.json`, the
//! data committed in the repository and numeric CSV rows.
//!
//! Each test file uses a part of it (`mod common;`), so unused items are
//! allowed here.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `host-sim` binary built for this test run.
pub fn host_sim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

/// `host-sim simulate --scenario slip --duration 12 --seed 1` (the slip
/// scenario's first wheel-spin episode at 8-11 s), for the caller to add
/// `--out` and more.
pub fn simulate_slip_12s() -> Command {
    let mut c = host_sim();
    c.args([
        "simulate",
        "--scenario",
        "slip",
        "--duration",
        "12",
        "--seed",
        "1",
    ]);
    c
}

/// An empty scratch folder `<temp>/<prefix>-<name>-<random>`, removed with
/// everything in it when the value is dropped (at the end of the test,
/// passed or failed). Derefs to its path; keep it bound for as long as
/// the folder is used (a temporary is dropped, and the folder removed, at
/// the end of its statement).
pub fn scratch(prefix: &str, name: &str) -> Scratch {
    Scratch(
        tempfile::Builder::new()
            .prefix(&format!("{prefix}-{name}-"))
            .tempdir()
            .unwrap(),
    )
}

/// A scratch folder (see [`scratch`]).
#[must_use]
pub struct Scratch(tempfile::TempDir);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<std::ffi::OsStr> for Scratch {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.path().as_os_str()
    }
}

/// Fails the test with the run's standard error unless it exited 0.
pub fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs `cmd`, failing the test with its standard error unless it exits 0.
pub fn succeed(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    assert_ok(&out);
    out
}

/// `host-sim replay DATASET --out OUT [extra]`, which must succeed; gives
/// its standard output.
pub fn replay(dataset: &Path, out: &Path, extra: &[&str]) -> String {
    let o = succeed(
        host_sim()
            .arg("replay")
            .arg(dataset)
            .arg("--out")
            .arg(out)
            .args(extra),
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `OUT/report.json`, parsed.
pub fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

/// A path under the repository's `data/` folder.
pub fn repo_data(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(relative)
}

/// The rows of a numeric CSV file after its header line.
pub fn csv_rows(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect()
}
