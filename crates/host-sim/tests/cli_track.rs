//! `host-sim track IMG1 IMG2`: run as a program on a real photograph and a
//! copy warped by a known homography.

use host_sim::pngio::{GrayImage, load_gray, save_gray};
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use std::path::Path;
use std::process::{Command, Output};

const W: usize = 320;
const H: usize = 240;
/// Top-left corner of the crop in the 512x512 photograph.
const ORIGIN: (f64, f64) = (96.0, 136.0);

/// A scratch folder for one test, removed when it is dropped unless `KEEP`
/// is set (to rerun the program on its files).
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("host-sim-cli-t-{name}-"))
        .disable_cleanup(std::env::var_os("KEEP").is_some())
        .tempdir()
        .unwrap()
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .unwrap()
}

fn photo() -> GrayImage {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/images/camera.png");
    load_gray(&p).unwrap()
}

/// Bilinear sample of `img` at `(x, y)`, edges clamped.
fn bilinear(img: &GrayImage, x: f64, y: f64) -> f64 {
    let x = x.clamp(0.0, (img.width - 1) as f64);
    let y = y.clamp(0.0, (img.height - 1) as f64);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(img.width - 1), (y0 + 1).min(img.height - 1));
    let (ax, ay) = (x - x0 as f64, y - y0 as f64);
    let px = |x: usize, y: usize| img.data[y * img.width + x] as f64;
    (1.0 - ay) * ((1.0 - ax) * px(x0, y0) + ax * px(x1, y0))
        + ay * ((1.0 - ax) * px(x0, y1) + ax * px(x1, y1))
}

fn apply(h: &Matrix3<f64>, x: f64, y: f64) -> (f64, f64) {
    let p = h * Vector3::new(x, y, 1.0);
    (p.x / p.z, p.y / p.z)
}

/// IMG1 = the crop at [`ORIGIN`]; IMG2(x2) = IMG1(H^-1 x2), sampled from the
/// whole photograph so that IMG2 has real content up to its edges.
fn image_pair(h: &Matrix3<f64>) -> (GrayImage, GrayImage) {
    let full = photo();
    let inv = h.try_inverse().unwrap();
    let render = |map: &dyn Fn(f64, f64) -> (f64, f64)| {
        let mut data = Vec::with_capacity(W * H);
        for y in 0..H {
            for x in 0..W {
                let (u, v) = map(x as f64, y as f64);
                data.push(bilinear(&full, u + ORIGIN.0, v + ORIGIN.1).round() as u8);
            }
        }
        GrayImage {
            width: W,
            height: H,
            data,
        }
    };
    (render(&|x, y| (x, y)), render(&|x, y| apply(&inv, x, y)))
}

