//! Homography estimation and decomposition entry points on fuzzed
//! correspondences: the four-point solver, the normalised DLT, RANSAC (with
//! and without refinement), Levenberg-Marquardt refinement, the pixel and
//! calibrated decompositions and the candidate selection.
//!
//! The first byte picks how numbers are read: raw `f32` bit patterns (NaN,
//! infinities, subnormals) or small integers on a pixel grid (the geometry
//! RANSAC and the decomposition actually see, degenerate cases included).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nalgebra::Matrix3;
use vslam_core::decompose::{
    NormalPrior, PinholeIntrinsics, SelectParams, decompose, decompose_calibrated,
};
use vslam_core::geometry::{Vec2, Vec3};
use vslam_core::homography::{
    Homography, HomographyRansac, RansacParams, RefineParams, dlt, dlt_masked, from_four_points,
    refine_homography,
};

const CAPACITY: usize = 48;

fn numbers(raw: bool, data: &[u8]) -> Vec<f32> {
    if raw {
        data.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    } else {
        data.chunks_exact(2)
            .map(|c| f32::from(i16::from_le_bytes([c[0], c[1]])) / 64.0)
            .collect()
    }
}

/// A valid homography is finite with unit Frobenius norm and `det > 0`.
fn check(h: &Homography) {
    let m = h.matrix();
    assert!(m.iter().all(|v| v.is_finite()), "{m}");
    assert!((m.norm() - 1.0).abs() < 1e-3, "{m}");
    assert!(m.determinant() > 0.0, "{m}");
}

fn check_decompositions(h: &Homography, points1: &[Vec2], inliers: &[bool]) {
    let Ok(k) = PinholeIntrinsics::new(400.0, 400.0, 320.0, 240.0) else {
        return;
    };
    let Ok(d) = decompose(h, &k) else {
        return;
    };
    assert!(!d.candidates().is_empty() && d.candidates().len() <= 4);
    for c in d.candidates() {
        let r = c.rotation.matrix();
        assert!(r.iter().all(|v| v.is_finite()));
        assert!((r.determinant() - 1.0).abs() < 1e-3, "{r}");
        assert!(c.translation_over_distance.iter().all(|v| v.is_finite()));
        assert!(c.normal.iter().all(|v| v.is_finite()));
    }
    let Ok(prior) = NormalPrior::new(&Vec3::z(), 0.5) else {
        return;
    };
    for prior in [None, Some(prior)] {
        let params = SelectParams {
            prior,
            ..SelectParams::default()
        };
        if let Ok(s) = d.select(points1, inliers, &params) {
            assert!(d.selected(&s).is_some());
            assert!(s.in_front <= s.points);
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let v = numbers(mode & 1 == 1, rest);

    // The calibrated decomposition of any 3x3 matrix.
    if let Some(m9) = v.get(..9) {
        let m = Matrix3::from_row_slice(m9);
        if let Ok(d) = decompose_calibrated(&m, 1e-4) {
            assert!(
                d.candidates()
                    .iter()
                    .all(|c| c.homography().iter().all(|x| x.is_finite()))
            );
        }
        if let Ok(h) = Homography::from_matrix(&m) {
            check(&h);
            check_decompositions(&h, &[], &[]);
        }
    }

    let points: Vec<(Vec2, Vec2)> = v
        .chunks_exact(4)
        .take(CAPACITY)
        .map(|c| (Vec2::new(c[0], c[1]), Vec2::new(c[2], c[3])))
        .collect();
    let p1: Vec<Vec2> = points.iter().map(|p| p.0).collect();
    let p2: Vec<Vec2> = points.iter().map(|p| p.1).collect();

    if let (Some(a), Some(b)) = (p1.first_chunk::<4>(), p2.first_chunk::<4>())
        && let Ok(h) = from_four_points(a, b)
    {
        check(&h);
    }
    if let Ok(h) = dlt(&p1, &p2) {
        check(&h);
        let mask: Vec<bool> = (0..p1.len()).map(|i| (mode >> (i % 7)) & 1 == 0).collect();
        if let Ok(hm) = dlt_masked(&p1, &p2, &mask) {
            check(&hm);
        }
        let params = RefineParams {
            max_iterations: 10,
            ..RefineParams::default()
        };
        if let Ok(r) = refine_homography(&h, &p1, &p2, &[], &params) {
            check(&r.homography);
            // Never worse than where it started.
            assert!(
                !(r.final_rms_px > r.initial_rms_px * (1.0 + 1e-4) + 1e-6),
                "{r:?}"
            );
        }
    }

    let params = RansacParams {
        seed: u64::from(mode),
        refine: mode & 2 == 0,
        max_iterations: 200,
        min_inliers: 4 + usize::from(mode >> 5),
        ..RansacParams::default()
    };
    let Ok(mut ransac) = HomographyRansac::<CAPACITY>::new(params) else {
        return;
    };
    let mut inliers = vec![false; p1.len()];
    match ransac.estimate(&p1, &p2, &mut inliers) {
        Ok(report) => {
            check(&report.homography);
            assert_eq!(report.inlier_count, inliers.iter().filter(|&&m| m).count());
            assert!(report.inlier_count >= params.min_inliers);
            assert!(report.iterations <= params.max_iterations);
            assert!(report.rms_error_px.is_finite());
            check_decompositions(&report.homography, &p1, &inliers);
        }
        Err(_) => assert!(inliers.iter().all(|&m| !m)),
    }
});
