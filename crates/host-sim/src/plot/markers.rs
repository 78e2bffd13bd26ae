//! What the plots mark besides the trajectories: the start and ends, where a
//! trajectory leaves the frame, the simulated world's cable, threshold
//! strips and slip, stuck and lift episodes (from [`Scene`]), and the
//! estimator's events (`report.json` `events`). Each marker has one shape
//! and colour, used on the plot and in its legend alike.

use super::scene::Scene;
use super::track::Planar;
use super::{EstimatorEvent, axes::escape};
use std::fmt::Write as _;

/// Colour of the slip highlight along the truth.
pub const SLIP_COLOUR: &str = "#9467bd";

/// A kind of marker.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    /// Where the run starts.
    Start,
    /// Where a trajectory ends (its colour).
    End(&'static str),
    /// Where a trajectory leaves the frame (its colour).
    Exit(&'static str),
    /// The truth crosses the cable.
    Cable,
    /// The truth crosses a threshold strip.
    Strip,
    /// A stuck episode starts.
    Stuck,
    /// A lift episode starts.
    Lifted,
    /// The estimator suspected an obstacle.
    SuspectedObstacle,
    /// The estimator explained a jolt by a threshold strip.
    ThresholdStrip,
    /// The estimator explained a jolt by the surface.
    SurfaceNoise,
}

impl Mark {
    /// Legend text.
    pub fn name(self) -> &'static str {
        match self {
            Mark::Start => "start",
            Mark::End(_) => "end",
            Mark::Exit(_) => "leaves the frame",
            Mark::Cable => "cable (simulated world)",
            Mark::Strip => "threshold strip (simulated world)",
            Mark::Stuck => "stuck episode (simulated)",
            Mark::Lifted => "lifted episode (simulated)",
            Mark::SuspectedObstacle => "estimator: suspected obstacle",
            Mark::ThresholdStrip => "estimator: threshold strip",
            Mark::SurfaceNoise => "estimator: surface noise",
        }
    }

    /// The mark of an estimator event kind.
    pub fn of_event(kind: &str) -> Option<Mark> {
        match kind {
            "SuspectedObstacle" => Some(Mark::SuspectedObstacle),
            "ThresholdStrip" => Some(Mark::ThresholdStrip),
            "SurfaceNoise" => Some(Mark::SurfaceNoise),
            _ => None,
        }
    }

    /// The mark's shape centred on `(x, y)` (pixels).
    pub fn svg(self, s: &mut String, x: f64, y: f64) {
        let _ = match self {
            Mark::Start => writeln!(
                s,
                r##"<circle cx="{x:.1}" cy="{y:.1}" r="6" fill="#2ca02c" stroke="white" stroke-width="1.5"/>"##
            ),
            Mark::End(c) => writeln!(
                s,
                r##"<rect x="{:.1}" y="{:.1}" width="10" height="10" fill="{c}" stroke="white" stroke-width="1.5"/>"##,
                x - 5.0,
                y - 5.0
            ),
            Mark::Exit(c) => writeln!(
                s,
                r##"<circle cx="{x:.1}" cy="{y:.1}" r="7" fill="white" stroke="{c}" stroke-width="2.5"/><line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{c}" stroke-width="2.5"/>"##,
                x - 4.0,
                y - 4.0,
                x + 4.0,
                y + 4.0
            ),
            Mark::Cable => writeln!(
                s,
                r##"<rect x="{:.1}" y="{:.1}" width="4" height="14" fill="#3b2f2f"/>"##,
                x - 2.0,
                y - 7.0
            ),
            Mark::Strip => writeln!(
                s,
                r##"<rect x="{:.1}" y="{:.1}" width="3" height="14" fill="#a0522d" fill-opacity="0.7"/>"##,
                x - 1.5,
                y - 7.0
            ),
            Mark::Stuck => writeln!(
                s,
                r##"<circle cx="{x:.1}" cy="{y:.1}" r="7" fill="#b71c1c"/><line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="white" stroke-width="2.5"/>"##,
                x - 4.0,
                x + 4.0
            ),
            Mark::Lifted => writeln!(
                s,
                r##"<path d="M{x:.1},{:.1} L{:.1},{:.1} L{:.1},{:.1} Z" fill="white" stroke="#6a1b9a" stroke-width="2"/>"##,
                y - 8.0,
                x + 7.0,
                y + 6.0,
                x - 7.0,
                y + 6.0
            ),
            Mark::SuspectedObstacle => writeln!(
                s,
                r##"<path d="M{x:.1},{:.1} L{:.1},{:.1} L{:.1},{:.1} Z" fill="#c2185b" stroke="white"/>"##,
                y - 8.0,
                x + 7.0,
                y + 5.0,
                x - 7.0,
                y + 5.0
            ),
            Mark::ThresholdStrip => writeln!(
                s,
                r##"<path d="M{x:.1},{:.1} L{:.1},{y:.1} L{x:.1},{:.1} L{:.1},{y:.1} Z" fill="#8c564b" stroke="white"/>"##,
                y - 7.0,
                x + 6.0,
                y + 7.0,
                x - 6.0
            ),
            Mark::SurfaceNoise => writeln!(
                s,
                r##"<circle cx="{x:.1}" cy="{y:.1}" r="4.5" fill="#17becf" stroke="white"/>"##
            ),
        };
    }
}

