//! `report.json` names every stream of the registry (`vslam_core::Stream`):
//! checked on the determinism reference, which the replay writes.

use std::collections::BTreeSet;
use traction::vslam_core::Stream;

#[test]
fn the_report_lists_every_stream_by_name() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/reference/short_seed1/replay/report.json"
    );
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("the determinism reference {path}: {e}"));
    let report: serde_json::Value = serde_json::from_str(&text).unwrap();
    let keys: BTreeSet<&str> = report["counts"]
        .as_object()
        .expect("a `counts` object")
        .keys()
        .map(String::as_str)
        .collect();
    let names: BTreeSet<&str> = Stream::ALL.iter().map(|s| s.name()).collect();
    assert_eq!(keys, names);
    // Each entry is a full tally.
    for s in Stream::ALL {
        let c = &report["counts"][s.name()];
        for field in ["seen", "fused", "gated", "rejected"] {
            assert!(!c[field].is_null(), "{s}: no `{field}`");
        }
    }
}
