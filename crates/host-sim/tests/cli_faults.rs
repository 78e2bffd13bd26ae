//! `host-sim simulate --faults` through the binary: the help lists every
//! kind, a bad list is a usage error (exit 2), and a run writes the `faults`
//! section of `report.json` whose counts match the report's own counts.

mod common;
use common::host_sim;

use serde_json::Value;

#[test]
fn help_lists_the_syntax_and_every_kind() {
    let out = host_sim().args(["simulate", "--help"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("KIND@START[+DUR][xCOUNT]"), "{text}");
    for kind in [
        "imu-nan",
        "flow-limit",
        "wheel-dt0",
        "flow-late",
        "imu-gap",
        "wheel-spi",
        "flow-brownout",
        "wheel-parity",
        "wheel-wrap",
        "cam-frozen",
        "seg-unknown",
        "stuck",
        "lifted",
        "bump",
    ] {
        assert!(text.contains(kind), "{kind} missing from the help");
    }
}

#[test]
fn a_bad_fault_list_is_a_usage_error() {
    for bad in ["imu-nan", "nope@3", "wheel-gap@3x2", "imu-nan@-1"] {
        let dir = common::scratch("host-sim-cli-faults", "bad");
        let out = host_sim()
            .args(["simulate", "--scenario", "short", "--faults", bad, "--out"])
            .arg(&dir)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{bad}");
        assert!(
            !dir.join("report.json").exists(),
            "{bad}: something was written"
        );
    }
}

#[test]
fn report_json_counts_what_was_injected() {
    let dir = common::scratch("host-sim-cli-faults", "run");
    let out = host_sim()
        .args([
            "simulate",
            "--scenario",
            "short",
            "--faults",
            "imu-nan@4x2,flow-limit@5x3,wheel-spi@6",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    common::assert_ok(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("flow-limit@5x3"), "{stdout}");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    let f = &report["faults"];
    assert_eq!(f["plan"], "imu-nan@4x2,flow-limit@5x3,wheel-spi@6");
    let expect = [
        ("imu", "non_finite", 2),
        ("flow", "saturated", 3),
        ("wheel", "bus", 1),
    ];
    for ((stream, reason, n), fault) in expect.iter().zip(f["faults"].as_array().unwrap()) {
        assert_eq!(fault["injected"], *n);
        assert_eq!(fault["as_expected"], *n);
        assert_eq!(fault["expected"], *reason);
        assert_eq!(
            report["counts"][stream]["rejected"][reason], *n,
            "{stream} {reason}"
        );
    }
    let h = &f["health"];
    assert_eq!(h["non_finite_steps"], 0);
    assert_eq!(h["not_spd_steps"], 0);
    assert!(h["imu_steps_checked"].as_u64().unwrap() > 2000);
}

#[test]
fn a_fault_that_never_fires_changes_nothing() {
    // A cable at 100 s, after the 12 s run: the fault path (generation with
    // fault hooks, the log read back, the stream injector, the feed) must
    // give exactly the outputs of a plain run.
    let base = common::scratch("host-sim-cli-faults", "idle");
    let (plain, idle) = (base.join("plain"), base.join("idle"));
    for (dir, extra) in [(&plain, None), (&idle, Some("bump@100"))] {
        let mut cmd = host_sim();
        cmd.args(["simulate", "--scenario", "short", "--out"])
            .arg(dir);
        if let Some(f) = extra {
            cmd.args(["--faults", f]);
        }
        assert!(cmd.output().unwrap().status.success());
    }
    for f in ["ekf.tum", "vslam.tum", "wheel_only.tum", "trajectory.svg"] {
        assert_eq!(
            std::fs::read(plain.join(f)).unwrap(),
            std::fs::read(idle.join(f)).unwrap(),
            "{f} differs"
        );
    }
    let read = |d: &std::path::Path| -> Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("report.json")).unwrap()).unwrap()
    };
    let mut with = read(&idle);
    let faults = with.as_object_mut().unwrap().remove("faults").unwrap();
    assert_eq!(with, read(&plain));
    assert_eq!(faults["faults"][0]["injected"], 0);
}
