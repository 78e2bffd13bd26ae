//! Properties of the homography estimators (seeded proptest).

use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use vslam_core::homography::{
    Homography, HomographyRansac, RansacParams, RefineParams, dlt, from_four_points,
    refine_homography,
};

type V2 = Vector2<f32>;

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x7472_6163),
        failure_persistence: None,
        max_global_rejects: 20_000,
        ..Config::default()
    }
}

fn point() -> impl Strategy<Value = V2> {
    (0.0f32..1000.0, 0.0f32..800.0).prop_map(|(x, y)| V2::new(x, y))
}

/// Smallest doubled triangle area over the four triples, relative to the
/// squared size of the set: 0 for collinear or repeated points.
fn spread(p: &[V2; 4]) -> f32 {
    let area = |a: &V2, b: &V2, c: &V2| ((b - a).perp(&(c - a))).abs();
    let tri = [
        area(&p[0], &p[1], &p[2]),
        area(&p[0], &p[1], &p[3]),
        area(&p[0], &p[2], &p[3]),
        area(&p[1], &p[2], &p[3]),
    ];
    let mut size: f32 = 0.0;
    for i in 0..4 {
        for j in 0..4 {
            size = size.max((p[i] - p[j]).norm_squared());
        }
    }
    tri.iter().fold(f32::INFINITY, |m, v| m.min(*v)) / size.max(1e-30)
}

/// A float that is sometimes NaN, infinite, huge or tiny.
fn wild() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => 0.0f32..640.0,
        1 => any::<f32>(),
        1 => -1e30f32..1e30,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(-0.0f32),
    ]
}

fn check_valid(h: &Homography) {
    let m = h.matrix();
    assert!(m.iter().all(|v| v.is_finite()));
    assert!((m.norm() - 1.0).abs() < 1e-4);
    assert!(m.determinant() > 0.0);
}

proptest! {
    #![proptest_config(config(512))]

    /// Any four non-degenerate correspondences are mapped onto each other.
    #[test]
    fn four_points_map_back(
        a in [point(), point(), point(), point()],
        b in [point(), point(), point(), point()],
    ) {
        prop_assume!(spread(&a) > 0.02 && spread(&b) > 0.02);
        let h = from_four_points(&a, &b).unwrap();
        check_valid(&h);
        for (p, q) in a.iter().zip(b.iter()) {
            let r = h.transfer(p).unwrap();
            prop_assert!((r - q).norm() < 0.05, "{p:?} -> {r:?}, want {q:?}");
        }
    }

    /// The DLT reproduces a homography of a real plane from exact points.
    #[test]
    fn dlt_maps_exact_points_back(
        rpy in prop::array::uniform3(-0.4f32..0.4),
        t in prop::array::uniform3(-0.5f32..0.5),
        pts in prop::collection::vec(point(), 6..60),
    ) {
        let k = Matrix3::new(500.0, 0.0, 500.0, 0.0, 500.0, 400.0, 0.0, 0.0, 1.0);
        let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        let he = r.matrix() + Vector3::from(t) * Vector3::z().transpose() / 2.0;
        let truth = k * he * k.try_inverse().unwrap();
        let map = |p: &V2| {
            let y = truth * Vector3::new(p.x, p.y, 1.0);
            V2::new(y.x / y.z, y.y / y.z)
        };
        let a: Vec<V2> = pts.iter().copied().filter(|p| (truth * Vector3::new(p.x, p.y, 1.0)).z > 0.2).collect();
        prop_assume!(a.len() >= 6);
        let b: Vec<V2> = a.iter().map(map).collect();
        prop_assume!(b.iter().all(|q| q.norm() < 5000.0));
        let est = dlt(&a, &b).unwrap();
        check_valid(&est);
        for (p, q) in a.iter().zip(b.iter()) {
            let r = est.transfer(p).unwrap();
            prop_assert!((r - q).norm() < 1e-3 * (1.0 + q.norm()), "{p:?} -> {r:?}, want {q:?}");
        }
    }

    /// No input makes an estimator panic; whatever it returns as a homography
    /// is a valid one.
    #[test]
    fn estimators_never_panic(
        a in prop::collection::vec((wild(), wild()), 0..40),
        b in prop::collection::vec((wild(), wild()), 0..40),
        seed in any::<u64>(),
        threshold in prop_oneof![0.1f32..10.0, Just(f32::NAN), Just(1e30f32)],
    ) {
        let n = a.len().min(b.len());
        let a: Vec<V2> = a.iter().take(n).map(|(x, y)| V2::new(*x, *y)).collect();
        let b: Vec<V2> = b.iter().take(n).map(|(x, y)| V2::new(*x, *y)).collect();
        if let Ok(h) = dlt(&a, &b) {
            check_valid(&h);
            let _ = refine_homography(&h, &a, &b, &[], &RefineParams::default());
            let _ = h.inverse();
        }
        if n >= 4 {
            let a4 = [a[0], a[1], a[2], a[3]];
            let b4 = [b[0], b[1], b[2], b[3]];
            if let Ok(h) = from_four_points(&a4, &b4) {
                check_valid(&h);
            }
        }
        let params = RansacParams { threshold_px: threshold, seed, max_iterations: 200, ..RansacParams::default() };
        if let Ok(mut r) = HomographyRansac::<40>::new(params) {
            let mut mask = vec![false; n];
            match r.estimate(&a, &b, &mut mask) {
                Ok(rep) => {
                    check_valid(&rep.homography);
                    prop_assert!(rep.inlier_count >= params.min_inliers);
                    prop_assert_eq!(rep.inlier_count, mask.iter().filter(|m| **m).count());
                }
                Err(_) => prop_assert!(mask.iter().all(|m| !*m)),
            }
        }
    }

    /// Homography::from_matrix and transfer never panic.
    #[test]
    fn matrices_never_panic(m in prop::array::uniform9(wild()), p in (wild(), wild())) {
        let m = Matrix3::from_row_slice(&m);
        if let Ok(h) = Homography::from_matrix(&m) {
            check_valid(&h);
            if let Some(q) = h.transfer(&V2::new(p.0, p.1)) {
                prop_assert!(q.x.is_finite() && q.y.is_finite());
            }
        }
    }
}
