//! The plots as a person sees them: `trajectory.svg` and `errors.svg`
//! rendered to pixels by a real SVG renderer (resvg), then each trace looked
//! for by its colour inside its plot area, and the truth checked to stay
//! visible under the estimates.

use host_sim::asl::{GroundTruth, read_dataset};
use host_sim::plot::errors::errors_svg;
use host_sim::plot::trajectory::trajectory_svg;
use host_sim::plot::{PlotInputs, Scene};
use host_sim::simulate::run_simulate;
use host_sim::tum::TumPose;
use resvg::tiny_skia::{Pixmap, Transform};
use serde_json::{Value, json};
use traction::Timestamp;

mod common;

// The trace colours, restated (plot/mod.rs).
const TRUTH: [u8; 3] = [0x7f, 0x7f, 0x7f];
const EKF: [u8; 3] = [0xd6, 0x27, 0x28];
const VSLAM: [u8; 3] = [0x1f, 0x77, 0xb4];
const WHEEL: [u8; 3] = [0xff, 0x7f, 0x0e];

/// Rendering scale: lines 2 px wide become 4 px, with solid pixels inside.
const SCALE: f32 = 2.0;

struct Picture {
    pixmap: Pixmap,
    svg: String,
}

fn render(svg: &str) -> Picture {
    let tree =
        resvg::usvg::Tree::from_str(svg, &resvg::usvg::Options::default()).expect("the SVG parses");
    let size = tree.size();
    let mut pixmap = Pixmap::new(
        (size.width() * SCALE).ceil() as u32,
        (size.height() * SCALE).ceil() as u32,
    )
    .unwrap();
    resvg::render(
        &tree,
        Transform::from_scale(SCALE, SCALE),
        &mut pixmap.as_mut(),
    );
    Picture {
        pixmap,
        svg: svg.to_string(),
    }
}

/// `(x, y, width, height)` of the rectangle `id="{id}-area"`, in pixels of
/// the rendering.
fn area(svg: &str, id: &str) -> (u32, u32, u32, u32) {
    let tag = format!(r#"id="{id}-area""#);
    let start = svg.find(&tag).unwrap_or_else(|| panic!("no {tag}"));
    let rest = &svg[start..svg[start..].find("/>").unwrap() + start];
    let attr = |name: &str| -> f32 {
        let k = rest.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
        rest[k..k + rest[k..].find('"').unwrap()].parse().unwrap()
    };
    let s = |v: f32| (v * SCALE).round() as u32;
    (
        s(attr("x")),
        s(attr("y")),
        s(attr("width")),
        s(attr("height")),
    )
}

impl Picture {
    /// Pixels within 10 levels of `colour` (every channel) inside `rect`.
    fn count(&self, colour: [u8; 3], rect: (u32, u32, u32, u32)) -> usize {
        let (x0, y0, w, h) = rect;
        let mut n = 0;
        for y in y0..(y0 + h).min(self.pixmap.height()) {
            for x in x0..(x0 + w).min(self.pixmap.width()) {
                let p = self.pixmap.pixel(x, y).unwrap();
                let c = [p.red(), p.green(), p.blue()];
                if c.iter().zip(colour).all(|(a, b)| a.abs_diff(b) <= 10) {
                    n += 1;
                }
            }
        }
        n
    }

    /// [`Picture::count`] inside the plot area `id`, its edge left out.
    fn count_in(&self, colour: [u8; 3], id: &str) -> usize {
        let (x, y, w, h) = area(&self.svg, id);
        self.count(
            colour,
            (x + 3, y + 3, w.saturating_sub(6), h.saturating_sub(6)),
        )
    }
}

fn pose(t: f64, x: f64, y: f64, yaw: f64) -> TumPose {
    TumPose {
        t: Timestamp((t * 1e9).round() as u64),
        p: [x, y, 0.0],
        q_xyzw: [0.0, 0.0, (0.5 * yaw).sin(), (0.5 * yaw).cos()],
    }
}

/// A 4 m x 2 m loop driven in 40 s, as the truth; `f(t)` is added to it.
fn loop_path(f: impl Fn(f64) -> (f64, f64, f64)) -> Vec<TumPose> {
    (0..=400)
        .map(|i| {
            let t = i as f64 * 0.1;
            let u = t / 40.0 * 12.0;
            let (x, y, yaw) = if u < 4.0 {
                (u, 0.0, 0.0)
            } else if u < 6.0 {
                (4.0, u - 4.0, std::f64::consts::FRAC_PI_2)
            } else if u < 10.0 {
                (10.0 - u, 2.0, std::f64::consts::PI)
            } else {
                (0.0, 12.0 - u, -std::f64::consts::FRAC_PI_2)
            };
            let (dx, dy, dyaw) = f(t);
            pose(t, x + dx, y + dy, yaw + dyaw)
        })
        .collect()
}

fn as_truth(v: &[TumPose]) -> Vec<GroundTruth> {
    v.iter()
        .map(|p| GroundTruth {
            t: p.t,
            p: p.p,
            q_wxyz: [p.q_xyzw[3], p.q_xyzw[0], p.q_xyzw[1], p.q_xyzw[2]],
            v: [0.0; 3],
            bias_gyro: [0.0; 3],
            bias_accel: [0.0; 3],
        })
        .collect()
}

/// A truth loop; an EKF near it; a camera path exactly on it (the worst
/// case for the truth's visibility); wheels that run 30 m away.
struct Synthetic {
    truth: Vec<GroundTruth>,
    ekf: Vec<TumPose>,
    vslam: Vec<TumPose>,
    wheel: Vec<TumPose>,
    report: Value,
}

fn synthetic() -> Synthetic {
    let exact = loop_path(|_| (0.0, 0.0, 0.0));
    Synthetic {
        truth: as_truth(&exact),
        ekf: loop_path(|t| (0.08 * (t * 0.3).sin(), 0.06, 0.02 * (t * 0.2).sin())),
        vslam: exact,
        wheel: loop_path(|t| (0.02 * t * t, 0.01 * t * t, 0.03 * t)),
        report: json!({"errors": {"wheel_only": {"ate_rmse_m": 12.0, "final_error_m": 35.8}}}),
    }
}

impl Synthetic {
    fn inputs(&self) -> PlotInputs<'_> {
        PlotInputs {
            ekf: &self.ekf,
            vslam: &self.vslam,
            wheel_only: &self.wheel,
            truth: Some(&self.truth),
            scene: None,
            report: &self.report,
        }
    }
}

