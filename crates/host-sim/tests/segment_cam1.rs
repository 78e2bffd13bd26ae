//! A log without segmentation maps (`seg0`) but with forward frames
//! (`cam1`): the replay labels the frames with the reference floor model and
//! the surface model uses those maps; without `cam1` there is no surface.

mod common;

use host_sim::asl::{read_dataset, write_dataset};
use host_sim::replay::{ReplayOptions, replay_with};
use host_sim::sim::scenario::{Scenario, generate};
use serde_json::Value;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-cam1", name)
}

fn surfaces(report: &Value) -> Vec<(String, String)> {
    report["surface_timeline"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["outcome"].as_str().unwrap_or("-").to_string(),
                s["surface"].as_str().unwrap_or("none").to_string(),
            )
        })
        .collect()
}

#[test]
fn replay_labels_cam1_frames_when_the_log_has_no_maps() {
    let root = tmp("office");
    let mut sc = Scenario::by_name("short").unwrap();
    sc.script.duration = 6.0;
    let (mut ds, _) = generate(&sc, 3, &root).unwrap();
    let frames = ds.cam1.as_ref().map_or(0, |c| c.1.len());
    assert!(frames >= 10, "{frames} cam1 frames");
    ds.seg = None;
    write_dataset(&root, &ds).unwrap();
    let _ = std::fs::remove_dir_all(root.join("mav0/seg0"));
    let back = read_dataset(&root).unwrap();
    assert!(back.seg.is_none() && back.cam1.is_some());

    let r = replay_with(&back, &root, false, ReplayOptions::default()).unwrap();
    let s = surfaces(&r.report);
    assert_eq!(s.len(), frames, "one map per cam1 frame: {s:?}");
    let used = s.iter().filter(|(o, _)| o == "used").count();
    assert!(used * 2 > frames, "most maps used: {s:?}");
    assert!(
        s.iter().any(|(_, k)| k != "none"),
        "the maps give a floor: {s:?}"
    );

    // Cut the link: no cam1, no maps, no surface model.
    let mut none = back.clone();
    none.cam1 = None;
    let r = replay_with(&none, &root, false, ReplayOptions::default()).unwrap();
    assert!(surfaces(&r.report).is_empty());
    let _ = std::fs::remove_dir_all(&root);
}
