//! The HTML tables of `report.html`, each from its section of
//! `report.json`: the trajectory errors, the per-aid counts, the scale
//! decisions by source, the estimator's events, the surface timeline, the
//! faults and the filter's final state. Every text is escaped; a missing or
//! non-finite number shows as a dash.

use super::html::escape;
use super::scale_chart::{SOURCE_ORDER, decision_source, finite, source_colour};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;

/// Shown for a missing or non-finite number.
pub const DASH: &str = "\u{2014}";

/// One cell: its HTML (already escaped) and whether it is a number
/// (right-aligned).
pub struct Cell {
    html: String,
    num: bool,
}

/// A text cell, escaped.
pub fn text(s: &str) -> Cell {
    Cell {
        html: escape(s),
        num: false,
    }
}

/// A number cell with `d` decimals (a dash when `v` is not a finite number).
pub fn num(v: &Value, d: usize) -> Cell {
    Cell {
        html: fixed(v, d),
        num: true,
    }
}

/// A count cell (a dash when `v` is not a count).
pub fn count(v: &Value) -> Cell {
    Cell {
        html: v.as_u64().map_or(DASH.to_string(), |n| n.to_string()),
        num: true,
    }
}

/// `v` with `d` decimals, a dash when it is not a finite number.
pub fn fixed(v: &Value, d: usize) -> String {
    finite(v).map_or(DASH.to_string(), |x| format!("{x:.d$}"))
}

/// A coloured square followed by `label`, for a legend-like first column.
fn swatch(colour: &str, label: &str) -> Cell {
    Cell {
        html: format!(
            r#"<span class="sw" style="background:{}"></span>{}"#,
            escape(colour),
            escape(label)
        ),
        num: false,
    }
}

