//! `errors.svg`: planar position error and yaw error over time of each
//! trajectory against the truth (interpolated at the estimate's time
//! stamps, no alignment, [`super::track`]), on one time axis. The position
//! panel's scale is set on the EKF and the camera path, and on the wheels
//! alone when their largest error is at most [`WHEELS_FRAMED_UP_TO`] times
//! the larger of those two; the yaw panel's likewise. A trace beyond the
//! scale is clipped at the panel's edge, marked where it leaves, with its
//! largest error in the legend. The
//! markers of the top view are here over time: slip, stuck and lift
//! episodes as bands, cable and strip crossings as lines, the estimator's
//! events along the top; and the windows of the faults `simulate --faults`
//! or `--chaos` injected, as dark ticks along the position panel's foot.

use super::axes::{Frame, Range, nice_step, points};
use super::markers::{self, LEGEND_LINE, Mark, SLIP_COLOUR, Swatch, legend_row};
use super::track::{self, ErrorSample};
use super::{
    EKF_COLOUR, EKF_WIDTH, PlotInputs, VSLAM_COLOUR, VSLAM_WIDTH, WHEEL_COLOUR, WHEEL_WIDTH,
    estimator_events,
};
use std::fmt::Write as _;

const LEFT: f64 = 70.0;
const WIDTH: f64 = 800.0;
const PANEL_H: f64 = 220.0;
const TOP: f64 = 50.0;
const GAP: f64 = 60.0;
const LEGEND_X: f64 = 900.0;
const PAGE_W: f64 = 1200.0;
/// Points drawn per trace at most (evenly thinned beyond).
const MAX_POINTS: usize = 3000;

/// Colour of an injected fault's window along the position panel's foot.
pub const FAULT_COLOUR: &str = "#37474f";

/// `(start, end)` seconds of every fault `simulate --faults` or `--chaos`
/// injected (`report.json` `faults.faults`), a count fault at least 0.1 s.
fn injected_faults(report: &serde_json::Value) -> Vec<(f64, f64)> {
    report["faults"]["faults"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|f| {
            let a = f["start_s"].as_f64()?;
            let b = f["window_end_s"].as_f64()?;
            (a.is_finite() && b.is_finite()).then_some((a, b.max(a + 0.1)))
        })
        .collect()
}