#[test]
fn every_trace_is_visible_inside_the_frame_and_the_truth_under_them() {
    let s = synthetic();
    let all = render(&trajectory_svg(&s.inputs()));
    for (name, c) in [
        ("truth", TRUTH),
        ("EKF", EKF),
        ("VSLAM", VSLAM),
        ("wheel", WHEEL),
    ] {
        let n = all.count_in(c, "frame");
        assert!(n > 400, "{name}: {n} pixels inside the frame");
    }
    let alone = render(&trajectory_svg(&PlotInputs {
        ekf: &[],
        vslam: &[],
        wheel_only: &[],
        ..s.inputs()
    }));
    let (covered, bare) = (all.count_in(TRUTH, "frame"), alone.count_in(TRUTH, "frame"));
    assert!(
        covered * 10 >= bare * 3,
        "the truth under the estimates keeps {covered} of its {bare} pixels"
    );
}

#[test]
fn the_frame_holds_the_truth_and_clips_the_trajectory_that_runs_off() {
    let s = synthetic();
    let svg = trajectory_svg(&s.inputs());
    let (_, _, w, _) = area(&svg, "frame");
    // Framed on the 4 m loop, not on the wheels' 30 m: the truth spans most
    // of the frame's width.
    let truth_alone = render(&trajectory_svg(&PlotInputs {
        ekf: &[],
        vslam: &[],
        wheel_only: &[],
        ..s.inputs()
    }));
    let (x0, y0, _, h) = area(&truth_alone.svg, "frame");
    let columns = (x0..x0 + w)
        .filter(|&x| truth_alone.count(TRUTH, (x, y0, 3, h)) > 0)
        .count();
    assert!(
        columns * 2 > w as usize,
        "truth over {columns} of {w} columns"
    );
    assert!(
        svg.contains("wheel only: off the frame from"),
        "legend says so"
    );
    assert!(svg.contains("final error 35.80 m"));
    // Nothing of the wheels' trace outside the frame but the exit mark and
    // the legend's swatch.
    let pic = render(&svg);
    let outside = pic.count(WHEEL, (0, 0, x0, pic.pixmap.height()))
        + pic.count(
            WHEEL,
            (x0, y0 + h + 16, w, pic.pixmap.height() - y0 - h - 16),
        );
    assert_eq!(
        outside, 0,
        "wheel-coloured pixels left of or below the frame"
    );
}

#[test]
fn the_error_plot_shows_every_trace_in_both_panels() {
    let s = synthetic();
    let pic = render(&errors_svg(&s.inputs()));
    for (name, c) in [("EKF", EKF), ("wheel", WHEEL)] {
        for panel in ["pos", "yaw"] {
            let n = pic.count_in(c, panel);
            assert!(n > 200, "{name} in {panel}: {n} pixels");
        }
    }
    // The camera path is exact: its line lies on zero in both panels.
    assert!(pic.count_in(VSLAM, "pos") > 200);
    assert!(pic.svg.contains("wheel only: position off scale from"));
}