/// A marked moment of the run: what, when (seconds), and where (metres,
/// when known).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moment {
    /// What.
    pub mark: Mark,
    /// Seconds.
    pub t: f64,
    /// Where, when known.
    pub at: Option<(f64, f64)>,
}

/// The times the truth crosses each of the scene's strips and cables
/// (crossings closer than a second to the previous one of the same strip
/// are one).
pub fn crossings(scene: &Scene, truth: &[Planar]) -> Vec<Moment> {
    let mut out = Vec::new();
    for strip in &scene.strips {
        let mark = if strip.threshold {
            Mark::Strip
        } else {
            Mark::Cable
        };
        let mut last: Option<f64> = None;
        for w in truth.windows(2) {
            let (a, b) = (w[0].x - strip.at, w[1].x - strip.at);
            if (a < 0.0) != (b < 0.0) && last.is_none_or(|l| w[1].t - l > 1.0) {
                last = Some(w[1].t);
                out.push(Moment {
                    mark,
                    t: w[1].t,
                    at: Some((w[1].x, w[1].y)),
                });
            }
        }
    }
    out.sort_by(|a, b| a.t.total_cmp(&b.t));
    out
}

/// Stuck and lift episodes' starts, placed on `truth`.
pub fn episode_starts(scene: &Scene, truth: &[Planar]) -> Vec<Moment> {
    scene
        .episodes
        .iter()
        .filter_map(|e| {
            let mark = match e.kind.as_str() {
                "stuck" => Mark::Stuck,
                "lifted" => Mark::Lifted,
                _ => return None,
            };
            let t = e.start_ns as f64 * 1e-9;
            Some(Moment {
                mark,
                t,
                at: super::track::at(truth, t).map(|p| (p.x, p.y)),
            })
        })
        .collect()
}

/// Slip episodes as `(start, end)` seconds.
pub fn slips(scene: &Scene) -> Vec<(f64, f64)> {
    scene
        .episodes
        .iter()
        .filter(|e| e.kind == "slip")
        .map(|e| (e.start_ns as f64 * 1e-9, e.end_ns as f64 * 1e-9))
        .collect()
}

/// The estimator's events, placed on `path` (the EKF's trajectory).
pub fn events(events: &[EstimatorEvent], path: &[Planar]) -> Vec<Moment> {
    events
        .iter()
        .filter_map(|e| {
            let t = e.t_ns as f64 * 1e-9;
            Some(Moment {
                mark: Mark::of_event(&e.kind)?,
                t,
                at: super::track::at(path, t).map(|p| (p.x, p.y)),
            })
        })
        .collect()
}

/// Characters per legend line before a row wraps.
pub const LEGEND_CHARS: usize = 40;

