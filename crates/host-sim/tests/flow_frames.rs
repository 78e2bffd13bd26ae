//! Optical flow from the flow sensor's raw frames, end to end: rendered
//! frames through the chip simulator's frame-grab registers and the real
//! driver, corners and Lucas-Kanade, `To` against the truth; a log with
//! `flowraw0` and no counts is replayed from its frames; cutting any link
//! (no frames, frames that do not move) shows.

mod common;

use host_sim::asl::{read_dataset, write_dataset};
use host_sim::replay::{FlowSource, ReplayOptions, replay_with};
use host_sim::sim::drivers::FrameGrabber;
use host_sim::sim::flow_accuracy::{measure, one_floor};
use host_sim::sim::flow_frames::{FlowFrameRenderer, record};
use host_sim::sim::scenario::{Scenario, generate};
use host_sim::sim::sensors::FlowModel;
use host_sim::sim::world::Surface;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-flowraw", name)
}

#[test]
fn the_driver_grabs_the_rendered_frame_through_the_registers() {
    let sc = Scenario::by_name("short").unwrap();
    let (_, truth) = generate(&sc, 1, &tmp("grab")).unwrap();
    let r = FlowFrameRenderer::new(&FlowModel::paa5100());
    let frame = r.render(
        &one_floor(Surface::Carpet),
        &truth[500],
        &mut ChaCha8Rng::seed_from_u64(1),
    );
    let mut g = FrameGrabber::new().unwrap();
    assert_eq!(g.grab(&frame).unwrap(), frame.pixels);
}

#[test]
fn to_from_frames_follows_the_truth() {
    for surface in [Surface::Wood, Surface::Carpet] {
        let a = measure(surface, 0.3, 1.0, 5).unwrap();
        assert!(a.frames_rms_pct < 10.0, "{a:?}");
        assert!(a.frames_total_pct.abs() < 4.0, "{a:?}");
        assert!(a.frames_refused_pct < 10.0, "{a:?}");
    }
}

fn flow_metres(report: &Value) -> Vec<f64> {
    report["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["flow_m"].as_f64().unwrap_or(0.0))
        .collect()
}

#[test]
fn a_log_with_frames_and_no_counts_is_replayed_from_its_frames() {
    let root = tmp("log");
    let mut sc = Scenario::by_name("short").unwrap();
    sc.script.duration = 6.0;
    let (mut ds, truth) = generate(&sc, 3, &root).unwrap();
    ds.flowraw = Some(record(&sc.world, &sc.flow, &truth, 3, &root).unwrap());
    write_dataset(&root, &ds).unwrap();
    let with_counts = read_dataset(&root).unwrap();
    let n = with_counts.flowraw.as_ref().map_or(0, |f| f.1.len());
    assert!(n >= 500, "{n} frames");

    // Counts by default when both are in the log.
    let counts = replay_with(&with_counts, &root, false, ReplayOptions::default()).unwrap();
    assert_eq!(counts.report["counts"]["flow_frame"]["seen"], 0);
    // Asked for frames: the frames' To, the counts unused.
    let frames_opt = ReplayOptions {
        flow_source: Some(FlowSource::Frames),
        ..ReplayOptions::default()
    };
    let frames = replay_with(&with_counts, &root, false, frames_opt).unwrap();
    assert_eq!(frames.report["counts"]["flow"]["seen"], 0);
    assert_eq!(frames.report["counts"]["flow_frame"]["seen"], n as u64);
    let fused = frames.report["counts"]["flow_frame"]["fused"]
        .as_u64()
        .unwrap();
    assert!(fused as usize * 10 > n * 9, "{fused} of {n} fused");

    // Each camera pair's To from frames agrees with the one from counts.
    let (a, b) = (flow_metres(&counts.report), flow_metres(&frames.report));
    assert_eq!(a.len(), b.len());
    let moving: Vec<f64> = a
        .iter()
        .zip(&b)
        .filter(|(c, _)| **c > 0.01)
        .map(|(c, f)| f / c)
        .collect();
    assert!(moving.len() >= 20, "{} moving pairs", moving.len());
    let mut sorted = moving.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!((median - 1.0).abs() < 0.05, "frames/counts To: {sorted:?}");

    // Without counts in the log, the frames are used on their own.
    let mut no_counts = with_counts.clone();
    no_counts.flow = None;
    let auto = replay_with(&no_counts, &root, false, ReplayOptions::default()).unwrap();
    assert_eq!(flow_metres(&auto.report), b);

    // Cut the link: the same log without its frames has no flow at all.
    let mut cut = no_counts.clone();
    cut.flowraw = None;
    let none = replay_with(&cut, &root, false, ReplayOptions::default()).unwrap();
    assert!(flow_metres(&none.report).iter().all(|m| *m == 0.0));
}