/// The injected faults as dark ticks along the foot of `panel`, inside it.
fn injected_faults_svg(s: &mut String, panel: &Frame, faults: &[(f64, f64)]) {
    if faults.is_empty() {
        return;
    }
    let _ = writeln!(s, r#"<g id="injected-faults">"#);
    for (a, b) in faults {
        let (x0, x1) = (panel.px(*a), panel.px(*b));
        if x1 < panel.left || x0 > panel.left + panel.width {
            continue;
        }
        let x0 = x0.max(panel.left);
        let _ = writeln!(
            s,
            r#"<rect x="{x0:.1}" y="{:.1}" width="{:.1}" height="7" fill="{FAULT_COLOUR}"/>"#,
            panel.top + panel.height - 8.0,
            (x1.min(panel.left + panel.width) - x0).max(2.0)
        );
    }
    let _ = writeln!(s, "</g>");
}

/// Colour of a stuck episode's band.
const STUCK_COLOUR: &str = "#b71c1c";
/// Colour of a lift episode's band.
const LIFT_COLOUR: &str = "#6a1b9a";

/// The wheels alone set the scale while their largest error is at most
/// this many times the larger of the EKF's and the camera path's.
pub const WHEELS_FRAMED_UP_TO: f64 = 3.0;

struct Trace {
    key: &'static str,
    label: &'static str,
    colour: &'static str,
    width: f64,
    errors: Vec<ErrorSample>,
}

fn thin(v: &[ErrorSample]) -> impl Iterator<Item = &ErrorSample> {
    let k = v.len().div_ceil(MAX_POINTS).max(1);
    v.iter().step_by(k)
}

/// Renders `errors.svg` (a short note when the log has no truth).
pub fn errors_svg(i: &PlotInputs<'_>) -> String {
    let truth = i.truth.map(track::from_truth).unwrap_or_default();
    if truth.is_empty() {
        return String::from(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="600" height="60" viewBox="0 0 600 60" font-family="DejaVu Sans, Arial, sans-serif" font-size="14"><rect width="100%" height="100%" fill="white"/><text x="10" y="35">No ground truth in this log: no errors to plot.</text></svg>
"#,
        );
    }
    let trace = |key, label, colour, width, v: &[_]| Trace {
        key,
        label,
        colour,
        width,
        errors: track::errors(&track::from_tum(v), &truth),
    };
    let traces = [
        trace(
            "wheel_only",
            "wheel only",
            WHEEL_COLOUR,
            WHEEL_WIDTH,
            i.wheel_only,
        ),
        trace(
            "vslam",
            "VSLAM (metric scale)",
            VSLAM_COLOUR,
            VSLAM_WIDTH,
            i.vslam,
        ),
        trace("ekf", "EKF", EKF_COLOUR, EKF_WIDTH, i.ekf),
    ];
    let largest =
        |t: &Trace, f: fn(&ErrorSample) -> f64| t.errors.iter().map(f).fold(0.0f64, f64::max);
    // The estimates always; the wheels alone when they stay comparable.
    let framing_for = |f: fn(&ErrorSample) -> f64| -> Vec<&Trace> {
        let [wheels, estimates @ ..] = &traces;
        let mut v: Vec<&Trace> = estimates.iter().filter(|t| !t.errors.is_empty()).collect();
        let top = v.iter().map(|t| largest(t, f)).fold(0.0f64, f64::max);
        if v.is_empty() || largest(wheels, f) <= WHEELS_FRAMED_UP_TO * top {
            v.push(wheels);
        }
        v
    };
    let framing = framing_for(|e| e.position);
    let framing_yaw = framing_for(|e| e.yaw_deg.abs());
    let t_range = Range::of(truth.iter().map(|p| p.t))
        .unwrap_or(Range { lo: 0.0, hi: 1.0 })
        .at_least(1.0);
    let pos_max = framing
        .iter()
        .flat_map(|t| t.errors.iter().map(|e| e.position))
        .fold(0.0f64, f64::max);
    let pos = Range {
        lo: 0.0,
        hi: (1.1 * pos_max).max(0.05),
    };
    let yaw_max = framing_yaw
        .iter()
        .flat_map(|t| t.errors.iter().map(|e| e.yaw_deg.abs()))
        .fold(0.0f64, f64::max);
    let yaw = Range {
        lo: -(1.1 * yaw_max).max(1.0),
        hi: (1.1 * yaw_max).max(1.0),
    };
    let top_panel = Frame {
        left: LEFT,
        top: TOP,
        width: WIDTH,
        height: PANEL_H,
        x: t_range,
        y: pos,
    };
    let bottom_panel = Frame {
        top: TOP + PANEL_H + GAP,
        y: yaw,
        ..top_panel
    };
    let t_step = nice_step(t_range.span(), 12.0);

    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{PAGE_W:.0}" height="HEIGHT" viewBox="0 0 {PAGE_W:.0} HEIGHT" font-family="DejaVu Sans, Arial, sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{LEFT:.0}" y="28" font-size="17">traction: error against the truth over time</text>"#
    );
    let episodes = i
        .scene
        .map(|sc| {
            sc.episodes
                .iter()
                .map(|e| {
                    (
                        e.kind.clone(),
                        e.start_ns as f64 * 1e-9,
                        e.end_ns as f64 * 1e-9,
                    )
                })
                .collect::<Vec<_>>()
        })
        .unwrap_or_default();
    let crossings = i
        .scene
        .map(|sc| markers::crossings(sc, &truth))
        .unwrap_or_default();
    let events = markers::events(&estimator_events(i.report), &truth);
    let faults = injected_faults(i.report);

    let mut exits: Vec<(String, &'static str, f64, f64)> = Vec::new();
    for (n, (panel, id, title)) in [
        (&top_panel, "pos", "planar position error [m]"),
        (&bottom_panel, "yaw", "yaw error [deg]"),
    ]
    .into_iter()
    .enumerate()
    {
        panel.area_svg(&mut s, id);
        let _ = writeln!(s, r#"<g clip-path="url(#{id})">"#);
        for (kind, a, b) in &episodes {
            let colour = match kind.as_str() {
                "slip" => SLIP_COLOUR,
                "stuck" => STUCK_COLOUR,
                _ => LIFT_COLOUR,
            };
            let (x0, x1) = (panel.px(*a), panel.px(*b));
            let _ = writeln!(
                s,
                r#"<rect x="{x0:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="{colour}" fill-opacity="0.16"/>"#,
                panel.top,
                (x1 - x0).max(1.5),
                panel.height
            );
        }
        let _ = writeln!(s, "</g>");
        panel.axes_svg(
            &mut s,
            t_step,
            nice_step(panel.y.span(), 6.0),
            "time [s]",
            title,
        );
        if n == 1 {
            let _ = writeln!(
                s,
                r##"<line x1="{LEFT:.1}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="#999"/>"##,
                panel.py(0.0),
                LEFT + WIDTH
            );
        }
        let _ = writeln!(s, r#"<g clip-path="url(#{id})">"#);
        for c in &crossings {
            let x = panel.px(c.t);
            let (colour, dash) = if c.mark == Mark::Cable {
                ("#3b2f2f", "")
            } else {
                ("#a0522d", r#" stroke-dasharray="6 4""#)
            };
            let _ = writeln!(
                s,
                r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}" stroke="{colour}" stroke-width="1.5"{dash}/>"#,
                panel.top,
                panel.top + panel.height
            );
        }
        for t in &traces {
            let value = |e: &ErrorSample| if n == 0 { e.position } else { e.yaw_deg };
            let _ = writeln!(
                s,
                r#"<polyline id="{}-{id}" points="{}" fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round"/>"#,
                t.key,
                points(panel, thin(&t.errors).map(|e| (e.t, value(e)))),
                t.colour,
                t.width
            );
            if let Some(e) = t.errors.iter().find(|e| !panel.y.contains(value(e))) {
                let edge = if value(e) > panel.y.hi {
                    panel.y.hi
                } else {
                    panel.y.lo
                };
                let max = t.errors.iter().map(|e| value(e).abs()).fold(0.0, f64::max);
                exits.push((
                    format!(
                        "{}: {} off scale from {:.1} s (largest {max:.2}{})",
                        t.label,
                        if n == 0 { "position" } else { "yaw" },
                        e.t,
                        if n == 0 { " m" } else { " deg" }
                    ),
                    t.colour,
                    panel.px(e.t),
                    panel.py(edge),
                ));
            }
        }
        let _ = writeln!(s, "</g>");
        if n == 0 {
            for m in &events {
                m.mark.svg(&mut s, panel.px(m.t), panel.top - 9.0);
            }
            injected_faults_svg(&mut s, panel, &faults);
        }
    }
    for (_, c, x, y) in &exits {
        Mark::Exit(c).svg(&mut s, *x, *y);
    }

    // Legend.
    let mut legend_y = TOP + 10.0;
    let mut row = |s: &mut String, swatch: Swatch<'_>, text: &str| {
        let lines = legend_row(s, LEGEND_X, legend_y, swatch, text);
        legend_y += 20.0 + LEGEND_LINE * (lines - 1) as f64;
    };
    for t in traces.iter().rev().filter(|t| !t.errors.is_empty()) {
        let ate = i.report["errors"][t.key]["ate_rmse_m"]
            .as_f64()
            .map(|a| format!(" (ATE {a:.3} m)"))
            .unwrap_or_default();
        row(
            &mut s,
            Swatch::Line {
                colour: t.colour,
                width: t.width.max(2.5),
            },
            &format!("{}{ate}", t.label),
        );
    }
    for (text, c, _, _) in &exits {
        row(&mut s, Swatch::Mark(Mark::Exit(c)), text);
    }
    let mut kinds: Vec<&str> = episodes.iter().map(|e| e.0.as_str()).collect();
    kinds.sort_unstable();
    kinds.dedup();
    for k in kinds {
        let colour = match k {
            "slip" => SLIP_COLOUR,
            "stuck" => STUCK_COLOUR,
            _ => LIFT_COLOUR,
        };
        row(
            &mut s,
            Swatch::Fill(colour),
            &format!("{k} episode (simulated)"),
        );
    }
    for (mark, dash) in [(Mark::Cable, ""), (Mark::Strip, "dashed")] {
        if crossings.iter().any(|c| c.mark == mark) {
            let name = if dash.is_empty() {
                "crossing the cable"
            } else {
                "crossing a threshold strip"
            };
            row(&mut s, Swatch::Mark(mark), name);
        }
    }
    for kind in [
        Mark::SuspectedObstacle,
        Mark::ThresholdStrip,
        Mark::SurfaceNoise,
    ] {
        let n = events.iter().filter(|m| m.mark == kind).count();
        if n > 0 {
            row(
                &mut s,
                Swatch::Mark(kind),
                &format!("{} ({n})", kind.name()),
            );
        }
    }
    if !faults.is_empty() {
        row(
            &mut s,
            Swatch::Fill(FAULT_COLOUR),
            &format!("injected fault window ({})", faults.len()),
        );
    }
    let height = (bottom_panel.top + PANEL_H + 50.0).max(legend_y + 20.0);
    s.push_str("</svg>\n");
    s.replace("HEIGHT", &format!("{height:.0}"))
}
