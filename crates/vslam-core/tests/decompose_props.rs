//! Properties of the homography decomposition (seeded proptest).

use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use vslam_core::decompose::{
    NormalPrior, PURE_ROTATION_TOLERANCE, SelectParams, decompose_calibrated,
};

type V3 = Vector3<f32>;

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x6465_636f),
        failure_persistence: None,
        max_global_rejects: 20_000,
        ..Config::default()
    }
}

fn wild() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -2.0f32..2.0,
        1 => any::<f32>(),
        1 => -1e30f32..1e30,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(0.0f32),
    ]
}

fn is_proper_rotation(r: &Matrix3<f32>) -> bool {
    r.iter().all(|v| v.is_finite())
        && (r.determinant() - 1.0).abs() < 1e-4
        && (r.transpose() * r - Matrix3::identity()).amax() < 1e-4
}

fn rotation_error(a: &Matrix3<f32>, b: &Matrix3<f32>) -> f32 {
    let d = a.transpose() * b;
    let skew = V3::new(
        d[(2, 1)] - d[(1, 2)],
        d[(0, 2)] - d[(2, 0)],
        d[(1, 0)] - d[(0, 1)],
    );
    (0.5 * skew.norm()).atan2(0.5 * (d.trace() - 1.0))
}

proptest! {
    #![proptest_config(config(512))]

    /// Every candidate of every valid homography has a proper rotation, and
    /// one of them is the true motion.
    #[test]
    fn valid_homographies_give_proper_rotations(
        rpy in prop::array::uniform3(-1.0f32..1.0),
        t in prop::array::uniform3(-1.0f32..1.0),
        n in prop::array::uniform3(-1.0f32..1.0),
        d in 0.5f32..5.0,
        scale in prop_oneof![-10.0f32..-0.1, 0.1f32..10.0],
    ) {
        let n = V3::from(n);
        prop_assume!(n.norm() > 0.1);
        let n = n.normalize();
        let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        let t = V3::from(t);
        // Both cameras on the same side of the plane (d2 / d > 0).
        prop_assume!(1.0 + n.dot(&(r.inverse() * t)) / d > 0.05);
        let h = (r.matrix() + t * n.transpose() / d) * scale;
        let dec = decompose_calibrated(&h, PURE_ROTATION_TOLERANCE).unwrap();
        for c in dec.candidates() {
            prop_assert!(is_proper_rotation(c.rotation.matrix()));
        }
        if !dec.is_pure_rotation() && (t / d).norm() > 0.01 {
            let best = dec
                .candidates()
                .iter()
                .map(|c| rotation_error(c.rotation.matrix(), r.matrix()))
                .fold(f32::INFINITY, f32::min);
            prop_assert!(best < 1e-3, "closest candidate {best} rad from the truth");
            // The candidate with the true normal is the true motion.
            let prior = NormalPrior::new(&n, 0.01).unwrap();
            let sel = dec
                .select(&[], &[], &SelectParams { prior: Some(prior), ..SelectParams::default() })
                .unwrap();
            let c = dec.selected(&sel).unwrap();
            prop_assert!(rotation_error(c.rotation.matrix(), r.matrix()) < 1e-3);
            prop_assert!((c.translation_over_distance - t / d).norm() < 1e-3 * (1.0 + (t / d).norm()));
        }
    }

    /// No matrix, however wild, makes the decomposition or the selection
    /// panic; whatever comes back has proper rotations.
    #[test]
    fn random_matrices_never_panic(
        m in prop::array::uniform9(wild()),
        tol in prop_oneof![0.0f32..1e-2, Just(f32::NAN), Just(-1.0f32)],
        pts in prop::collection::vec((wild(), wild()), 0..10),
        prior in prop::array::uniform3(wild()),
    ) {
        let m = Matrix3::from_row_slice(&m);
        if let Ok(dec) = decompose_calibrated(&m, tol) {
            prop_assert!(!dec.candidates().is_empty());
            for c in dec.candidates() {
                prop_assert!(is_proper_rotation(c.rotation.matrix()));
            }
            let pts: Vec<Vector2<f32>> = pts.iter().map(|(x, y)| Vector2::new(*x, *y)).collect();
            let prior = NormalPrior::new(&V3::from(prior), 0.3).ok();
            if let Ok(sel) = dec.select(&pts, &[], &SelectParams { prior, ..SelectParams::default() }) {
                prop_assert!(sel.index < dec.candidates().len());
            }
        }
    }
}