/// Splits `text` into lines of at most [`LEGEND_CHARS`] characters at spaces
/// (a longer word stays whole).
pub fn wrap_text(text: &str) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split(' ') {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + word.chars().count() <= LEGEND_CHARS => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// One legend entry at `y` (its first line): a swatch (a line in `colour`, a
/// box or a mark) and its text, wrapped; returns the lines it took.
pub fn legend_row(s: &mut String, x: f64, y: f64, swatch: Swatch<'_>, text: &str) -> usize {
    match swatch {
        Swatch::Line { colour, width } => {
            let _ = writeln!(
                s,
                r#"<line x1="{x:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{colour}" stroke-width="{width}"/>"#,
                x + 26.0
            );
        }
        Swatch::Fill(colour) => {
            let _ = writeln!(
                s,
                r##"<rect x="{x:.1}" y="{:.1}" width="26" height="12" fill="{colour}" stroke="#bbb"/>"##,
                y - 6.0
            );
        }
        Swatch::Mark(m) => m.svg(s, x + 13.0, y),
    }
    let lines = wrap_text(text);
    for (k, line) in lines.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
            x + 34.0,
            y + 4.0 + LEGEND_LINE * k as f64,
            escape(line)
        );
    }
    lines.len().max(1)
}

/// Height of a legend line, px.
pub const LEGEND_LINE: f64 = 16.0;

/// What a legend row shows.
#[derive(Clone, Copy, Debug)]
pub enum Swatch<'a> {
    /// A line.
    Line {
        /// Its colour.
        colour: &'a str,
        /// Its width, px.
        width: f64,
    },
    /// A filled box.
    Fill(&'a str),
    /// A marker.
    Mark(Mark),
}

#[cfg(test)]
mod tests {
    use super::super::scene::{SceneEpisode, SceneStrip};
    use super::*;

    fn line(n: usize) -> Vec<Planar> {
        (0..n)
            .map(|i| Planar {
                t: i as f64 * 0.1,
                x: i as f64 * 0.1,
                y: 0.0,
                yaw: 0.0,
            })
            .collect()
    }

    #[test]
    fn crossings_of_the_truth_over_strips_and_cables() {
        let scene = Scene {
            strips: vec![
                SceneStrip {
                    at: 1.0,
                    height: 0.006,
                    threshold: true,
                },
                SceneStrip {
                    at: 0.55,
                    height: 0.012,
                    threshold: false,
                },
                SceneStrip {
                    at: 9.0,
                    height: 0.006,
                    threshold: true,
                },
            ],
            episodes: vec![SceneEpisode {
                start_ns: 500_000_000,
                end_ns: 900_000_000,
                kind: "stuck".into(),
            }],
            ..Scene::default()
        };
        let truth = line(20);
        let c = crossings(&scene, &truth);
        assert_eq!(c.len(), 2, "{c:?}");
        assert_eq!(c[0].mark, Mark::Cable);
        assert!((c[0].t - 0.6).abs() < 1e-9);
        assert_eq!(c[1].mark, Mark::Strip);
        let e = episode_starts(&scene, &truth);
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].mark, Mark::Stuck);
        assert!((e[0].at.unwrap().0 - 0.5).abs() < 1e-9);
    }

    #[test]
    fn long_legend_text_wraps_at_spaces() {
        let l = wrap_text("wheel only: position off scale from 8.9 s (largest 7.91 m)");
        assert!(
            l.len() == 2 && l.iter().all(|l| l.chars().count() <= LEGEND_CHARS),
            "{l:?}"
        );
        assert_eq!(
            l.join(" "),
            "wheel only: position off scale from 8.9 s (largest 7.91 m)"
        );
        assert_eq!(wrap_text("short"), vec!["short".to_string()]);
    }

    #[test]
    fn events_are_placed_on_the_path_and_unknown_kinds_left_out() {
        let ev = [
            EstimatorEvent {
                t_ns: 1_000_000_000,
                kind: "SuspectedObstacle".into(),
            },
            EstimatorEvent {
                t_ns: 1_000_000_000,
                kind: "Other".into(),
            },
        ];
        let m = events(&ev, &line(20));
        assert_eq!(m.len(), 1);
        assert!((m[0].at.unwrap().0 - 1.0).abs() < 1e-9);
    }
}
