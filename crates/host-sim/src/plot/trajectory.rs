//! `trajectory.svg`: the top view. Framed on the truth and the estimates
//! that stay near it (within [`NEAR_M`] or [`NEAR_FRACTION`] of the truth's
//! extent, whichever is larger); a trajectory that runs farther is clipped
//! at the frame, marked where it leaves, and its final error given in the
//! legend. Equal scales on both axes with metre ticks; the truth drawn as a
//! wide band under the thinner estimates so it stays visible where they
//! follow it; start and ends marked. From the simulator ([`Scene`]): the
//! floors as a light background map, the cable and threshold strips as
//! lines, slip episodes highlighted along the truth, stuck and lift
//! episodes marked. The estimator's events are marked on the EKF's path.
//! Without a truth, the frame is set on the EKF and the estimates near it.

use super::axes::{Frame, Range, escape, nice_step, points};
use super::markers::{self, LEGEND_LINE, Mark, Moment, SLIP_COLOUR, Swatch, legend_row};
use super::scene::Scene;
use super::track::{self, Planar};
use super::{
    EKF_COLOUR, EKF_WIDTH, PlotInputs, TRUTH_COLOUR, TRUTH_WIDTH, VSLAM_COLOUR, VSLAM_WIDTH,
    WHEEL_COLOUR, WHEEL_WIDTH, estimator_events,
};
use std::fmt::Write as _;

/// An estimate stays in the frame when its largest error is at most this
/// (metres) ...
pub const NEAR_M: f64 = 1.0;
/// ... or this fraction of the truth's larger extent.
pub const NEAR_FRACTION: f64 = 0.15;

const LEFT: f64 = 70.0;
const TOP: f64 = 50.0;
const WIDTH: f64 = 800.0;
const LEGEND_X: f64 = 900.0;
const PAGE_W: f64 = 1200.0;

/// Light background colour of a floor surface.
pub fn floor_colour(surface: &str) -> &'static str {
    match surface {
        "wood" => "#f4e6cf",
        "carpet" => "#e8efd8",
        "tile" => "#dfeef6",
        "concrete" => "#e7e7e7",
        _ => "#f5f5f0",
    }
}

/// One estimate as drawn.
struct Drawn<'a> {
    key: &'static str,
    label: &'static str,
    colour: &'static str,
    width: f64,
    path: &'a [Planar],
    /// Inside the frame's framing set.
    near: bool,
}

fn bbox(path: &[Planar]) -> Option<(Range, Range)> {
    Some((
        Range::of(path.iter().map(|p| p.x))?,
        Range::of(path.iter().map(|p| p.y))?,
    ))
}

fn union(a: Option<(Range, Range)>, b: Option<(Range, Range)>) -> Option<(Range, Range)> {
    match (a, b) {
        (Some(a), Some(b)) => Some((a.0.union(b.0), a.1.union(b.1))),
        (a, None) => a,
        (None, b) => b,
    }
}

/// Where the segment from inside point `a` to outside point `b` crosses the
/// frame's edge (bisection on the data coordinates).
fn edge_crossing(f: &Frame, a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..30 {
        let m = 0.5 * (lo + hi);
        let p = (a.0 + m * (b.0 - a.0), a.1 + m * (b.1 - a.1));
        if f.contains(p.0, p.1) {
            lo = m;
        } else {
            hi = m;
        }
    }
    (a.0 + lo * (b.0 - a.0), a.1 + lo * (b.1 - a.1))
}

/// The first place and time `path` leaves the frame, if it does.
fn exit(f: &Frame, path: &[Planar]) -> Option<(f64, (f64, f64))> {
    path.windows(2).find_map(|w| {
        (f.contains(w[0].x, w[0].y) && !f.contains(w[1].x, w[1].y))
            .then(|| (w[1].t, edge_crossing(f, (w[0].x, w[0].y), (w[1].x, w[1].y))))
    })
}

