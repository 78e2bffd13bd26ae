//! `report.html` in a real browser: a short simulation (once plain, once
//! with faults) writes OUT/report.html, and headless Chromium (the Debian
//! package `chromium`) loads it from disk:
//!
//! - `--dump-dom`: the parsed page has the three plots as `<svg>` elements
//!   and the tables with what report.json says (trajectory names and ATE,
//!   stream counts, one row per event, the faults);
//! - `--screenshot`: in the rendered PNG each plot's frame (colour
//!   `FIGURE_FRAME`) is found and what the plot draws is there: the truth and
//!   EKF colours in the top view, the scale decisions' colours in the scale
//!   chart, ink wherever an SVG draws something;
//! - `--enable-logging=stderr --v=0`: no console message from the page.
//!
//! What Chromium prints on stderr here on its own, and the test ignores:
//! the Debian launcher's `/usr/bin/chromium: 9: [: ...: unexpected
//! operator`, `ERROR:dbus/...` (no system bus in a container),
//! `WARNING:media/gpu/vaapi/...` (no GPU), `WARNING:sandbox/...`
//! (`--no-sandbox`), `bluez_dbus_manager`, `idle_linux` and
//! `NN bytes written to file` after a screenshot. What the page causes is
//! logged as `INFO:CONSOLE:<line>] "<message>", source: file:///...`: SVG
//! attribute errors (`<path> attribute d: Expected number, "NaN"`), script
//! errors (`Uncaught ...`) and, since the page's content security policy
//! is `default-src 'none'`, every resource load it tries (`Loading the
//! image '...' violates the following Content Security Policy directive`).
//! The filter takes every line with `CONSOLE` or `Uncaught` or the page's
//! file name; it is checked on a broken page first, so a filter that stops
//! seeing Chromium's errors fails the test.
//!
//! Without Chromium the test fails when `CI` is set and is skipped
//! otherwise. Each Chromium run is killed after 60 s.

mod common;

use host_sim::faults::FaultPlan;
use host_sim::plot::EKF_COLOUR;
use host_sim::plot::html::FIGURE_FRAME;
use host_sim::simulate::{run_simulate, run_simulate_faults};
use serde_json::Value;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(60);
const WIDTH: u32 = 1200;
const HEIGHT: u32 = 4500;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-it", name)
}

/// The Chromium binary: `chromium` on the PATH.
fn chromium() -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("chromium"))
            .find(|p| p.is_file())
    })
}

/// What one Chromium run printed.
struct Run {
    stdout: String,
    stderr: String,
}

/// Runs headless Chromium with `args` and a fresh profile in `work`, in a
/// process group of its own that is killed after [`TIMEOUT`].
fn run_chromium(bin: &Path, work: &Path, tag: &str, args: &[String]) -> Run {
    let profile = work.join(format!("profile-{tag}"));
    let _ = std::fs::remove_dir_all(&profile);
    std::fs::create_dir_all(&profile).unwrap();
    let out_path = work.join(format!("{tag}.stdout"));
    let err_path = work.join(format!("{tag}.stderr"));
    let mut child = Command::new(bin)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--force-device-scale-factor=1",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .process_group(0)
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > TIMEOUT {
            let _ = Command::new("kill")
                .args(["-KILL", "--", &format!("-{}", child.id())])
                .status();
            let _ = child.kill();
            let _ = child.wait();
            panic!("chromium ({tag}) did not finish within {TIMEOUT:?}; killed");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let run = Run {
        stdout: std::fs::read_to_string(&out_path).unwrap(),
        stderr: std::fs::read_to_string(&err_path).unwrap(),
    };
    assert!(
        status.success(),
        "chromium ({tag}) failed: {status}\n{}",
        run.stderr
    );
    run
}

/// The lines of Chromium's stderr the page caused (module docs).
fn page_errors<'a>(stderr: &'a str, page: &str) -> Vec<&'a str> {
    stderr
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Uncaught") || l.contains(page))
        .collect()
}

fn url(p: &Path) -> String {
    format!("file://{}", p.canonicalize().unwrap().display())
}

/// The `<table>` elements of `dom`, each from `<table` to `</table>`.
fn tables(dom: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = dom;
    while let Some(i) = rest.find("<table") {
        let j = rest[i..].find("</table>").expect("unclosed table") + i + 8;
        out.push(&rest[i..j]);
        rest = &rest[j..];
    }
    out
}

fn table_with<'a>(tables: &[&'a str], caption: &str) -> &'a str {
    tables
        .iter()
        .copied()
        .find(|t| t.contains(caption))
        .unwrap_or_else(|| panic!("no table with the caption `{caption}`"))
}

/// The `<svg>…</svg>` elements of `dom` (top level, as the page inlines them).
fn svgs(dom: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = dom;
    while let Some(i) = rest.find("<svg") {
        let j = rest[i..].find("</svg>").expect("unclosed svg") + i + 6;
        out.push(&rest[i..j]);
        rest = &rest[j..];
    }
    out
}

