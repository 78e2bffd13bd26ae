//! The scale decisions over time as an SVG chart for `report.html`: one
//! point per camera frame pair at the scale it decided, coloured by the
//! source (wheel, flow, fused, camera), the scale the camera path applied as
//! a line, and two bands under the plot marking the pairs with no scale and
//! the pairs whose slip exceeded the limit. Time axis in seconds from `t0`.
//! Only finite values are drawn; a missing (`null`) value never becomes a
//! coordinate.

use super::html::escape;
use serde_json::Value;
use std::fmt::Write;

/// Colour of a decision with no scale.
pub const NO_SCALE_COLOUR: &str = "#aaaaaa";
/// Colour of the slip-exceeded marks.
pub const SLIP_COLOUR: &str = "#8c564b";
/// Colour of the applied-scale line.
pub const APPLIED_COLOUR: &str = "#222222";

/// The source of a decision (`frames[i].source`), `None` when it decided
/// no scale.
pub fn decision_source(frame: &Value) -> Option<&str> {
    frame["source"].as_str()
}

/// Colour of a decision by its source.
pub fn source_colour(source: Option<&str>) -> &'static str {
    match source {
        Some("wheel") => super::WHEEL_COLOUR,
        Some("flow") => "#2ca02c",
        Some("fused") => "#9467bd",
        Some("camera") => super::VSLAM_COLOUR,
        Some(_) => "#17becf",
        None => NO_SCALE_COLOUR,
    }
}

/// The sources in the order the legend and the tables list them.
pub const SOURCE_ORDER: [&str; 4] = ["wheel", "flow", "fused", "camera"];

/// A finite number of `v`, `None` for `null`, strings and the like.
pub fn finite(v: &Value) -> Option<f64> {
    v.as_f64().filter(|x| x.is_finite())
}

/// Round tick values in `[lo, hi]`, about `target` of them, and their step.
pub fn ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) || target == 0 {
        return (vec![lo], 1.0);
    }
    let raw = span / target as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    ((first..=last).map(|k| k as f64 * step).collect(), step)
}

/// Decimals that show a tick step of `step` exactly.
pub fn decimals(step: f64) -> usize {
    if step >= 1.0 || step <= 0.0 || !step.is_finite() {
        0
    } else {
        (-step.log10().floor()) as usize
    }
}

const W: f64 = 900.0;
const H: f64 = 370.0;
const LEFT: f64 = 92.0;
const RIGHT: f64 = 880.0;
const TOP: f64 = 56.0;
const BOTTOM: f64 = 250.0;
const SLIP_Y: f64 = 292.0;
const NONE_Y: f64 = 312.0;

/// A legend entry's mark.
enum Mark {
    Source,
    NoScale,
    Applied,
    Slip,
}

/// One frame pair as drawn.
struct Pair<'a> {
    t_s: f64,
    source: Option<&'a str>,
    scale: Option<f64>,
    applied: Option<f64>,
    slip: bool,
    why: Option<&'a str>,
}

fn pairs(frames: &[Value], t0_ns: u64) -> Vec<Pair<'_>> {
    frames
        .iter()
        .filter_map(|f| {
            let t = f["t"].as_u64()?;
            Some(Pair {
                t_s: t.saturating_sub(t0_ns) as f64 * 1e-9,
                source: decision_source(f),
                scale: finite(&f["scale"]).filter(|_| decision_source(f).is_some()),
                applied: finite(&f["applied_scale"]),
                slip: f["slip_exceeded"].as_bool() == Some(true),
                why: f["no_scale"].as_str(),
            })
        })
        .collect()
}