/// Renders `trajectory.svg`.
pub fn trajectory_svg(i: &PlotInputs<'_>) -> String {
    let truth = i.truth.map(track::from_truth).unwrap_or_default();
    let (ekf, vslam, wheel) = (
        track::from_tum(i.ekf),
        track::from_tum(i.vslam),
        track::from_tum(i.wheel_only),
    );
    let reference: &[Planar] = if truth.is_empty() { &ekf } else { &truth };
    let extent = bbox(reference).map_or(0.0, |(x, y)| x.span().max(y.span()));
    let near_limit = NEAR_M.max(NEAR_FRACTION * extent);
    let near = |p: &[Planar]| {
        std::ptr::eq(p, reference)
            || track::max_error(p, reference).is_some_and(|e| e <= near_limit)
    };
    let mut drawn = [
        Drawn {
            key: "wheel_only",
            label: "wheel only",
            colour: WHEEL_COLOUR,
            width: WHEEL_WIDTH,
            path: &wheel,
            near: false,
        },
        Drawn {
            key: "vslam",
            label: "VSLAM (metric scale)",
            colour: VSLAM_COLOUR,
            width: VSLAM_WIDTH,
            path: &vslam,
            near: false,
        },
        Drawn {
            key: "ekf",
            label: "EKF",
            colour: EKF_COLOUR,
            width: EKF_WIDTH,
            path: &ekf,
            near: false,
        },
    ];
    for d in &mut drawn {
        d.near = near(d.path);
    }

    // The frame: the reference and the estimates near it.
    let framed = drawn
        .iter()
        .filter(|d| d.near)
        .fold(bbox(reference), |b, d| union(b, bbox(d.path)));
    let (xr, yr) = framed.unwrap_or((Range { lo: 0.0, hi: 1.0 }, Range { lo: 0.0, hi: 1.0 }));
    let pad = 0.3 + 0.03 * xr.span().max(yr.span());
    let frame = Frame::equal(LEFT, TOP, WIDTH, 260.0, 640.0, xr.pad(pad), yr.pad(pad));
    let step = nice_step(frame.x.span().max(frame.y.span()), 12.0).max(0.1);

    let scene = i.scene;
    let mut legend_y = TOP + 10.0;
    let mut s = String::new();
    let mut legend = String::new();
    let mut row = |legend: &mut String, swatch: Swatch<'_>, text: &str| {
        let lines = legend_row(legend, LEGEND_X, legend_y, swatch, text);
        legend_y += 20.0 + LEGEND_LINE * (lines - 1) as f64;
    };

    // Traces in the legend, with their errors.
    let errors = &i.report["errors"];
    if !truth.is_empty() {
        row(
            &mut legend,
            Swatch::Line {
                colour: TRUTH_COLOUR,
                width: TRUTH_WIDTH,
            },
            "truth",
        );
    }
    let mut exits = Vec::new();
    for d in drawn.iter().rev() {
        if d.path.is_empty() {
            continue;
        }
        let ate = errors[d.key]["ate_rmse_m"].as_f64();
        let mut text = match ate {
            Some(a) => format!("{} (ATE {a:.3} m)", d.label),
            None => d.label.to_string(),
        };
        if let Some((t, at)) = exit(&frame, d.path).filter(|_| !d.near) {
            exits.push((d.colour, at));
            let fin = errors[d.key]["final_error_m"].as_f64();
            text = match fin {
                Some(f) => format!(
                    "{}: off the frame from {t:.1} s, final error {f:.2} m",
                    d.label
                ),
                None => format!("{}: off the frame from {t:.1} s", d.label),
            };
        }
        row(
            &mut legend,
            Swatch::Line {
                colour: d.colour,
                width: d.width.max(2.5),
            },
            &text,
        );
    }

    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{PAGE_W:.0}" height="HEIGHT" viewBox="0 0 {PAGE_W:.0} HEIGHT" font-family="DejaVu Sans, Arial, sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let title = match scene {
        Some(sc) => format!("traction: top view, simulated `{}`", sc.scenario),
        None => "traction: top view".to_string(),
    };
    let _ = writeln!(
        s,
        r#"<text x="{LEFT:.0}" y="28" font-size="17">{}</text>"#,
        escape(&title)
    );
    frame.area_svg(&mut s, "frame");
    let _ = writeln!(s, r#"<g clip-path="url(#frame)">"#);

    // The world.
    if let Some(sc) = scene {
        floors(&mut s, &frame, sc);
        strips(&mut s, &frame, sc);
    }
    let _ = writeln!(s, "</g>");
    frame.axes_svg(&mut s, step, step, "x [m]", "y [m]");
    let _ = writeln!(s, r#"<g clip-path="url(#frame)">"#);
    if let Some(sc) = scene {
        for (a, b) in markers::slips(sc) {
            let seg = truth
                .iter()
                .filter(|p| p.t >= a && p.t <= b)
                .map(|p| (p.x, p.y));
            let _ = writeln!(
                s,
                r#"<polyline points="{}" fill="none" stroke="{SLIP_COLOUR}" stroke-width="16" stroke-opacity="0.5" stroke-linecap="round"/>"#,
                points(&frame, seg)
            );
        }
    }

    // The trajectories: truth under the others, far ones first, the EKF on top.
    if !truth.is_empty() {
        let _ = writeln!(
            s,
            r#"<polyline id="truth" points="{}" fill="none" stroke="{TRUTH_COLOUR}" stroke-width="{TRUTH_WIDTH}" stroke-linejoin="round"/>"#,
            points(&frame, truth.iter().map(|p| (p.x, p.y)))
        );
    }
    for d in drawn.iter().filter(|d| !d.path.is_empty()) {
        let _ = writeln!(
            s,
            r#"<polyline id="{}" points="{}" fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round"/>"#,
            d.key,
            points(&frame, d.path.iter().map(|p| (p.x, p.y))),
            d.colour,
            d.width
        );
    }

    // Markers.
    let mut moments: Vec<Moment> = Vec::new();
    if let Some(sc) = scene {
        moments.extend(markers::episode_starts(sc, &truth));
    }
    moments.extend(markers::events(&estimator_events(i.report), &ekf));
    for m in &moments {
        if let Some((x, y)) = m.at {
            m.mark.svg(&mut s, frame.px(x), frame.py(y));
        }
    }
    if let Some(p) = reference.first() {
        Mark::Start.svg(&mut s, frame.px(p.x), frame.py(p.y));
    }
    for d in drawn.iter().filter(|d| d.near) {
        if let Some(p) = d.path.last() {
            Mark::End(d.colour).svg(&mut s, frame.px(p.x), frame.py(p.y));
        }
    }
    if let Some(p) = truth.last() {
        Mark::End(TRUTH_COLOUR).svg(&mut s, frame.px(p.x), frame.py(p.y));
    }
    let _ = writeln!(s, "</g>");
    for (c, (x, y)) in &exits {
        Mark::Exit(c).svg(&mut s, frame.px(*x), frame.py(*y));
    }

    // The rest of the legend: marks, episodes, floors.
    row(&mut legend, Swatch::Mark(Mark::Start), Mark::Start.name());
    row(
        &mut legend,
        Swatch::Mark(Mark::End("#555")),
        "end (in the trace's colour)",
    );
    if !exits.is_empty() {
        row(
            &mut legend,
            Swatch::Mark(Mark::Exit("#555")),
            Mark::Exit("").name(),
        );
    }
    if let Some(sc) = scene {
        if !markers::slips(sc).is_empty() {
            row(
                &mut legend,
                Swatch::Line {
                    colour: SLIP_COLOUR,
                    width: 10.0,
                },
                "wheel slip episode (simulated)",
            );
        }
        let mut kinds: Vec<Mark> = sc
            .strips
            .iter()
            .map(|s| {
                if s.threshold {
                    Mark::Strip
                } else {
                    Mark::Cable
                }
            })
            .collect();
        kinds.dedup();
        kinds.sort_by_key(|m| m.name());
        kinds.dedup();
        for m in kinds {
            row(&mut legend, Swatch::Mark(m), m.name());
        }
    }
    for kind in [
        Mark::Stuck,
        Mark::Lifted,
        Mark::SuspectedObstacle,
        Mark::ThresholdStrip,
        Mark::SurfaceNoise,
    ] {
        let n = moments.iter().filter(|m| m.mark == kind).count();
        if n > 0 {
            row(
                &mut legend,
                Swatch::Mark(kind),
                &format!("{} ({n})", kind.name()),
            );
        }
    }
    if let Some(sc) = scene {
        let mut surfaces: Vec<&str> = sc.rooms.iter().map(|r| r.surface.as_str()).collect();
        surfaces.sort_unstable();
        surfaces.dedup();
        for f in surfaces {
            row(
                &mut legend,
                Swatch::Fill(floor_colour(f)),
                &format!("floor: {f}"),
            );
        }
    }
    s.push_str(&legend);
    let height = (frame.top + frame.height + 50.0).max(legend_y + 20.0);
    s.push_str("</svg>\n");
    s.replace("HEIGHT", &format!("{height:.0}"))
}

/// The rooms as light rectangles with their surface's name.
fn floors(s: &mut String, f: &Frame, sc: &Scene) {
    for r in &sc.rooms {
        let (x0, x1) = (f.px(r.min[0]), f.px(r.max[0]));
        let (y0, y1) = (f.py(r.max[1]), f.py(r.min[1]));
        let _ = writeln!(
            s,
            r#"<rect x="{x0:.1}" y="{y0:.1}" width="{:.1}" height="{:.1}" fill="{}"/>"#,
            x1 - x0,
            y1 - y0,
            floor_colour(&r.surface)
        );
        let lx = x0.max(f.left) + 6.0;
        let ly = y0.max(f.top) + 16.0;
        let _ = writeln!(
            s,
            r##"<text x="{lx:.1}" y="{ly:.1}" fill="#8a8a8a" font-style="italic">{}</text>"##,
            escape(&r.surface)
        );
    }
}

/// Threshold strips (dashed) and cables (solid) across the rooms.
fn strips(s: &mut String, f: &Frame, sc: &Scene) {
    let ys = Range::of(sc.rooms.iter().flat_map(|r| [r.min[1], r.max[1]])).unwrap_or(f.y);
    for st in &sc.strips {
        let x = f.px(st.at);
        let (colour, width, dash, name) = if st.threshold {
            ("#a0522d", 3.0, r#" stroke-dasharray="6 4""#, "strip")
        } else {
            ("#3b2f2f", 4.0, "", "cable")
        };
        let _ = writeln!(
            s,
            r#"<line x1="{x:.1}" y1="{:.1}" x2="{x:.1}" y2="{:.1}" stroke="{colour}" stroke-width="{width}" stroke-opacity="0.7"{dash}/><text x="{:.1}" y="{:.1}" fill="{colour}">{name}</text>"#,
            f.py(ys.hi),
            f.py(ys.lo),
            x + 4.0,
            f.py(ys.lo).min(f.top + f.height) - 6.0
        );
    }
}