fn hex(c: &str) -> [u8; 3] {
    let v = u32::from_str_radix(c.trim_start_matches('#'), 16).unwrap();
    [(v >> 16) as u8, (v >> 8) as u8, v as u8]
}

/// An RGB image.
struct Image {
    w: usize,
    h: usize,
    rgb: Vec<[u8; 3]>,
}

fn load_png(p: &Path) -> Image {
    let mut dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0u8; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => panic!("screenshot is {other:?}"),
    };
    let (w, h) = (info.width as usize, info.height as usize);
    let mut rgb = Vec::with_capacity(w * h);
    for row in buf.chunks(info.line_size).take(h) {
        for px in row.chunks_exact(channels).take(w) {
            rgb.push([px[0], px[1], px[2]]);
        }
    }
    Image { w, h, rgb }
}

fn near(px: [u8; 3], c: [u8; 3], tol: u8) -> bool {
    px.iter().zip(c).all(|(a, b)| a.abs_diff(b) <= tol)
}

/// A plot's area inside its frame: columns `x0..x1`, rows `y0..y1`.
#[derive(Debug)]
struct Area {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// The plots' areas: the frames' top and bottom edges are the rows with a
/// long run of the frame colour.
fn plot_areas(img: &Image) -> Vec<Area> {
    let frame = hex(FIGURE_FRAME);
    let mut edges = Vec::new();
    for y in 0..img.h {
        let row = &img.rgb[y * img.w..(y + 1) * img.w];
        let xs: Vec<usize> = (0..img.w).filter(|&x| near(row[x], frame, 2)).collect();
        if xs.len() >= 300 {
            edges.push((y, xs[0], *xs.last().unwrap()));
        }
    }
    edges
        .chunks(2)
        .filter_map(|e| match e {
            [(top, x0, x1), (bottom, ..)] => Some(Area {
                x0: x0 + 1,
                x1: *x1,
                y0: top + 1,
                y1: *bottom,
            }),
            _ => None,
        })
        .collect()
}

/// Pixels in `a` within `tol` of `colour`.
fn count(img: &Image, a: &Area, colour: [u8; 3], tol: u8) -> usize {
    (a.y0..a.y1)
        .flat_map(|y| (a.x0..a.x1).map(move |x| (x, y)))
        .filter(|&(x, y)| near(img.rgb[y * img.w + x], colour, tol))
        .count()
}

/// Pixels in `a` that are not (nearly) white.
fn ink(img: &Image, a: &Area) -> usize {
    let area = (a.x1 - a.x0) * (a.y1 - a.y0);
    area - count(img, a, [255, 255, 255], 8)
}

/// Whether an SVG draws anything beyond its background rectangle.
fn draws(svg: &str) -> bool {
    [
        "<line",
        "<polyline",
        "<path",
        "<circle",
        "<text",
        "<polygon",
    ]
    .iter()
    .any(|e| svg.contains(e))
}

/// Chromium's filter sees what a broken page does: an SVG attribute error,
/// a script error and a load blocked by the page's policy.
fn check_error_filter(bin: &Path, work: &Path) {
    let page = work.join("broken.html");
    std::fs::write(
        &page,
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\">\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\
         <title>broken</title></head><body><img src=\"missing.png\" alt=\"\">\
         <svg xmlns=\"http://www.w3.org/2000/svg\"><path d=\"M 0 0 L NaN 3\"/></svg>\
         <script>notAFunction();</script></body></html>",
    )
    .unwrap();
    let run = run_chromium(bin, work, "broken", &["--dump-dom".into(), url(&page)]);
    let errors = page_errors(&run.stderr, "broken.html");
    for what in ["missing.png", "NaN", "Uncaught"] {
        assert!(
            errors.iter().any(|l| l.contains(what)),
            "the error filter misses `{what}` on the broken page; Chromium printed:\n{}",
            run.stderr
        );
    }
}

/// Loads `out/report.html` (DOM dump, and a screenshot when `shot`) and
/// checks it against `out/report.json`; returns the DOM.
fn check_page(bin: &Path, work: &Path, out: &Path, tag: &str, shot: bool) -> String {
    let page = out.join("report.html");
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();

    // The DOM as parsed.
    let run = run_chromium(bin, work, tag, &["--dump-dom".into(), url(&page)]);
    let errors = page_errors(&run.stderr, "report.html");
    assert!(errors.is_empty(), "page errors: {errors:#?}");
    let dom = run.stdout;
    assert!(dom.contains("<html"), "no DOM dumped: {dom:.200}");
    assert!(
        !dom.contains("<script"),
        "the page must work without scripts"
    );
    assert!(dom.contains("default-src 'none'"), "no content policy");
    let svg = svgs(&dom);
    assert_eq!(svg.len(), 3, "trajectory, errors and scale plots");
    assert_eq!(dom.matches("<figure class=\"plot\">").count(), 3);
    assert!(!dom.contains("NaN"), "a NaN reached the page");

    let tables = tables(&dom);
    let summary = table_with(&tables, "errors against the ground truth");
    for (name, e) in report["errors"].as_object().unwrap() {
        let ate = format!("{:.3}", e["ate_rmse_m"].as_f64().unwrap());
        assert!(
            summary.contains(&format!("{name}</td>")) && summary.contains(&ate),
            "summary lacks {name} with ATE {ate}:\n{summary}"
        );
    }
    let counts = table_with(&tables, "samples per stream");
    for (stream, c) in report["counts"].as_object().unwrap() {
        let seen = c["seen"].as_u64().unwrap();
        if seen > 0 {
            assert!(
                counts.contains(&format!("<td>{stream}</td><td class=\"n\">{seen}</td>")),
                "counts lack {stream} seen {seen}:\n{counts}"
            );
        }
    }
    table_with(&tables, "samples per aid");
    let frames = report["frames"].as_array().unwrap();
    let decisions = table_with(&tables, "scale decisions by source");
    assert!(decisions.contains(&format!("over {} frame pairs", frames.len())));
    let events = report["events"].as_array().unwrap();
    if !events.is_empty() {
        let t = table_with(&tables, "events reported by the estimator");
        assert_eq!(t.matches("<tr>").count(), events.len() + 1, "{t}");
    }
    table_with(&tables, "floor surface");
    table_with(&tables, "the filter at the end");
    let expected_tables =
        7 - usize::from(events.is_empty()) + usize::from(report["faults"].is_object());
    assert_eq!(tables.len(), expected_tables);

    // The scale chart draws one point per decision with a scale.
    let scaled = frames.iter().filter(|f| f["scale"].is_number()).count();
    assert!(scaled > 0, "the short run decides a scale");
    assert!(svg[2].matches("<circle").count() >= scaled);

    if shot {
        let png = work.join(format!("{tag}.png"));
        run_chromium(
            bin,
            work,
            &format!("{tag}-shot"),
            &[
                format!("--screenshot={}", png.display()),
                format!("--window-size={WIDTH},{HEIGHT}"),
                url(&page),
            ],
        );
        let img = load_png(&png);
        assert_eq!((img.w, img.h), (WIDTH as usize, HEIGHT as usize));
        let areas = plot_areas(&img);
        assert_eq!(areas.len(), 3, "plot frames found: {areas:?}");
        for (a, svg) in areas.iter().zip(&svg) {
            let ink = ink(&img, a);
            let share = ink as f64 / ((a.x1 - a.x0) * (a.y1 - a.y0)) as f64;
            println!("plot {a:?}: {ink} px of ink ({:.1} %)", 100.0 * share);
            if draws(svg) {
                assert!(share > 0.01, "plot at {a:?} is blank: {ink} px of ink");
            }
        }
        let ekf = count(&img, &areas[0], hex(EKF_COLOUR), 6);
        let truth = count(&img, &areas[0], hex(host_sim::plot::TRUTH_COLOUR), 6);
        println!("top view: {ekf} px of EKF colour, {truth} px of truth colour");
        assert!(ekf >= 30 && truth >= 30, "top view without EKF or truth");
        if svg[1].contains(EKF_COLOUR) {
            let ekf = count(&img, &areas[1], hex(EKF_COLOUR), 6);
            println!("errors plot: {ekf} px of EKF colour");
            assert!(ekf >= 30, "errors plot draws the EKF but shows none");
        }
        let fused = count(&img, &areas[2], hex("#9467bd"), 6);
        println!("scale chart: {fused} px of the fused colour");
        assert!(fused >= 100, "scale chart without its fused decisions");
    }
    dom
}

#[test]
fn report_html_renders_in_headless_chromium() {
    let Some(bin) = chromium() else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set and chromium is not installed (apt-get install chromium)"
        );
        eprintln!("skipped: chromium is not installed (apt-get install chromium)");
        return;
    };
    let root = tmp("report-html");
    let work = root.join("chromium");
    std::fs::create_dir_all(&work).unwrap();
    check_error_filter(&bin, &work);

    let plain = root.join("plain");
    run_simulate("short", 1, &plain, false).unwrap();
    let dom = check_page(&bin, &work, &plain, "plain", true);
    assert!(dom.contains("short"), "the header names the scenario");
    assert!(!dom.contains("<section id=\"faults\">"));

    let faulty = root.join("faults");
    let plan: FaultPlan = "imu-nan@2x3,wheel-outlier@4x2".parse().unwrap();
    run_simulate_faults("short", 1, &faulty, false, &plan).unwrap();
    let dom = check_page(&bin, &work, &faulty, "faults", false);
    let t = tables(&dom);
    let faults = table_with(&t, "injected faults");
    for f in ["imu-nan@2x3", "wheel-outlier@4x2"] {
        assert!(faults.contains(f), "faults table lacks {f}:\n{faults}");
    }
    let _ = std::fs::remove_dir_all(&root);
}