/// The chart of `frames` (`report.json` `frames`), time from `t0_ns`.
pub fn scale_chart_svg(frames: &[Value], t0_ns: u64) -> String {
    let pairs = pairs(frames, t0_ns);
    let t_end = pairs.iter().map(|p| p.t_s).fold(0.0, f64::max);
    let t_end = if t_end > 0.0 { t_end } else { 1.0 };
    let values: Vec<f64> = pairs
        .iter()
        .flat_map(|p| p.scale.into_iter().chain(p.applied))
        .collect();
    let (mut lo, mut hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
    if values.is_empty() {
        (lo, hi) = (0.0, 1.0);
    } else if hi - lo < 1e-9 * hi.abs().max(1.0) {
        let pad = (hi.abs() * 0.05).max(0.05);
        (lo, hi) = (lo - pad, hi + pad);
    } else {
        let pad = 0.05 * (hi - lo);
        (lo, hi) = (lo - pad, hi + pad);
    }
    let x = |t: f64| LEFT + (RIGHT - LEFT) * (t / t_end).clamp(0.0, 1.0);
    let y = |v: f64| BOTTOM - (BOTTOM - TOP) * ((v - lo) / (hi - lo)).clamp(0.0, 1.0);

    let mut s = String::new();
    let _ = writeln!(
        s,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">"##
    );
    let _ = writeln!(s, r##"<rect width="{W}" height="{H}" fill="white"/>"##);
    let _ = writeln!(
        s,
        r##"<text x="8" y="20" font-size="15">scale decisions per camera frame pair</text>"##
    );

    // Axes, grid and tick labels.
    let (yt, ystep) = ticks(lo, hi, 5);
    let yd = decimals(ystep);
    for v in yt {
        let py = y(v);
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{py:.1}" x2="{RIGHT}" y2="{py:.1}" stroke="#e6e6e6"/><text x="{:.1}" y="{:.1}" text-anchor="end">{v:.yd$}</text>"##,
            LEFT - 6.0,
            py + 4.0
        );
    }
    let (xt, xstep) = ticks(0.0, t_end, 10);
    let xd = decimals(xstep);
    for t in xt {
        let px = x(t);
        let _ = writeln!(
            s,
            r##"<line x1="{px:.1}" y1="{TOP}" x2="{px:.1}" y2="{BOTTOM}" stroke="#e6e6e6"/><line x1="{px:.1}" y1="{BOTTOM}" x2="{px:.1}" y2="{:.1}" stroke="#333"/><text x="{px:.1}" y="{:.1}" text-anchor="middle">{t:.xd$}</text>"##,
            BOTTOM + 5.0,
            BOTTOM + 18.0
        );
    }
    let _ = writeln!(
        s,
        r##"<rect x="{LEFT}" y="{TOP}" width="{:.1}" height="{:.1}" fill="none" stroke="#333"/>"##,
        RIGHT - LEFT,
        BOTTOM - TOP
    );
    let _ = writeln!(
        s,
        r##"<text x="{:.1}" y="{:.1}" text-anchor="middle">time [s]</text>"##,
        (LEFT + RIGHT) / 2.0,
        H - 12.0
    );
    let _ = writeln!(
        s,
        r##"<text transform="translate(30 {:.1}) rotate(-90)" text-anchor="middle">scale [m per camera unit]</text>"##,
        (TOP + BOTTOM) / 2.0
    );
    for (label, by) in [("slip exceeded", SLIP_Y), ("no scale", NONE_Y)] {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{by}" x2="{RIGHT}" y2="{by}" stroke="#e6e6e6"/><text x="{:.1}" y="{:.1}" text-anchor="end" font-size="11">{label}</text>"##,
            LEFT - 6.0,
            by + 4.0
        );
    }

    // The applied scale: a line, broken where the camera path had none.
    let mut run: Vec<(f64, f64)> = Vec::new();
    let mut lines: Vec<Vec<(f64, f64)>> = Vec::new();
    for p in &pairs {
        match p.applied {
            Some(v) => run.push((x(p.t_s), y(v))),
            None if !run.is_empty() => lines.push(std::mem::take(&mut run)),
            None => {}
        }
    }
    if !run.is_empty() {
        lines.push(run);
    }
    for l in lines {
        if let [(px, py)] = l[..] {
            let _ = writeln!(
                s,
                r##"<circle cx="{px:.1}" cy="{py:.1}" r="1.5" fill="{APPLIED_COLOUR}"/>"##
            );
        } else {
            let points: Vec<String> = l.iter().map(|(a, b)| format!("{a:.1},{b:.1}")).collect();
            let _ = writeln!(
                s,
                r##"<polyline points="{}" fill="none" stroke="{APPLIED_COLOUR}" stroke-width="1.2"/>"##,
                points.join(" ")
            );
        }
    }

    // The decisions.
    for p in &pairs {
        let px = x(p.t_s);
        match (p.source, p.scale) {
            (Some(src), Some(v)) => {
                let applied = p
                    .applied
                    .map(|a| format!(", applied {a:.3}"))
                    .unwrap_or_default();
                let _ = writeln!(
                    s,
                    r##"<circle cx="{px:.1}" cy="{:.1}" r="2.6" fill="{}"><title>{:.2} s: {} {v:.3}{applied}</title></circle>"##,
                    y(v),
                    source_colour(Some(src)),
                    p.t_s,
                    escape(src)
                );
            }
            _ => {
                let _ = writeln!(
                    s,
                    r##"<line x1="{px:.1}" y1="{:.1}" x2="{px:.1}" y2="{:.1}" stroke="{NO_SCALE_COLOUR}" stroke-width="2"><title>{:.2} s: no scale ({})</title></line>"##,
                    NONE_Y - 6.0,
                    NONE_Y + 6.0,
                    p.t_s,
                    escape(p.why.unwrap_or("no value"))
                );
            }
        }
        if p.slip {
            let _ = writeln!(
                s,
                r##"<path d="M{px:.1} {:.1}l-4 8h8z" fill="{SLIP_COLOUR}"><title>{:.2} s: slip exceeded</title></path>"##,
                SLIP_Y - 5.0,
                p.t_s
            );
        }
    }
    if pairs.is_empty() {
        let _ = writeln!(
            s,
            r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="#555">no camera frame pairs in this log</text>"##,
            (LEFT + RIGHT) / 2.0,
            (TOP + BOTTOM) / 2.0
        );
    }

    // Legend: the sources present, no scale, the applied line, slip.
    let mut sources: Vec<&str> = SOURCE_ORDER
        .iter()
        .copied()
        .filter(|k| pairs.iter().any(|p| p.source == Some(*k)))
        .collect();
    for p in &pairs {
        if let Some(src) = p.source.filter(|s| !sources.contains(s)) {
            sources.push(src);
        }
    }
    let mut items: Vec<(Mark, &str)> = sources.iter().map(|k| (Mark::Source, *k)).collect();
    items.push((Mark::NoScale, "no scale"));
    items.push((Mark::Applied, "applied scale"));
    items.push((Mark::Slip, "slip exceeded"));
    let mut lx = 300.0;
    for (mark, label) in items {
        let _ = match mark {
            Mark::Source => write!(
                s,
                r##"<circle cx="{lx:.1}" cy="38" r="4" fill="{}"/>"##,
                source_colour(Some(label))
            ),
            Mark::NoScale => write!(
                s,
                r##"<line x1="{lx:.1}" y1="33" x2="{lx:.1}" y2="45" stroke="{NO_SCALE_COLOUR}" stroke-width="2"/>"##
            ),
            Mark::Applied => write!(
                s,
                r##"<line x1="{:.1}" y1="38" x2="{:.1}" y2="38" stroke="{APPLIED_COLOUR}" stroke-width="1.5"/>"##,
                lx - 6.0,
                lx + 6.0
            ),
            Mark::Slip => write!(
                s,
                r##"<path d="M{lx:.1} 33l-4 8h8z" fill="{SLIP_COLOUR}"/>"##
            ),
        };
        let _ = writeln!(
            s,
            r##"<text x="{:.1}" y="42">{}</text>"##,
            lx + 10.0,
            escape(label)
        );
        lx += 22.0 + 7.0 * label.len() as f64;
    }

    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn frame(t_s: f64, source: Option<&str>, scale: Value, applied: Value, slip: bool) -> Value {
        json!({
            "t": (t_s * 1e9) as u64, "source": source, "scale": scale,
            "applied_scale": applied, "slip_exceeded": slip,
            "no_scale": if source.is_none() { json!("BaselineTooSmall") } else { Value::Null },
        })
    }

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let (t, step) = ticks(0.0, 12.0, 10);
        assert_eq!(step, 2.0);
        assert_eq!(t, vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0]);
        let (t, step) = ticks(2.18, 2.62, 5);
        assert!((step - 0.1).abs() < 1e-12);
        assert_eq!(t.len(), 5, "{t:?}");
        assert!((t[0] - 2.2).abs() < 1e-9 && (t[4] - 2.6).abs() < 1e-9);
        assert_eq!(decimals(step), 1);
        assert_eq!(decimals(2.0), 0);
        assert_eq!(decimals(0.05), 2);
        assert_eq!(ticks(3.0, 3.0, 5).0, vec![3.0]);
    }

    #[test]
    fn a_decision_without_scale_is_a_mark_in_the_no_scale_band() {
        let frames = [
            frame(1.0, None, Value::Null, Value::Null, false),
            frame(2.0, Some("fused"), json!(2.4), json!(2.4), true),
        ];
        let svg = scale_chart_svg(&frames, 0);
        // One point: the fused decision; the other is a no-scale mark with its reason.
        assert_eq!(
            svg.matches(&format!(
                "fill=\"{}\"><title>",
                source_colour(Some("fused"))
            ))
            .count(),
            1
        );
        assert!(svg.contains("1.00 s: no scale (BaselineTooSmall)"), "{svg}");
        assert!(svg.contains(&format!("y1=\"{:.1}\"", NONE_Y - 6.0)));
        assert_eq!(svg.matches("slip exceeded</title>").count(), 1);
        // The legend names the sources present only.
        assert!(svg.contains(">fused</text>") && !svg.contains(">wheel</text>"));
        assert!(svg.starts_with("<svg xmlns=") && svg.ends_with("</svg>\n"));
    }

    #[test]
    fn missing_and_non_finite_values_never_become_nan() {
        // serde_json keeps no NaN or infinity: they arrive as null.
        let frames = [
            frame(
                0.5,
                Some("wheel"),
                json!(f64::NAN),
                json!(f64::INFINITY),
                false,
            ),
            frame(1.0, Some("flow"), json!("2.3"), Value::Null, false),
            json!({"t": null, "source": "fused", "scale": 2.0}),
            frame(1.5, None, Value::Null, Value::Null, false),
        ];
        for f in [&frames[..], &frames[..1], &frames[3..], &[]] {
            let svg = scale_chart_svg(f, 0);
            for bad in ["NaN", "inf", "null"] {
                assert!(!svg.contains(bad), "{bad} in\n{svg}");
            }
        }
        // Nothing finite to plot: no point, no line, the axis still drawn.
        let svg = scale_chart_svg(&frames, 0);
        assert!(!svg.contains("<polyline") && !svg.contains("r=\"2.6\""));
        assert!(svg.contains("time [s]"));
        assert!(scale_chart_svg(&[], 0).contains("no camera frame pairs"));
    }

    #[test]
    fn the_applied_scale_line_breaks_where_there_is_none() {
        let frames = [
            frame(1.0, Some("fused"), json!(2.4), json!(2.4), false),
            frame(2.0, Some("fused"), json!(2.5), json!(2.45), false),
            frame(3.0, None, Value::Null, Value::Null, false),
            frame(4.0, Some("flow"), json!(2.3), json!(2.35), false),
            frame(5.0, Some("flow"), json!(2.3), json!(2.33), false),
        ];
        let svg = scale_chart_svg(&frames, 0);
        assert_eq!(svg.matches("<polyline").count(), 2);
    }
}
