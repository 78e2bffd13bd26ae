//! The long commands draw progress bars only on a terminal: with stderr a
//! pipe (as here) `simulate`, `simulate --faults` and `replay` write nothing
//! to it.

mod common;
use common::host_sim;

use std::process::Output;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-cli-progress", name)
}

/// `run` succeeded and drew nothing on stderr: no carriage returns or
/// escape codes of a bar, no text at all.
fn quiet(what: &str, run: &Output) {
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{what}: {err}");
    assert!(
        !err.contains('\r') && !err.contains('\x1b'),
        "{what} drew on a pipe: {err:?}"
    );
    assert!(err.is_empty(), "{what} wrote to stderr: {err:?}");
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(
        !out.contains('\r') && !out.contains('\x1b'),
        "{what} drew on stdout: {out:?}"
    );
}

#[test]
fn simulate_and_replay_are_quiet_on_a_pipe() {
    let out = tmp("sim");
    let sim = host_sim()
        .args(["simulate", "--scenario", "short", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    quiet("simulate", &sim);
    assert!(String::from_utf8_lossy(&sim.stdout).contains("wrote "));

    let rep = host_sim()
        .arg("replay")
        .arg(out.join("dataset"))
        .arg("--out")
        .arg(out.join("again"))
        .output()
        .unwrap();
    quiet("replay", &rep);

    let faults = tmp("faults");
    let run = host_sim()
        .args([
            "simulate",
            "--scenario",
            "short",
            "--faults",
            "wheel-gap@5+0.5",
            "--out",
        ])
        .arg(&faults)
        .output()
        .unwrap();
    quiet("simulate --faults", &run);
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&faults);
}
