//! `host-sim homography MATCHES`: run as a program on files written here.

use nalgebra::{Matrix3, Vector3};
use std::process::{Command, Output};

/// A scratch folder for one test, removed when it is dropped.
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("host-sim-cli-h-{name}-"))
        .tempdir()
        .unwrap()
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .unwrap()
}

fn true_h() -> Matrix3<f64> {
    Matrix3::new(1.02, -0.05, 12.0, 0.04, 0.98, -7.0, 1.5e-4, -8e-5, 1.0)
}

fn apply(h: &Matrix3<f64>, x: f64, y: f64) -> (f64, f64) {
    let p = h * Vector3::new(x, y, 1.0);
    (p.x / p.z, p.y / p.z)
}

/// 30 exact matches of [`true_h`] and 8 gross outliers, interleaved; returns
/// the file text and the inlier flags.
fn matches_file() -> (String, Vec<u8>) {
    let h = true_h();
    let mut text = String::from("# x1 y1 x2 y2\n");
    let mut flags = Vec::new();
    for i in 0..30 {
        let (x, y) = (20.0 + 57.0 * (i % 6) as f64, 15.0 + 49.0 * (i / 6) as f64);
        let (u, v) = apply(&h, x, y);
        text += &format!("{x} {y}, {u:.5},{v:.5}\n");
        flags.push(1);
        if i % 4 == 1 && flags.iter().filter(|f| **f == 0).count() < 8 {
            // An outlier: 40 to 110 px away from where H puts it.
            let k = flags.len() as f64;
            let (ox, oy) = (40.0 + 9.0 * k, if i % 8 == 1 { 35.0 } else { -50.0 });
            text += &format!(
                "{} {} {:.5} {:.5}  # outlier\n",
                x + 3.0,
                y + 2.0,
                u + ox,
                v + oy
            );
            flags.push(0);
        }
    }
    // Fill up to 8 outliers at the end.
    while flags.iter().filter(|f| **f == 0).count() < 8 {
        let k = flags.len() as f64;
        text += &format!(
            "{} {} {} {}\n",
            5.0 * k,
            300.0 - 3.0 * k,
            200.0 - k,
            7.0 * k
        );
        flags.push(0);
    }
    (text, flags)
}

#[test]
fn recovers_h_and_exact_inlier_flags() {
    let scratch = temp_dir("ok");
    let dir = scratch.path();
    let path = dir.join("matches.txt");
    let (text, flags) = matches_file();
    assert_eq!(flags.iter().filter(|f| **f == 1).count(), 30);
    assert_eq!(flags.iter().filter(|f| **f == 0).count(), 8);
    std::fs::write(&path, text).unwrap();
    let out = run(&["homography", path.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let inliers: Vec<u8> = v["inliers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as u8)
        .collect();
    assert_eq!(inliers, flags);
    let h: Vec<f64> = v["homography"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(h.len(), 9);
    let est = Matrix3::from_row_slice(&h);
    let truth = true_h();
    for (x, y) in [(0.0, 0.0), (320.0, 0.0), (0.0, 240.0), (320.0, 240.0)] {
        let (a, b) = (apply(&est, x, y), apply(&truth, x, y));
        let err = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
        assert!(err < 0.01, "corner ({x}, {y}) off by {err} px");
    }
    // Deterministic: the same file gives the same bytes.
    let again = run(&["homography", path.to_str().unwrap(), "--json"]);
    assert_eq!(again.stdout, out.stdout);
    // A threshold below the outliers' distance but with all-exact inliers
    // changes nothing; the summary form names the counts.
    let human = run(&["homography", path.to_str().unwrap(), "--threshold", "1"]);
    assert!(human.status.success());
    let s = String::from_utf8_lossy(&human.stdout);
    assert!(s.contains("38 matches, 30 inliers"), "{s}");
}

#[test]
fn malformed_line_names_file_and_line() {
    let scratch = temp_dir("bad");
    let dir = scratch.path();
    let path = dir.join("bad.txt");
    std::fs::write(&path, "# header\n1 2 3 4\n1 2 x 4\n5 6 7 8\n").unwrap();
    let out = run(&["homography", path.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.txt:3:"), "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn too_few_matches_is_no_result() {
    let scratch = temp_dir("few");
    let dir = scratch.path();
    let path = dir.join("three.txt");
    std::fs::write(&path, "0 0 1 1\n10 0 11 1\n0 10 1 11\n").unwrap();
    let out = run(&["homography", path.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("at least 4"), "{err}");
    assert!(err.contains("three.txt"), "{err}");
    assert!(out.stdout.is_empty());
    // Missing file: bad input.
    let missing = dir.join("missing.txt");
    let out = run(&["homography", missing.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.txt"));
}

#[test]
fn collinear_matches_are_no_result() {
    let scratch = temp_dir("line");
    let dir = scratch.path();
    let path = dir.join("line.txt");
    let text: String = (0..12)
        .map(|i| format!("{} {} {} {}\n", 10 * i, 5 * i, 10 * i + 3, 5 * i + 1))
        .collect();
    std::fs::write(&path, text).unwrap();
    let out = run(&["homography", path.to_str().unwrap(), "--json"]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stdout.is_empty());
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("host-sim: no homography"));
}