/// A table with a caption, a header row and body rows; rows whose flag is
/// set get `class="bad"`.
pub fn table(caption: &str, head: &[&str], rows: &[(Vec<Cell>, bool)]) -> String {
    let mut s = String::from("<table>\n");
    let _ = writeln!(s, "<caption>{}</caption>", escape(caption));
    s.push_str("<thead><tr>");
    for h in head {
        let _ = write!(s, "<th>{}</th>", escape(h));
    }
    s.push_str("</tr></thead>\n<tbody>\n");
    for (row, bad) in rows {
        s.push_str(if *bad { "<tr class=\"bad\">" } else { "<tr>" });
        for c in row {
            if c.num {
                let _ = write!(s, "<td class=\"n\">{}</td>", c.html);
            } else {
                let _ = write!(s, "<td>{}</td>", c.html);
            }
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</tbody>\n</table>\n");
    s
}

/// A paragraph with a note.
pub fn note(s: &str) -> String {
    format!("<p class=\"note\">{}</p>\n", escape(s))
}

/// Colour of a trajectory by its name in `errors`.
fn trajectory_colour(name: &str) -> &'static str {
    match name {
        "ekf" => super::EKF_COLOUR,
        "vslam" => super::VSLAM_COLOUR,
        "wheel_only" => super::WHEEL_COLOUR,
        _ => super::TRUTH_COLOUR,
    }
}

/// The error table from `report.json` `errors`: one row per trajectory,
/// and a note that says how the figures are aligned.
pub fn errors_table(errors: &Value) -> String {
    let Some(map) = errors.as_object().filter(|m| !m.is_empty()) else {
        return note("no ground truth in this log");
    };
    let rows: Vec<(Vec<Cell>, bool)> = map
        .iter()
        .map(|(name, e)| {
            (
                vec![
                    swatch(trajectory_colour(name), name),
                    num(&e["ate_rmse_m"], 3),
                    num(&e["ate_se2_rmse_m"], 3),
                    num(&e["final_error_m"], 3),
                    num(&e["final_error_pct_of_path"], 2),
                    num(&e["max_height_error_m"], 3),
                    num(&e["yaw_rmse_deg"], 2),
                    num(&e["path_length_m"], 2),
                ],
                false,
            )
        })
        .collect();
    table(
        "errors against the ground truth",
        &[
            "trajectory",
            "ATE first pose [m]",
            "ATE SE(2) [m]",
            "final error [m]",
            "final / path [%]",
            "height max [m]",
            "yaw RMSE [deg]",
            "path length [m]",
        ],
        &rows,
    ) + &note(crate::metrics::ALIGNMENT)
}

/// A counts table (`report.json` `counts` or `filter_counts`, `what` names
/// its first column): per stream or aid seen, fused, gated and rejected by
/// reason; those that saw nothing are named in a note under it.
pub fn counts_table(caption: &str, what: &str, counts: &Value) -> String {
    let Some(map) = counts.as_object() else {
        return note(&format!("{caption}: not in the report"));
    };
    let (present, absent): (Vec<_>, Vec<_>) = map
        .iter()
        .partition(|(_, c)| c["seen"].as_u64().unwrap_or(0) > 0);
    let reasons: BTreeSet<&str> = present
        .iter()
        .flat_map(|(_, c)| c["rejected"].as_object().into_iter().flatten())
        .map(|(r, _)| r.as_str())
        .collect();
    let head_owned: Vec<String> = [what, "seen", "fused", "gated"]
        .iter()
        .map(|h| h.to_string())
        .chain(reasons.iter().map(|r| format!("rejected: {r}")))
        .collect();
    let head: Vec<&str> = head_owned.iter().map(String::as_str).collect();
    let rows: Vec<(Vec<Cell>, bool)> = present
        .iter()
        .map(|(name, c)| {
            let mut row = vec![
                text(name),
                count(&c["seen"]),
                count(&c["fused"]),
                count(&c["gated"]),
            ];
            for r in &reasons {
                let n = c["rejected"][*r].as_u64().unwrap_or(0);
                row.push(count(&Value::from(n)));
            }
            (row, false)
        })
        .collect();
    let mut s = if rows.is_empty() {
        note(&format!("{caption}: no samples"))
    } else {
        table(caption, &head, &rows)
    };
    if !absent.is_empty() {
        let names: Vec<&str> = absent.iter().map(|(n, _)| n.as_str()).collect();
        s += &note(&format!("not in this log: {}", names.join(", ")));
    }
    s
}

/// Scale decisions by source (`report.json` `frames`): frame pairs, share,
/// pairs with slip exceeded, the median scale, and why there was no scale.
pub fn decisions_table(frames: &[Value]) -> String {
    if frames.is_empty() {
        return note("no camera frame pairs in this log");
    }
    #[derive(Default)]
    struct Group {
        pairs: u64,
        slip: u64,
        scales: Vec<f64>,
        why: BTreeMap<String, u64>,
    }
    let mut groups: BTreeMap<Option<&str>, Group> = BTreeMap::new();
    for f in frames {
        let src = decision_source(f);
        let g = groups.entry(src).or_default();
        g.pairs += 1;
        if f["slip_exceeded"].as_bool() == Some(true) {
            g.slip += 1;
        }
        if let Some(v) = finite(&f["scale"]).filter(|_| src.is_some()) {
            g.scales.push(v);
        }
        if src.is_none() {
            let why = f["no_scale"].as_str().unwrap_or("unknown");
            *g.why.entry(why.to_string()).or_default() += 1;
        }
    }
    let mut order: Vec<Option<&str>> = SOURCE_ORDER
        .iter()
        .map(|s| Some(*s))
        .filter(|k| groups.contains_key(k))
        .collect();
    let others: Vec<Option<&str>> = groups
        .keys()
        .copied()
        .filter(|k| k.is_some() && !order.contains(k))
        .collect();
    order.extend(others);
    if groups.contains_key(&None) {
        order.push(None);
    }
    let total = frames.len() as f64;
    let rows: Vec<(Vec<Cell>, bool)> = order
        .iter()
        .map(|k| {
            let g = &groups[k];
            let mut sorted = g.scales.clone();
            sorted.sort_by(f64::total_cmp);
            let median = if sorted.is_empty() {
                Value::Null
            } else {
                Value::from(sorted[sorted.len() / 2])
            };
            let why: Vec<String> = g.why.iter().map(|(w, n)| format!("{w} {n}")).collect();
            (
                vec![
                    swatch(source_colour(*k), k.unwrap_or("no scale")),
                    count(&Value::from(g.pairs)),
                    num(&Value::from(100.0 * g.pairs as f64 / total), 1),
                    count(&Value::from(g.slip)),
                    num(&median, 3),
                    text(&why.join(", ")),
                ],
                false,
            )
        })
        .collect();
    table(
        &format!(
            "scale decisions by source over {} frame pairs",
            frames.len()
        ),
        &[
            "source",
            "frame pairs",
            "share [%]",
            "slip exceeded",
            "median scale",
            "no scale because",
        ],
        &rows,
    )
}

/// Seconds of `t` (ns) after `t0` (ns), three decimals.
fn seconds(t: &Value, t0: u64) -> Cell {
    match t.as_u64() {
        Some(t) => num(&Value::from(t.saturating_sub(t0) as f64 * 1e-9), 3),
        None => text(DASH),
    }
}

fn str_or_dash(v: &Value) -> Cell {
    text(v.as_str().unwrap_or(DASH))
}

/// The estimator's events (`report.json` `events`), time from `t0` (ns).
pub fn events_table(events: &Value, t0: u64) -> String {
    let events = events.as_array().map(Vec::as_slice).unwrap_or(&[]);
    if events.is_empty() {
        return note("the estimator reported no events");
    }
    let rows: Vec<(Vec<Cell>, bool)> = events
        .iter()
        .map(|e| {
            (
                vec![
                    seconds(&e["t"], t0),
                    str_or_dash(&e["kind"]),
                    num(&e["magnitude"], 2),
                    num(&e["explained"], 2),
                    str_or_dash(&e["surface"]),
                ],
                false,
            )
        })
        .collect();
    table(
        &format!("events reported by the estimator ({})", events.len()),
        &["t [s]", "kind", "magnitude", "explained", "surface"],
        &rows,
    )
}

/// The surface timeline (`report.json` `surface_timeline`) as runs of the
/// same surface and outcome: from, to, samples, mean grip.
pub fn surface_table(timeline: &Value, t0: u64) -> String {
    let items = timeline.as_array().map(Vec::as_slice).unwrap_or(&[]);
    if items.is_empty() {
        return note("no surface classifications in this log");
    }
    struct Run<'a> {
        from: &'a Value,
        to: &'a Value,
        surface: &'a Value,
        outcome: &'a Value,
        n: u64,
        grip: f64,
        grips: u64,
    }
    let mut runs: Vec<Run<'_>> = Vec::new();
    for it in items {
        let same = runs
            .last()
            .is_some_and(|r| *r.surface == it["surface"] && *r.outcome == it["outcome"]);
        if !same {
            runs.push(Run {
                from: &it["t"],
                to: &it["t"],
                surface: &it["surface"],
                outcome: &it["outcome"],
                n: 0,
                grip: 0.0,
                grips: 0,
            });
        }
        let r = runs.last_mut().expect("pushed above");
        r.to = &it["t"];
        r.n += 1;
        if let Some(g) = finite(&it["grip"]) {
            r.grip += g;
            r.grips += 1;
        }
    }
    let rows: Vec<(Vec<Cell>, bool)> = runs
        .iter()
        .map(|r| {
            let grip = if r.grips > 0 {
                Value::from(r.grip / r.grips as f64)
            } else {
                Value::Null
            };
            (
                vec![
                    seconds(r.from, t0),
                    seconds(r.to, t0),
                    str_or_dash(r.surface),
                    str_or_dash(r.outcome),
                    count(&Value::from(r.n)),
                    num(&grip, 2),
                ],
                false,
            )
        })
        .collect();
    table(
        "floor surface as classified (runs of equal classifications)",
        &[
            "from [s]",
            "to [s]",
            "surface",
            "outcome",
            "classifications",
            "mean grip",
        ],
        &rows,
    )
}

