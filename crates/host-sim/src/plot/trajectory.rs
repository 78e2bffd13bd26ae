//! `trajectory.svg`: top view of the trajectories, one polyline per
//! trajectory, equal scale on both axes, a metre grid and a legend.

use super::{EKF_COLOUR, PlotInputs, TRUTH_COLOUR, VSLAM_COLOUR, WHEEL_COLOUR};
use crate::tum::TumPose;
use std::fmt::Write as _;

/// Renders `trajectory.svg`: truth (when given), EKF, camera and wheel-only paths.
pub fn trajectory_svg(i: &PlotInputs<'_>) -> String {
    let xy = |v: &[TumPose]| v.iter().map(|p| (p.p[0], p.p[1])).collect::<Vec<_>>();
    let (e, v, w) = (xy(i.ekf), xy(i.vslam), xy(i.wheel_only));
    let t: Vec<(f64, f64)> = i
        .truth
        .map(|g| g.iter().map(|g| (g.p[0], g.p[1])).collect())
        .unwrap_or_default();
    let mut series = vec![
        Series {
            label: "EKF",
            colour: EKF_COLOUR,
            points: &e,
        },
        Series {
            label: "VSLAM (metric scale)",
            colour: VSLAM_COLOUR,
            points: &v,
        },
        Series {
            label: "wheel only",
            colour: WHEEL_COLOUR,
            points: &w,
        },
    ];
    if !t.is_empty() {
        series.insert(
            0,
            Series {
                label: "truth",
                colour: TRUTH_COLOUR,
                points: &t,
            },
        );
    }
    top_view("traction: top view", &series)
}

/// One trajectory to draw.
pub struct Series<'a> {
    /// Legend label.
    pub label: &'a str,
    /// CSS colour.
    pub colour: &'a str,
    /// Planar points `(x, y)`, metres.
    pub points: &'a [(f64, f64)],
}

/// Renders the SVG text.
pub fn top_view(title: &str, series: &[Series<'_>]) -> String {
    let pts = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in pts {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
        y0 = y0.min(*y);
        y1 = y1.max(*y);
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let pad = 0.5;
    let (x0, x1, y0, y1) = (x0 - pad, x1 + pad, y0 - pad, y1 + pad);
    let (w, h) = (900.0, 900.0 * ((y1 - y0) / (x1 - x0)).clamp(0.3, 1.5));
    let k = w / (x1 - x0);
    let sx = |x: f64| (x - x0) * k;
    let sy = |y: f64| h - (y - y0) * k;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0}" height="{:.0}" viewBox="0 -40 {w:.0} {:.0}" font-family="sans-serif" font-size="13">"#,
        h + 40.0,
        h + 40.0
    );
    let _ = writeln!(
        s,
        r#"<rect x="0" y="-40" width="{w:.0}" height="{:.0}" fill="white"/>"#,
        h + 40.0
    );
    let _ = writeln!(
        s,
        r#"<text x="8" y="-20" font-size="16">{}</text>"#,
        escape(title)
    );
    for gx in (x0.ceil() as i64)..=(x1.floor() as i64) {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" y1="0" x2="{0:.1}" y2="{h:.1}" stroke="#eee"/>"##,
            sx(gx as f64)
        );
    }
    for gy in (y0.ceil() as i64)..=(y1.floor() as i64) {
        let _ = writeln!(
            s,
            r##"<line x1="0" y1="{0:.1}" x2="{w:.1}" y2="{0:.1}" stroke="#eee"/>"##,
            sy(gy as f64)
        );
    }
    for (i, se) in series.iter().enumerate() {
        let mut d = String::new();
        for (x, y) in se
            .points
            .iter()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
        {
            let _ = write!(d, "{:.1},{:.1} ", sx(*x), sy(*y));
        }
        let _ = writeln!(
            s,
            r#"<polyline points="{d}" fill="none" stroke="{}" stroke-width="2" stroke-opacity="0.85"/>"#,
            escape(se.colour)
        );
        let ly = 20.0 + 18.0 * i as f64;
        let _ = writeln!(
            s,
            r#"<line x1="{:.0}" y1="{ly}" x2="{:.0}" y2="{ly}" stroke="{}" stroke-width="3"/><text x="{:.0}" y="{:.0}">{}</text>"#,
            w - 190.0,
            w - 160.0,
            escape(se.colour),
            w - 152.0,
            ly + 4.0,
            escape(se.label)
        );
    }
    let _ = writeln!(
        s,
        r##"<text x="8" y="{:.0}" fill="#666">grid: 1 m</text>"##,
        h - 8.0
    );
    s.push_str("</svg>\n");
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_every_series_and_escapes() {
        let a = [(0.0, 0.0), (1.0, 2.0)];
        let b = [(0.0, 0.0), (f64::NAN, 1.0), (2.0, 1.0)];
        let svg = top_view(
            "a < b",
            &[
                Series {
                    label: "truth",
                    colour: "black",
                    points: &a,
                },
                Series {
                    label: "ekf",
                    colour: "#d62728",
                    points: &b,
                },
            ],
        );
        assert!(svg.starts_with("<svg"));
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("a &lt; b"));
        assert!(!svg.contains("NaN"));
    }
}
