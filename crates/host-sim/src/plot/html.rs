//! `report.html`: one self-contained page (no network, no scripts) with the
//! trajectory and error plots, the summary table, the per-aid counts, the
//! scale decisions over time, the estimator's events, the surface timeline,
//! the faults (with `simulate --faults`) and the filter's final state.
//!
//! The page has inline CSS only and a content security policy that forbids
//! every load (`default-src 'none'`), so it cannot fetch anything even if a
//! plot were to name a resource; a browser would refuse and say so on the
//! console. The plots are inlined as `<svg>` elements.

use super::PlotInputs;
use super::scale_chart::scale_chart_svg;
use super::tables::{
    counts_table, decisions_table, errors_table, events_table, faults_table, final_table, note,
    surface_table,
};
use serde_json::Value;
use std::fmt::Write;

/// `s` with `& < > " '` escaped, for HTML text and attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// An SVG document as an inline element: everything before the `<svg`
/// start tag (an XML prolog, a doctype, comments) dropped; `None` when
/// there is no `<svg`.
pub fn inline_svg(svg: &str) -> Option<&str> {
    svg.find("<svg").map(|i| svg[i..].trim_end())
}

/// First and last time stamp of the run, nanoseconds: over the truth, the
/// three trajectories and the camera frame pairs.
pub fn time_span(inputs: &PlotInputs<'_>) -> Option<(u64, u64)> {
    let truth = inputs.truth.unwrap_or(&[]).iter().map(|g| g.t.0);
    let poses = [inputs.ekf, inputs.vslam, inputs.wheel_only]
        .into_iter()
        .flat_map(|p| p.iter().map(|p| p.t.0));
    let frames = inputs.report["frames"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|f| f["t"].as_u64());
    truth.chain(poses).chain(frames).fold(None, |acc, t| {
        Some(acc.map_or((t, t), |(a, b): (u64, u64)| (a.min(t), b.max(t))))
    })
}

/// Colour of the frame around each plot; used nowhere else on the page, so
/// the browser test finds the plots in a screenshot by it.
pub const FIGURE_FRAME: &str = "#b4c8dc";