/// The `faults` section (`simulate --faults`): one row per fault, rows
/// where not every spoiled sample met the expectation marked; the plan and
/// the IMU health check in a note.
pub fn faults_table(faults: &Value) -> String {
    let list = faults["faults"]
        .as_array()
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let rows: Vec<(Vec<Cell>, bool)> = list
        .iter()
        .map(|f| {
            let observed: Vec<String> = f["observed"]
                .as_object()
                .into_iter()
                .flatten()
                .map(|(k, v)| format!("{k} {v}"))
                .collect();
            let bad = f["as_expected"] != f["injected"];
            (
                vec![
                    str_or_dash(&f["fault"]),
                    str_or_dash(&f["stream"]),
                    str_or_dash(&f["stage"]),
                    num(&f["start_s"], 3),
                    num(&f["window_end_s"], 3),
                    count(&f["injected"]),
                    count(&f["dropped"]),
                    str_or_dash(&f["expected"]),
                    count(&f["as_expected"]),
                    text(&observed.join(", ")),
                ],
                bad,
            )
        })
        .collect();
    let mut s = table(
        "injected faults and what became of them",
        &[
            "fault",
            "stream",
            "stage",
            "from [s]",
            "to [s]",
            "spoiled",
            "dropped",
            "expected",
            "as expected",
            "observed",
        ],
        &rows,
    );
    if let Some(plan) = faults["plan"].as_str() {
        s += &note(&format!("plan: {plan}"));
    }
    let h = &faults["health"];
    if h.is_object() {
        s += &note(&format!(
            "IMU steps checked {}, non-finite steps {}, not positive definite {} (the whole matrix, pose clone included: {})",
            count(&h["imu_steps_checked"]).html,
            count(&h["non_finite_steps"]).html,
            count(&h["not_spd_steps"]).html,
            count(&h["with_clone_not_spd_steps"]).html
        ));
    }
    s
}

