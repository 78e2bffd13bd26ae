//! Homography estimation and decomposition timings.
//!
//! Goals (issue): RANSAC on 100 correspondences with 20 % outliers and 1 px
//! noise <= 100 us (OpenCV `findHomography` ~200 us on the same data);
//! decomposition <= 5 us. Inputs are seeded and made outside the timer.
//!
//! The scene, the true inlier set and ours are written to
//! `target/peer/homography_scene.txt` so that `benches/peer/opencv_homography.py`
//! runs OpenCV on exactly the same data (`benches/peer/run_homography_peer.sh`
//! runs both and prints the side-by-side table).

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use proptest::prelude::Rng;
use proptest::test_runner::{RngAlgorithm, TestRng};
use std::hint::black_box;
use vslam_core::decompose::{NormalPrior, PinholeIntrinsics, SelectParams, decompose};
use vslam_core::homography::{Homography, HomographyRansac, RansacParams, dlt, from_four_points};

type V2 = Vector2<f32>;

struct Scene {
    k: PinholeIntrinsics,
    h: Matrix3<f32>,
    points1: Vec<V2>,
    points2: Vec<V2>,
    inliers: Vec<bool>,
}

fn uniform(rng: &mut TestRng) -> f32 {
    (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn gauss(rng: &mut TestRng) -> f32 {
    let u1 = uniform(rng).max(1e-7);
    let u2 = uniform(rng);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f32::consts::PI * u2).cos()
}

/// 100 correspondences of a ceiling under a mixed motion, 20 % outliers
/// uniform in the image, 1 px Gaussian noise on the inliers.
fn scene() -> Scene {
    let mut rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]);
    let k = PinholeIntrinsics::new(420.0, 410.0, 320.0, 240.0).unwrap();
    let r = Rotation3::from_euler_angles(0.05, -0.03, 0.25);
    let n = Vector3::new(0.05, -0.1, 1.0).normalize();
    let t = Vector3::new(0.12, -0.08, 0.05) / 2.0;
    let h = k.matrix() * (r.matrix() + t * n.transpose()) * k.inverse_matrix();
    let (mut points1, mut points2, mut inliers) = (Vec::new(), Vec::new(), Vec::new());
    while points1.len() < 100 {
        let p = V2::new(640.0 * uniform(&mut rng), 480.0 * uniform(&mut rng));
        let y = h * Vector3::new(p.x, p.y, 1.0);
        let q = V2::new(y.x / y.z, y.y / y.z);
        if !(0.0..640.0).contains(&q.x) || !(0.0..480.0).contains(&q.y) {
            continue;
        }
        let outlier = points1.len() % 5 == 0;
        let q = if outlier {
            V2::new(640.0 * uniform(&mut rng), 480.0 * uniform(&mut rng))
        } else {
            q + V2::new(gauss(&mut rng), gauss(&mut rng))
        };
        points1.push(p);
        points2.push(q);
        inliers.push(!outlier);
    }
    Scene {
        k,
        h,
        points1,
        points2,
        inliers,
    }
}

/// Writes the scene for the OpenCV peer: `K fx fy cx cy`, `H` (row-major),
/// `RANSAC threshold`, then one line per match: `x1 y1 x2 y2 true_inlier our_inlier`.
fn write_peer_scene(s: &Scene, ours: &[bool], threshold: f32) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/peer");
    std::fs::create_dir_all(&dir)?;
    let k = s.k.matrix();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "K {} {} {} {}",
        k[(0, 0)],
        k[(1, 1)],
        k[(0, 2)],
        k[(1, 2)]
    );
    let h: Vec<String> = (0..9)
        .map(|i| format!("{:e}", s.h[(i / 3, i % 3)]))
        .collect();
    let _ = writeln!(out, "H {}", h.join(" "));
    let _ = writeln!(out, "threshold {threshold}");
    for (((a, b), t), o) in s.points1.iter().zip(&s.points2).zip(&s.inliers).zip(ours) {
        let _ = writeln!(
            out,
            "{} {} {} {} {} {}",
            a.x, a.y, b.x, b.y, *t as u8, *o as u8
        );
    }
    std::fs::write(dir.join("homography_scene.txt"), out)
}

fn bench(c: &mut Criterion) {
    let s = scene();
    let mut ransac = HomographyRansac::<128>::new(RansacParams {
        threshold_px: 3.0,
        seed: 1,
        ..RansacParams::default()
    })
    .unwrap();
    let mut mask = vec![false; s.points1.len()];
    let report = ransac.estimate(&s.points1, &s.points2, &mut mask).unwrap();
    eprintln!(
        "ransac: {} inliers of {}, {} samples, rms {:.2} px, {} LM iterations",
        report.inlier_count,
        report.point_count,
        report.iterations,
        report.rms_error_px,
        report.refine_iterations
    );
    let same = mask.iter().zip(&s.inliers).filter(|(a, b)| a == b).count();
    eprintln!(
        "ransac: inlier set equals the true one on {same} of {} matches",
        mask.len()
    );
    if let Err(e) = write_peer_scene(&s, &mask, 3.0) {
        eprintln!("could not write the peer scene: {e}");
    }
    c.bench_function("homography/ransac_100_20pct_outliers", |b| {
        b.iter(|| {
            ransac
                .estimate(black_box(&s.points1), black_box(&s.points2), &mut mask)
                .unwrap()
        })
    });

    let mut no_refine = HomographyRansac::<128>::new(RansacParams {
        threshold_px: 3.0,
        seed: 1,
        refine: false,
        ..RansacParams::default()
    })
    .unwrap();
    c.bench_function("homography/ransac_100_20pct_outliers_no_lm", |b| {
        b.iter(|| {
            no_refine
                .estimate(black_box(&s.points1), black_box(&s.points2), &mut mask)
                .unwrap()
        })
    });

    // The normalised DLT on 100 inliers: the inliers plus 20 more of the same scene.
    let mut p1: Vec<V2> = Vec::new();
    let mut p2: Vec<V2> = Vec::new();
    for ((a, b), inl) in s.points1.iter().zip(&s.points2).zip(&s.inliers) {
        if *inl {
            p1.push(*a);
            p2.push(*b);
        }
    }
    let mut i = 0.0f32;
    while p1.len() < 100 {
        let p = V2::new(30.0 + 5.7 * i, 40.0 + 4.1 * i);
        let y = s.h * Vector3::new(p.x, p.y, 1.0);
        p1.push(p);
        p2.push(V2::new(y.x / y.z, y.y / y.z));
        i += 1.0;
    }
    c.bench_function("homography/dlt_100_inliers", |b| {
        b.iter(|| dlt(black_box(&p1), black_box(&p2)).unwrap())
    });

    let q1 = [p1[0], p1[10], p1[20], p1[30]];
    let q2 = [p2[0], p2[10], p2[20], p2[30]];
    c.bench_function("homography/four_point", |b| {
        b.iter(|| from_four_points(black_box(&q1), black_box(&q2)).unwrap())
    });

    let h = Homography::from_matrix(&s.h).unwrap();
    c.bench_function("homography/decompose", |b| {
        b.iter(|| decompose(black_box(&h), black_box(&s.k)).unwrap())
    });

    let prior = NormalPrior::new(&Vector3::z(), 0.35).unwrap();
    let params = SelectParams {
        prior: Some(prior),
        ..SelectParams::default()
    };
    c.bench_function("homography/decompose_and_select_80_points", |b| {
        b.iter(|| {
            let dec = decompose(black_box(&h), &s.k).unwrap();
            dec.select(black_box(&p1[..80]), &[], &params).unwrap()
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