const STYLE: &str = "
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1100px; padding: 0 1em; color: #222; background: #fff; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; }
h2 { font-size: 1.2em; margin-top: 1.8em; border-bottom: 1px solid #ccc; padding-bottom: 0.2em; }
p.meta { color: #444; margin-top: 0; }
p.note { color: #555; font-style: italic; }
figure { margin: 1em 0; }
figure svg { max-width: 100%; height: auto; display: block; border: 1px solid FRAME; }
figcaption { color: #555; font-size: 0.9em; margin-top: 0.3em; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }
caption { text-align: left; font-weight: bold; padding-bottom: 0.3em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; }
th { background: #f2f2f2; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
tr.bad td { background: #fde0dc; }
span.sw { display: inline-block; width: 0.8em; height: 0.8em; margin-right: 0.4em; vertical-align: -0.05em; }
pre { background: #f7f7f7; padding: 0.6em; overflow-x: auto; }
";

fn figure(s: &mut String, svg: &str, caption: &str) {
    match inline_svg(svg) {
        Some(svg) => {
            let _ = writeln!(
                s,
                "<figure class=\"plot\">\n{svg}\n<figcaption>{}</figcaption>\n</figure>",
                escape(caption)
            );
        }
        None => s.push_str(&note(&format!("{caption}: no plot"))),
    }
}

fn header(s: &mut String, inputs: &PlotInputs<'_>, span: Option<(u64, u64)>) {
    let source = match inputs.scene {
        Some(scene) => format!("simulated scenario \u{201c}{}\u{201d}", scene.scenario),
        None => "recorded log".to_string(),
    };
    let duration = span.map_or("no samples".to_string(), |(a, b)| {
        format!("{:.1} s", (b - a) as f64 * 1e-9)
    });
    let mut meta = format!("{source}; duration {duration}");
    let r = inputs.report;
    if let Some(missing) = r["missing_sensors"].as_array().filter(|m| !m.is_empty()) {
        let names: Vec<&str> = missing.iter().filter_map(Value::as_str).collect();
        meta += &format!("; missing sensors: {}", names.join(", "));
    }
    if let (Some(frames), Some(corners)) = (
        r["camera_path"]["frames"].as_u64(),
        r["camera_path"]["corner_detections"].as_u64(),
    ) {
        meta += &format!("; {frames} camera frames, corners detected on {corners}");
    }
    if let Some(n) = r["camera_rejections"]
        .as_array()
        .map(Vec::len)
        .filter(|n| *n > 0)
    {
        meta += &format!("; {n} camera frames rejected");
    }
    let _ = writeln!(
        s,
        "<header>\n<h1>traction report</h1>\n<p class=\"meta\">{}</p>\n</header>",
        escape(&meta)
    );
}

/// Renders `report.html` from the inputs, the two plots' SVG text and the
/// summary table as printed (kept at the end of the page, folded).
pub fn report_html(
    inputs: &PlotInputs<'_>,
    trajectory_svg: &str,
    errors_svg: &str,
    summary: &str,
) -> String {
    let span = time_span(inputs);
    let t0 = span.map_or(0, |(a, _)| a);
    let r = inputs.report;
    let mut s = String::new();
    s.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    s.push_str(
        "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'\">\n",
    );
    s.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    let title = match inputs.scene {
        Some(scene) => format!("traction report: {}", scene.scenario),
        None => "traction report: recorded log".to_string(),
    };
    let _ = writeln!(
        s,
        "<title>{}</title>\n<style>{}</style>\n</head>\n<body>",
        escape(&title),
        STYLE.replace("FRAME", FIGURE_FRAME)
    );
    header(&mut s, inputs, span);

    s.push_str("<section id=\"summary\">\n<h2>Summary</h2>\n");
    s += &errors_table(&r["errors"]);
    s.push_str("</section>\n");

    s.push_str("<section id=\"plots\">\n<h2>Trajectories and errors</h2>\n");
    let (top_view, errors) = if inputs.truth.is_some() {
        (
            "top view: the truth, the EKF, the camera path and wheel odometry alone",
            "error over time against the truth",
        )
    } else {
        (
            "top view: the EKF, the camera path and wheel odometry alone",
            "error over time: needs the ground truth, which this log does not have",
        )
    };
    figure(&mut s, trajectory_svg, top_view);
    figure(&mut s, errors_svg, errors);
    s.push_str("</section>\n");

    let frames = r["frames"].as_array().map(Vec::as_slice).unwrap_or(&[]);
    s.push_str("<section id=\"scale\">\n<h2>Scale decisions over time</h2>\n");
    figure(
        &mut s,
        &scale_chart_svg(frames, t0),
        "the scale each camera frame pair decided, by source, and the scale the camera path applied",
    );
    s += &decisions_table(frames);
    s.push_str("</section>\n");

    s.push_str("<section id=\"counts\">\n<h2>Samples per aid</h2>\n");
    s += &counts_table("samples per stream (the estimator)", "stream", &r["counts"]);
    s += &counts_table("samples per aid (the filter)", "aid", &r["filter_counts"]);
    s.push_str("</section>\n");

    s.push_str("<section id=\"events\">\n<h2>Events</h2>\n");
    s += &events_table(&r["events"], t0);
    s.push_str("</section>\n");

    s.push_str("<section id=\"surfaces\">\n<h2>Floor surface</h2>\n");
    s += &surface_table(&r["surface_timeline"], t0);
    s.push_str("</section>\n");

    if r["faults"].is_object() {
        s.push_str("<section id=\"faults\">\n<h2>Faults</h2>\n");
        s += &faults_table(&r["faults"]);
        s.push_str("</section>\n");
    }

    s.push_str("<section id=\"final\">\n<h2>Final state</h2>\n");
    s += &final_table(&r["final"]);
    s.push_str("</section>\n");

    if !summary.trim().is_empty() {
        let _ = writeln!(
            s,
            "<details>\n<summary>summary as printed</summary>\n<pre>{}</pre>\n</details>",
            escape(summary)
        );
    }
    s.push_str("</body>\n</html>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tum::TumPose;
    use serde_json::json;
    use traction::vslam_core::Timestamp;

    fn pose(t_s: f64) -> TumPose {
        TumPose {
            t: Timestamp((t_s * 1e9) as u64),
            p: [t_s, 0.0, 0.0],
            q_xyzw: [0.0, 0.0, 0.0, 1.0],
        }
    }

    const SVG_A: &str = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- plot -->\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\" height=\"10\"><circle cx=\"5\" cy=\"5\" r=\"2\"/></svg>\n";
    const SVG_B: &str = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\" height=\"10\"><rect width=\"10\" height=\"10\"/></svg>";

    fn page(report: &Value, scene: Option<&super::super::Scene>) -> String {
        let poses = [pose(1.0), pose(3.5)];
        let inputs = PlotInputs {
            ekf: &poses,
            vslam: &[],
            wheel_only: &[],
            truth: None,
            scene,
            report,
        };
        report_html(&inputs, SVG_A, SVG_B, "trajectory <ekf> & co")
    }

    #[test]
    fn escape_replaces_the_five_special_characters() {
        assert_eq!(
            escape(r#"<a href="x">Tom & Jerry's</a>"#),
            "&lt;a href=&quot;x&quot;&gt;Tom &amp; Jerry&#39;s&lt;/a&gt;"
        );
        assert_eq!(escape("plain text, 2.5 m"), "plain text, 2.5 m");
        assert_eq!(escape("&amp;"), "&amp;amp;");
    }

    #[test]
    fn inline_svg_drops_the_prolog() {
        let s = inline_svg(SVG_A).unwrap();
        assert!(s.starts_with("<svg xmlns="), "{s}");
        assert!(s.ends_with("</svg>"), "{s}");
        assert_eq!(inline_svg(SVG_B), Some(SVG_B));
        assert_eq!(inline_svg("not a plot"), None);
    }

    #[test]
    fn page_of_a_recorded_log_without_truth() {
        let report = json!({
            "counts": {"imu": {"seen": 10, "fused": 9, "gated": 0, "rejected": {"not_ready": 1}}},
            "events": [{"t": 2_000_000_000u64, "kind": "<b>Strip</b>", "magnitude": 1.5,
                        "explained": null, "surface": "wood"}],
            "frames": [],
        });
        let html = page(&report, None);
        assert!(html.starts_with("<!DOCTYPE html>\n<html lang=\"en\">"));
        assert!(html.contains("recorded log; duration 2.5 s"), "{html}");
        assert!(html.contains("no ground truth in this log"));
        assert!(html.contains("which this log does not have</figcaption>"));
        // Both plots inlined once, without their prolog; the scale chart too.
        assert!(!html.contains("<?xml"));
        assert!(!html.contains("<!-- plot -->"));
        assert_eq!(html.matches("<svg xmlns=").count(), 3);
        assert_eq!(html.matches("<figure class=\"plot\">").count(), 3);
        // Every text escaped: the event kind and the printed summary.
        assert!(html.contains("&lt;b&gt;Strip&lt;/b&gt;"));
        assert!(!html.contains("<b>"));
        assert!(html.contains("trajectory &lt;ekf&gt; &amp; co"));
        // The event at 2 s after the first pose at 1 s.
        assert!(html.contains("<td class=\"n\">1.000</td><td>&lt;b&gt;Strip"));
        // No faults section without faults; no scripts, no loads.
        assert!(!html.contains("id=\"faults\""));
        assert!(!html.contains("<script"));
        assert!(html.contains("default-src 'none'"));
        for tag in ["table", "section", "figure", "svg", "tr", "td", "p"] {
            let open = html.matches(&format!("<{tag}>")).count()
                + html.matches(&format!("<{tag} ")).count();
            let close = html.matches(&format!("</{tag}>")).count();
            assert_eq!(open, close, "<{tag}> opened {open} times, closed {close}");
        }
    }

    #[test]
    fn page_of_a_simulation_with_truth_and_faults() {
        let scene = super::super::Scene {
            scenario: "office".into(),
            ..Default::default()
        };
        let report = json!({
            "errors": {"ekf": {"ate_rmse_m": 0.1234, "final_error_m": 0.2,
                               "final_error_pct_of_path": 1.5, "path_length_m": 10.0}},
            "faults": {"plan": "imu-nan@2x3", "faults": [{"fault": "imu-nan@2x3",
                "injected": 3, "as_expected": 3, "observed": {"non_finite": 3}}]},
        });
        let html = page(&report, Some(&scene));
        assert!(html.contains("<title>traction report: office</title>"));
        assert!(html.contains("simulated scenario \u{201c}office\u{201d}"));
        assert!(html.contains("<td class=\"n\">0.123</td>"));
        assert!(!html.contains("no ground truth"));
        assert!(html.contains("id=\"faults\""));
        assert!(html.contains("<td>imu-nan@2x3</td>"));
    }
}