fn list(v: &Value, d: usize) -> String {
    match v.as_array() {
        Some(a) => a.iter().map(|x| fixed(x, d)).collect::<Vec<_>>().join(", "),
        None => fixed(v, d),
    }
}

/// The filter's state at the end of the run (`report.json` `final`).
pub fn final_table(fin: &Value) -> String {
    if !fin.is_object() {
        return note("no final state in the report");
    }
    let lock = &fin["wheel_lockout"];
    let rows: Vec<(&str, String)> = vec![
        ("running scale", fixed(&fin["running_scale"], 4)),
        ("wheel radii [m]", list(&fin["wheel_radii"], 5)),
        ("wheel radius std [m]", list(&fin["wheel_radius_std"], 6)),
        ("gyro bias [rad/s]", list(&fin["gyro_bias"], 5)),
        ("accel bias [m/s\u{b2}]", list(&fin["accel_bias"], 4)),
        (
            "flow velocity resets",
            count(&fin["flow_velocity_resets"]).html,
        ),
        (
            "wheel lockout resets to flow / to wheels",
            format!(
                "{} / {}",
                count(&lock["resets_to_flow"]).html,
                count(&lock["resets_to_wheels"]).html
            ),
        ),
        ("IMU gaps bridged", count(&fin["imu_gaps_bridged"]).html),
    ];
    let rows: Vec<(Vec<Cell>, bool)> = rows
        .into_iter()
        .map(|(k, v)| {
            (
                vec![
                    text(k),
                    Cell {
                        html: escape(&v),
                        num: true,
                    },
                ],
                false,
            )
        })
        .collect();
    table("the filter at the end of the run", &["", "value"], &rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn errors_table_has_one_row_per_trajectory_and_dashes_for_missing_numbers() {
        let t = errors_table(&json!({
            "ekf": {"ate_rmse_m": 0.16158, "ate_se2_rmse_m": 0.0712, "final_error_m": 0.1247,
                    "final_error_pct_of_path": 0.787, "max_height_error_m": 0.1403,
                    "yaw_rmse_deg": 0.254, "path_length_m": 15.847},
            "wheel_only": {"ate_rmse_m": null, "final_error_m": 3.6466,
                           "final_error_pct_of_path": 23.0, "path_length_m": 15.847},
        }));
        assert_eq!(t.matches("<tr>").count(), 3);
        assert!(t.contains("ekf</td><td class=\"n\">0.162</td><td class=\"n\">0.071</td><td class=\"n\">0.125</td><td class=\"n\">0.79</td><td class=\"n\">0.140</td><td class=\"n\">0.25</td><td class=\"n\">15.85</td>"), "{t}");
        assert!(t.contains("first-pose"), "{t}");
        assert!(t.contains(&format!("wheel_only</td><td class=\"n\">{DASH}</td>")));
        assert!(t.contains(super::super::EKF_COLOUR));
        assert_eq!(
            errors_table(&Value::Null),
            "<p class=\"note\">no ground truth in this log</p>\n"
        );
        assert_eq!(errors_table(&json!({})), errors_table(&Value::Null));
    }

    #[test]
    fn counts_table_has_a_column_per_rejection_reason() {
        let t = counts_table(
            "samples",
            "stream",
            &json!({
                "flow": {"seen": 6000, "fused": 5764, "gated": 216,
                         "rejected": {"gated": 216, "not_ready": 20}},
                "imu": {"seen": 15001, "fused": 14951, "gated": 0,
                        "rejected": {"non_finite": 3}},
                "flow_frame": {"seen": 0, "fused": 0, "gated": 0, "rejected": {}},
            }),
        );
        assert!(
            t.contains(
                "<th>rejected: gated</th><th>rejected: non_finite</th><th>rejected: not_ready</th>"
            ),
            "{t}"
        );
        let n = |v: u64| format!("<td class=\"n\">{v}</td>");
        let flow = ["6000", "5764", "216", "216", "0", "20"].map(|v| n(v.parse().unwrap()));
        assert!(
            t.contains(&format!("<td>flow</td>{}", flow.concat())),
            "{t}"
        );
        let imu = ["15001", "14951", "0", "0", "3", "0"].map(|v| n(v.parse().unwrap()));
        assert!(t.contains(&format!("<td>imu</td>{}", imu.concat())), "{t}");
        assert!(!t.contains("<td>flow_frame</td>"));
        assert!(t.contains("not in this log: flow_frame"));
    }

    #[test]
    fn decisions_table_groups_by_source_with_no_scale_last() {
        let f = |src: Option<&str>, scale: f64, slip: bool| {
            json!({"source": src, "scale": if src.is_some() { json!(scale) } else { Value::Null },
                   "slip_exceeded": slip,
                   "no_scale": if src.is_none() { json!("CameraUnreliable") } else { Value::Null }})
        };
        let frames = [
            f(None, 0.0, true),
            f(Some("fused"), 2.4, false),
            f(Some("wheel"), 2.0, true),
            f(Some("fused"), 2.6, false),
            f(Some("fused"), 2.5, false),
        ];
        let t = decisions_table(&frames);
        let wheel = t.find("wheel</td>").unwrap();
        let fused = t.find("fused</td>").unwrap();
        let none = t.find("no scale</td>").unwrap();
        assert!(wheel < fused && fused < none, "{t}");
        assert!(t.contains("fused</td><td class=\"n\">3</td><td class=\"n\">60.0</td><td class=\"n\">0</td><td class=\"n\">2.500</td><td></td>"), "{t}");
        assert!(t.contains(&format!("no scale</td><td class=\"n\">1</td><td class=\"n\">20.0</td><td class=\"n\">1</td><td class=\"n\">{DASH}</td><td>CameraUnreliable 1</td>")), "{t}");
        assert!(t.contains("over 5 frame pairs"));
        assert!(decisions_table(&[]).contains("no camera frame pairs"));
    }

    #[test]
    fn events_and_surfaces_count_time_from_the_start() {
        let t = events_table(
            &json!([{"t": 3_500_000_000u64, "kind": "ThresholdStrip", "magnitude": 6.45,
                     "explained": 2.0, "surface": null}]),
            1_000_000_000,
        );
        assert!(t.contains(&format!("<td class=\"n\">2.500</td><td>ThresholdStrip</td><td class=\"n\">6.45</td><td class=\"n\">2.00</td><td>{DASH}</td>")), "{t}");
        assert!(events_table(&json!([]), 0).contains("no events"));
        let s = surface_table(
            &json!([
                {"t": 0, "surface": "wood", "outcome": "used", "grip": 0.9},
                {"t": 500_000_000u64, "surface": "wood", "outcome": "used", "grip": 1.0},
                {"t": 1_000_000_000u64, "surface": "carpet", "outcome": "used", "grip": 0.7},
            ]),
            0,
        );
        assert_eq!(s.matches("<tr>").count(), 3, "{s}");
        assert!(s.contains("<td class=\"n\">0.000</td><td class=\"n\">0.500</td><td>wood</td><td>used</td><td class=\"n\">2</td><td class=\"n\">0.95</td>"), "{s}");
    }

    #[test]
    fn faults_table_marks_faults_not_met() {
        let t = faults_table(&json!({
            "plan": "imu-nan@2x3,wheel-stuck@4",
            "faults": [
                {"fault": "imu-nan@2x3", "injected": 3, "as_expected": 3, "observed": {"non_finite": 3}},
                {"fault": "wheel-stuck@4", "injected": 5, "as_expected": 4,
                 "observed": {"fused": 4, "missing": 1}},
            ],
            "health": {"imu_steps_checked": 100, "non_finite_steps": 0, "not_spd_steps": 0},
        }));
        assert_eq!(t.matches("<tr class=\"bad\">").count(), 1);
        assert!(t.contains("<tr class=\"bad\"><td>wheel-stuck@4</td>"));
        assert!(t.contains("<td>fused 4, missing 1</td>"));
        assert!(t.contains("plan: imu-nan@2x3,wheel-stuck@4"));
        assert!(t.contains("IMU steps checked 100"));
    }
}