fn save_pair(dir: &Path, h: &Matrix3<f64>) -> (String, String) {
    let (a, b) = image_pair(h);
    let (pa, pb) = (dir.join("img1.png"), dir.join("img2.png"));
    save_gray(&pa, &a).unwrap();
    save_gray(&pb, &b).unwrap();
    (
        pa.to_str().unwrap().to_owned(),
        pb.to_str().unwrap().to_owned(),
    )
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn track_json(args: &[&str]) -> serde_json::Value {
    let out = run(args);
    assert!(
        out.status.success(),
        "exit {:?}: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Largest distance between where `est` and `truth` put the image corners.
fn corner_transfer_error(est: &Matrix3<f64>, truth: &Matrix3<f64>) -> f64 {
    let (w, h) = ((W - 1) as f64, (H - 1) as f64);
    [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .iter()
        .map(|&(x, y)| {
            let (a, b) = (apply(est, x, y), apply(truth, x, y));
            ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
}

#[test]
fn recovers_a_known_homography() {
    // 2.5 degrees and 2 % scale about the centre, a shift and some
    // perspective: small enough that few corners leave the image.
    let c = Matrix3::new(1.0, 0.0, 160.0, 0.0, 1.0, 120.0, 0.0, 0.0, 1.0);
    let (s, t) = (
        1.02 * 2.5f64.to_radians().sin(),
        1.02 * 2.5f64.to_radians().cos(),
    );
    let a = Matrix3::new(t, -s, 5.0, s, t, -3.0, 0.0, 0.0, 1.0);
    let p = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 2e-5, -1e-5, 1.0);
    let truth = p * c * a * c.try_inverse().unwrap();

    let scratch = temp_dir("known");
    let dir = scratch.path();
    let (i1, i2) = save_pair(dir, &truth);
    let v = track_json(&["track", &i1, &i2, "--json"]);

    let h = numbers(&v["homography"]);
    assert_eq!(h.len(), 9);
    let est = Matrix3::from_row_slice(&h);
    let err = corner_transfer_error(&est, &truth);
    let tracks = v["tracks"].as_array().unwrap();
    let tracked = tracks.iter().filter(|t| t[4].as_u64() == Some(1)).count();
    let inliers = v["inliers"].as_u64().unwrap() as usize;
    eprintln!(
        "known H: corner transfer error {err:.4} px, {tracked}/{} tracked, {inliers} inliers",
        tracks.len()
    );
    assert!(err < 1.0, "corner transfer error {err} px");
    assert!(
        tracks.len() >= 50 && tracks.len() <= 200,
        "{} tracks",
        tracks.len()
    );
    assert!(tracked * 10 >= tracks.len() * 9, "{tracked} tracked");
    assert!(inliers >= 50 && inliers <= tracked, "{inliers} inliers");
    // Every tracked inlier-quality track agrees with the truth.
    let close = tracks
        .iter()
        .filter(|t| t[4].as_u64() == Some(1))
        .filter(|t| {
            let (u, v) = apply(&truth, t[0].as_f64().unwrap(), t[1].as_f64().unwrap());
            ((u - t[2].as_f64().unwrap()).powi(2) + (v - t[3].as_f64().unwrap()).powi(2)).sqrt()
                < 1.0
        })
        .count();
    assert!(close >= inliers * 9 / 10, "{close} tracks within 1 px");
    // Without intrinsics nothing is decomposed.
    assert_eq!(v["decompositions"], serde_json::json!([]));
    assert!(v["selected"].is_null());
    // The summary says the same.
    let out = run(&["track", &i1, &i2]);
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(
        s.contains(&format!("{} corners, {tracked} tracked", tracks.len())),
        "{s}"
    );
    assert!(s.contains(&format!("homography: {inliers} inliers")), "{s}");
    assert!(s.contains("decomposition: not computed"), "{s}");
    // Fixed seed: the same files give the same output.
    let again = run(&["track", &i1, &i2, "--json"]);
    assert_eq!(
        serde_json::from_slice::<serde_json::Value>(&again.stdout).unwrap(),
        v
    );
}

/// Angle of `a^T b`, degrees.
fn rotation_angle_deg(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let m = a.transpose() * b;
    ((m.trace() - 1.0) / 2.0)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

#[test]
fn decomposes_a_plane_induced_homography() {
    let (fu, fv, cu, cv) = (300.0, 300.0, 160.0, 120.0);
    let k = Matrix3::new(fu, 0.0, cu, 0.0, fv, cv, 0.0, 0.0, 1.0);
    let axis = Unit::new_normalize(Vector3::new(0.2, 1.0, 0.1));
    let r = Rotation3::from_axis_angle(&axis, 3f64.to_radians()).into_inner();
    let t_over_d = Vector3::new(0.06, -0.02, 0.03);
    let n = Vector3::new(0.05, -0.1, 1.0).normalize();
    let truth = k * (r + t_over_d * n.transpose()) * k.try_inverse().unwrap();

    let scratch = temp_dir("plane");
    let dir = scratch.path();
    let (i1, i2) = save_pair(dir, &truth);
    let intr = format!("{fu},{fv},{cu},{cv}");
    let v = track_json(&["track", &i1, &i2, "--intrinsics", &intr, "--json"]);

    let est = Matrix3::from_row_slice(&numbers(&v["homography"]));
    let h_err = corner_transfer_error(&est, &truth);
    let cands = v["decompositions"].as_array().unwrap();
    assert_eq!(cands.len(), 4, "{v}");
    let errors: Vec<(f64, f64, f64)> = cands
        .iter()
        .map(|c| {
            let rc = Matrix3::from_row_slice(&numbers(&c["R"]));
            let tc = Vector3::from_row_slice(&numbers(&c["t"]));
            let nc = Vector3::from_row_slice(&numbers(&c["n"]));
            (
                rotation_angle_deg(&rc, &r),
                (tc - t_over_d).norm(),
                nc.angle(&n).to_degrees(),
            )
        })
        .collect();
    let best = (0..4)
        .min_by(|&a, &b| errors[a].1.total_cmp(&errors[b].1))
        .unwrap();
    let (dr, dt, dn) = errors[best];
    eprintln!(
        "plane H: corner transfer error {h_err:.4} px, {} inliers; best candidate #{best}: \
         R off {dr:.4} deg, |t/d error| {dt:.5}, n off {dn:.3} deg; selected {}",
        v["inliers"], v["selected"]
    );
    assert!(h_err < 1.0, "corner transfer error {h_err} px");
    assert!(dr < 0.3, "R off by {dr} deg");
    assert!(dt < 0.006, "t/d off by {dt}");
    assert!(dn < 3.0, "n off by {dn} deg");
    // `selected` is null or a valid index; if the depth test alone decided,
    // it chose the true motion.
    match v["selected"].as_u64() {
        None => assert!(v["selected"].is_null()),
        Some(i) => assert_eq!(i as usize, best),
    }
    // A ceiling prior decides: the true candidate.
    let v = track_json(&[
        "track",
        &i1,
        &i2,
        "--intrinsics",
        &intr,
        "--normal",
        "0,0,1",
        "--json",
    ]);
    assert_eq!(
        v["selected"].as_u64(),
        Some(best as u64),
        "{}",
        v["selected"]
    );
    // The summary names the selected candidate.
    let out = run(&[
        "track",
        &i1,
        &i2,
        "--intrinsics",
        &intr,
        "--normal",
        "0,0,1",
    ]);
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains(&format!("selected: #{best}")), "{s}");
}

#[test]
fn bad_files_exit_2_naming_the_file() {
    let scratch = temp_dir("bad");
    let dir = scratch.path();
    let good = dir.join("good.png");
    save_gray(&good, &image_pair(&Matrix3::identity()).0).unwrap();
    let good = good.to_str().unwrap();

    let missing = dir.join("missing.png");
    let out = run(&["track", good, missing.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.png"));
    assert!(out.stdout.is_empty());

    let text = dir.join("text.png");
    std::fs::write(&text, "this is not an image\n").unwrap();
    let out = run(&["track", text.to_str().unwrap(), good]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("text.png"));
    assert!(out.stdout.is_empty());

    let small = dir.join("small.png");
    save_gray(
        &small,
        &GrayImage {
            width: 64,
            height: 48,
            data: vec![128; 64 * 48],
        },
    )
    .unwrap();
    let out = run(&["track", good, small.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("small.png") && err.contains("64x48"), "{err}");
}

#[test]
fn no_texture_is_no_result_without_output() {
    let scratch = temp_dir("flat");
    let dir = scratch.path();
    let flat = dir.join("flat.png");
    save_gray(
        &flat,
        &GrayImage {
            width: W,
            height: H,
            data: vec![90; W * H],
        },
    )
    .unwrap();
    let f = flat.to_str().unwrap();
    let out = run(&["track", f, f, "--json"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    assert!(!out.stderr.is_empty());
}

#[test]
fn help_documents_the_json_without_intrinsics() {
    let out = run(&["track", "--help"]);
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(
        s.contains("\"decompositions\": [] and \"selected\": null"),
        "{s}"
    );
    assert!(s.contains("--intrinsics <fu,fv,cu,cv>"), "{s}");
}