#[test]
fn without_a_truth_the_plots_frame_on_the_ekf_and_say_there_are_no_errors() {
    let s = synthetic();
    let inputs = PlotInputs {
        truth: None,
        report: &Value::Null,
        ..s.inputs()
    };
    let pic = render(&trajectory_svg(&inputs));
    assert!(pic.count_in(EKF, "frame") > 400);
    assert_eq!(pic.count_in(TRUTH, "frame"), 0);
    let errors = errors_svg(&inputs);
    render(&errors);
    assert!(errors.contains("No ground truth"));
    // Nothing at all still makes a picture.
    let empty = PlotInputs {
        ekf: &[],
        vslam: &[],
        wheel_only: &[],
        truth: None,
        scene: None,
        report: &Value::Null,
    };
    render(&trajectory_svg(&empty));
    render(&errors_svg(&empty));
}

#[test]
fn a_simulated_run_draws_its_world_its_traces_and_its_events() {
    let out = common::scratch("traction-plots", "short");
    let r = run_simulate("short", 1, &out, false).unwrap();
    let dataset = out.join("dataset");
    let ds = read_dataset(&dataset).unwrap();
    let scene = Scene::read(&dataset)
        .unwrap()
        .expect("simulate writes world.json");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let inputs = PlotInputs {
        ekf: &r.ekf,
        vslam: &r.vslam,
        wheel_only: &r.wheel_only,
        truth: ds.groundtruth.as_deref(),
        scene: Some(&scene),
        report: &report,
    };
    let svg = trajectory_svg(&inputs);
    assert_eq!(
        svg,
        std::fs::read_to_string(out.join("trajectory.svg")).unwrap(),
        "the file is what the inputs draw"
    );
    let pic = render(&svg);
    for (name, c) in [
        ("truth", TRUTH),
        ("EKF", EKF),
        ("VSLAM", VSLAM),
        ("wheel", WHEEL),
    ] {
        let n = pic.count_in(c, "frame");
        assert!(n > 100, "{name}: {n} pixels inside the frame");
    }
    let alone = render(&trajectory_svg(&PlotInputs {
        ekf: &[],
        vslam: &[],
        wheel_only: &[],
        ..inputs
    }));
    let (covered, bare) = (pic.count_in(TRUTH, "frame"), alone.count_in(TRUTH, "frame"));
    assert!(covered * 10 >= bare * 3, "{covered} of {bare}");
    // The world: the floor map's wood and the cable (the short run crosses it).
    assert!(
        pic.count_in([0xf4, 0xe6, 0xcf], "frame") > 10_000,
        "wood floor"
    );
    assert!(svg.contains(">cable</text>"));
    assert!(svg.contains("floor: wood"));
    // The estimator's events, each as a mark with its count in the legend.
    let n_events = report["events"].as_array().unwrap().len();
    assert!(n_events > 0, "the short run crosses the cable");
    assert!(svg.contains("estimator: suspected obstacle"));
    let errors = render(&std::fs::read_to_string(out.join("errors.svg")).unwrap());
    for (name, c) in [("EKF", EKF), ("VSLAM", VSLAM)] {
        assert!(errors.count_in(c, "pos") > 100, "{name} position error");
        assert!(errors.count_in(c, "yaw") > 100, "{name} yaw error");
    }
}

#[test]
fn injected_faults_are_drawn_along_the_error_plot() {
    let s = synthetic();
    let report = json!({"faults": {"faults": [
        {"fault": "wheel-gap@5+2", "start_s": 5.0, "window_end_s": 7.0},
        {"fault": "imu-nan@20x3", "start_s": 20.0, "window_end_s": 20.012},
        {"fault": "late", "start_s": 99.0, "window_end_s": 100.0},
    ]}});
    let svg = errors_svg(&PlotInputs {
        report: &report,
        ..s.inputs()
    });
    let group = &svg[svg
        .find(r#"<g id="injected-faults">"#)
        .expect("the faults' group")..];
    let group = &group[..group.find("</g>").unwrap()];
    assert_eq!(
        group.matches("<rect").count(),
        2,
        "the one past the run is left out"
    );
    assert!(svg.contains("injected fault window (3)"));
    // Dark ticks at the foot of the position panel: 2 s of an 800 px wide
    // 40 s panel is 40 px, 7 px tall (x2 when rendered).
    const FAULT: [u8; 3] = [0x37, 0x47, 0x4f];
    let pic = render(&svg);
    let n = pic.count_in(FAULT, "pos");
    assert!(n > 400, "{n} fault pixels");
    assert_eq!(render(&errors_svg(&s.inputs())).count_in(FAULT, "pos"), 0);
}
