//! Homography estimation on synthetic scenes: a camera looking at a plane,
//! moved by a known motion, so the true `H = K (R + t n^T / d) K^-1` is known.

use nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use vslam_core::homography::{
    Homography, HomographyError, HomographyRansac, RansacParams, RefineParams, dlt, dlt_masked,
    from_four_points, refine_homography,
};

type V2 = Vector2<f32>;

const WIDTH: f32 = 640.0;
const HEIGHT: f32 = 480.0;

fn k() -> Matrix3<f32> {
    Matrix3::new(420.0, 0.0, 320.0, 0.0, 410.0, 240.0, 0.0, 0.0, 1.0)
}

/// The pixel homography of a plane `n^T X1 = d` under `X2 = R X1 + t`.
fn true_h(rpy: [f32; 3], t: [f32; 3], n: [f32; 3], d: f32) -> Matrix3<f32> {
    let r = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    let n = Vector3::from(n).normalize();
    let he = r.matrix() + Vector3::from(t) * n.transpose() / d;
    k() * he * k().try_inverse().unwrap()
}

fn apply(h: &Matrix3<f32>, p: &V2) -> V2 {
    let y = h * Vector3::new(p.x, p.y, 1.0);
    V2::new(y.x / y.z, y.y / y.z)
}

/// Normalise to unit Frobenius norm with `det > 0`, as `Homography` does.
fn normalized(h: &Matrix3<f32>) -> Matrix3<f32> {
    let u = h / h.norm();
    if u.determinant() < 0.0 { -u } else { u }
}

fn relative_error(estimate: &Homography, truth: &Matrix3<f32>) -> f32 {
    (estimate.matrix() - normalized(truth)).norm()
}

struct Rng(oorandom::Rand32);

impl Rng {
    fn new(seed: u64) -> Self {
        Rng(oorandom::Rand32::new(seed))
    }
    fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.0.rand_float()
    }
    /// Standard normal by Box-Muller.
    fn gauss(&mut self) -> f32 {
        let u1 = self.0.rand_float().max(1e-7);
        let u2 = self.0.rand_float();
        (-2.0 * u1.ln()).sqrt() * (2.0 * core::f32::consts::PI * u2).cos()
    }
    fn in_image(&mut self, margin: f32) -> V2 {
        V2::new(
            self.uniform(margin, WIDTH - margin),
            self.uniform(margin, HEIGHT - margin),
        )
    }
}

/// The ceiling seen by an upward camera, with a motion that has a bit of everything.
fn scene_h(variant: u32) -> Matrix3<f32> {
    match variant % 4 {
        0 => true_h(
            [0.02, -0.03, 0.10],
            [0.20, 0.05, 0.02],
            [0.0, 0.0, 1.0],
            2.0,
        ),
        1 => true_h(
            [-0.05, 0.04, -0.30],
            [-0.10, 0.25, -0.05],
            [0.1, -0.05, 1.0],
            2.4,
        ),
        2 => true_h(
            [0.08, 0.02, 0.5],
            [0.05, -0.15, 0.20],
            [-0.1, 0.1, 1.0],
            1.8,
        ),
        _ => true_h([0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.0, 1.0], 2.2),
    }
}

/// `count` exact correspondences inside both images.
fn exact_points(h: &Matrix3<f32>, rng: &mut Rng, count: usize) -> (Vec<V2>, Vec<V2>) {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    while a.len() < count {
        let p = rng.in_image(10.0);
        let q = apply(h, &p);
        if q.x > 0.0 && q.x < WIDTH && q.y > 0.0 && q.y < HEIGHT {
            a.push(p);
            b.push(q);
        }
    }
    (a, b)
}

#[test]
fn four_exact_points_give_the_true_homography() {
    for variant in 0..4 {
        let h = scene_h(variant);
        let p1 = [
            V2::new(50.0, 40.0),
            V2::new(600.0, 60.0),
            V2::new(560.0, 430.0),
            V2::new(80.0, 400.0),
        ];
        let p2 = p1.map(|p| apply(&h, &p));
        let est = from_four_points(&p1, &p2).unwrap();
        let err = relative_error(&est, &h);
        assert!(err < 1e-4, "variant {variant}: relative error {err}");
        for (a, b) in p1.iter().zip(p2.iter()) {
            assert!((est.transfer(a).unwrap() - b).norm() < 1e-2);
        }
    }
}

#[test]
fn dlt_on_exact_points_gives_the_true_homography() {
    let mut rng = Rng::new(7);
    for variant in 0..4 {
        let h = scene_h(variant);
        // Four random points can be nearly degenerate; the spread quadrilateral
        // of the four-point test is the exactly determined case.
        let quad = [
            V2::new(50.0, 40.0),
            V2::new(600.0, 60.0),
            V2::new(560.0, 430.0),
            V2::new(80.0, 400.0),
        ];
        let est = dlt(&quad, &quad.map(|p| apply(&h, &p))).unwrap();
        assert!(relative_error(&est, &h) < 1e-4);
        for count in [5, 8, 12, 100, 400] {
            let (a, b) = exact_points(&h, &mut rng, count);
            let est = dlt(&a, &b).unwrap();
            let err = relative_error(&est, &h);
            assert!(err < 1e-4, "variant {variant}, {count} points: {err}");
        }
    }
}

#[test]
fn normalisation_convention_and_row_major_export() {
    let h = scene_h(1);
    let est = Homography::from_matrix(&(-3.7 * h)).unwrap();
    assert!((est.matrix().norm() - 1.0).abs() < 1e-6);
    assert!(est.matrix().determinant() > 0.0);
    let rm = est.to_row_major();
    assert_eq!(rm[1], est.matrix()[(0, 1)]);
    assert_eq!(rm[5], est.matrix()[(1, 2)]);
    assert_eq!(rm[7], est.matrix()[(2, 1)]);
    assert_eq!(Homography::from_row_major(&rm).unwrap(), est);
    let inv = est.inverse().unwrap();
    let p = V2::new(100.0, 200.0);
    let back = inv.transfer(&est.transfer(&p).unwrap()).unwrap();
    assert!((back - p).norm() < 1e-3);
}

/// Noisy inliers (1 px Gaussian, truncated at 2.5 px so the true inlier set is
/// well defined at a 3 px threshold) and 30 % outliers uniform in image 2, at
/// least 15 px from where their point truly maps.
fn noisy_scene(
    h: &Matrix3<f32>,
    rng: &mut Rng,
    count: usize,
    outlier_fraction: f32,
) -> (Vec<V2>, Vec<V2>, Vec<bool>) {
    let (a, mut b) = exact_points(h, rng, count);
    let mut truth = vec![true; count];
    let outliers = (count as f32 * outlier_fraction).round() as usize;
    // Spread the outliers over the list.
    let mut chosen = 0;
    while chosen < outliers {
        let i = rng.0.rand_range(0..count as u32) as usize;
        if !truth[i] {
            continue;
        }
        truth[i] = false;
        chosen += 1;
    }
    for i in 0..count {
        if truth[i] {
            loop {
                let n = V2::new(rng.gauss(), rng.gauss());
                if n.norm() <= 2.5 {
                    b[i] += n;
                    break;
                }
            }
        } else {
            loop {
                let q = rng.in_image(0.0);
                if (q - b[i]).norm() > 15.0 {
                    b[i] = q;
                    break;
                }
            }
        }
    }
    (a, b, truth)
}

fn corners() -> [V2; 4] {
    [
        V2::new(0.0, 0.0),
        V2::new(WIDTH, 0.0),
        V2::new(WIDTH, HEIGHT),
        V2::new(0.0, HEIGHT),
    ]
}

#[test]
fn ransac_finds_exactly_the_inliers_under_noise_and_outliers() {
    let mut ransac = HomographyRansac::<256>::new(RansacParams {
        threshold_px: 3.0,
        seed: 42,
        ..RansacParams::default()
    })
    .unwrap();
    // The exact inlier set at the size the tracker works with (100 points).
    for trial in 0..24u64 {
        let mut rng = Rng::new(1000 + trial);
        let h = scene_h(trial as u32);
        let (a, b, truth) = noisy_scene(&h, &mut rng, 100 + 5 * trial as usize, 0.3);
        let mut mask = vec![false; a.len()];
        let report = ransac.estimate(&a, &b, &mut mask).unwrap();
        assert_eq!(mask, truth, "trial {trial}: inlier set differs");
        assert_eq!(report.inlier_count, truth.iter().filter(|m| **m).count());
        assert!(report.rms_error_px < 2.0, "rms {}", report.rms_error_px);
        assert!(
            report.iterations < 2000,
            "adaptive stop: {}",
            report.iterations
        );
        assert!(report.refined);
    }
}

#[test]
fn ransac_transfers_the_image_corners_within_a_pixel() {
    // With 1 px noise the error at the corners (extrapolated beyond the
    // points) falls as 1/sqrt(inliers): at 70 inliers it is 0.4..1.5 px even
    // for the DLT on the true inlier set, so this check uses 300 points
    // (210 inliers), where sub-pixel corners are what the statistics allow.
    let mut ransac = HomographyRansac::<512>::new(RansacParams {
        threshold_px: 3.0,
        seed: 7,
        ..RansacParams::default()
    })
    .unwrap();
    for trial in 0..16u64 {
        let mut rng = Rng::new(2000 + trial);
        let h = scene_h(trial as u32);
        let (a, b, truth) = noisy_scene(&h, &mut rng, 300, 0.3);
        let mut mask = vec![false; a.len()];
        let report = ransac.estimate(&a, &b, &mut mask).unwrap();
        assert_eq!(mask, truth, "trial {trial}: inlier set differs");
        for c in corners() {
            let est = report.homography.transfer(&c).unwrap();
            let err = (est - apply(&h, &c)).norm();
            assert!(err < 1.0, "trial {trial}: corner {c:?} off by {err} px");
        }
    }
}

#[test]
fn ransac_is_deterministic_for_a_seed() {
    let mut rng = Rng::new(5);
    let (a, b, _) = noisy_scene(&scene_h(2), &mut rng, 150, 0.4);
    let run = |seed| {
        let mut r = HomographyRansac::<200>::new(RansacParams {
            seed,
            ..RansacParams::default()
        })
        .unwrap();
        let mut mask = vec![false; a.len()];
        let rep = r.estimate(&a, &b, &mut mask).unwrap();
        (rep, mask)
    };
    assert_eq!(run(9), run(9));
}

#[test]
fn ransac_iteration_count_adapts_and_respects_the_cap() {
    let mut rng = Rng::new(11);
    let (a, b, _) = noisy_scene(&scene_h(0), &mut rng, 100, 0.0);
    let mut r = HomographyRansac::<100>::new(RansacParams::default()).unwrap();
    let mut mask = vec![false; 100];
    let clean = r.estimate(&a, &b, &mut mask).unwrap();
    // All inliers: w = 1 after the first good sample.
    // No outliers: the count stops far below the cap (noisy minimal samples
    // need not reach every inlier, so not at 1).
    assert!(clean.iterations < 50, "{}", clean.iterations);
    assert_eq!(clean.inlier_count, 100);

    let (a, b, _) = noisy_scene(&scene_h(0), &mut rng, 100, 0.7);
    let mut capped = HomographyRansac::<100>::new(RansacParams {
        max_iterations: 5,
        ..RansacParams::default()
    })
    .unwrap();
    match capped.estimate(&a, &b, &mut mask) {
        Ok(rep) => assert!(rep.iterations <= 5),
        Err(e) => assert_eq!(e, HomographyError::NoConsensus),
    }
    let mut patient = HomographyRansac::<100>::new(RansacParams::default()).unwrap();
    let rep = patient.estimate(&a, &b, &mut mask).unwrap();
    // w = 0.3: k = log(0.005) / log(1 - 0.3^4) ~ 651.
    assert!(
        rep.iterations > 100 && rep.iterations <= 2000,
        "{}",
        rep.iterations
    );
    assert_eq!(rep.inlier_count, 30);
}

#[test]
fn refinement_reaches_the_noise_floor_from_a_perturbed_start() {
    let mut rng = Rng::new(3);
    let h = scene_h(1);
    let (a, b, truth) = noisy_scene(&h, &mut rng, 120, 0.0);
    assert!(truth.iter().all(|m| *m));
    let mut start = normalized(&h);
    start[(0, 2)] += 0.02 * start[(0, 2)].abs().max(1e-3);
    start[(2, 0)] *= 1.05;
    let start = Homography::from_matrix(&start).unwrap();
    let rep = refine_homography(&start, &a, &b, &[], &RefineParams::default()).unwrap();
    assert!(
        rep.initial_rms_px > 2.0,
        "start too good: {}",
        rep.initial_rms_px
    );
    // 1 px per-axis noise: RMS of the 2D residual is about sqrt(2) px.
    assert!(rep.final_rms_px < 1.6, "{}", rep.final_rms_px);
    let dlt_fit = dlt(&a, &b).unwrap();
    let dlt_rms = (a
        .iter()
        .zip(b.iter())
        .map(|(p, q)| dlt_fit.transfer_error_sq(p, q))
        .sum::<f32>()
        / a.len() as f32)
        .sqrt();
    assert!(
        rep.final_rms_px <= dlt_rms + 1e-3,
        "{} vs dlt {}",
        rep.final_rms_px,
        dlt_rms
    );
}

#[test]
fn dlt_masked_ignores_unselected_points() {
    let mut rng = Rng::new(21);
    let h = scene_h(2);
    let (a, mut b) = exact_points(&h, &mut rng, 40);
    let mut mask = vec![true; 40];
    for i in (0..40).step_by(3) {
        b[i] += V2::new(50.0, -40.0);
        mask[i] = false;
    }
    b[1] = V2::new(f32::NAN, 0.0);
    mask[1] = false;
    let est = dlt_masked(&a, &b, &mask).unwrap();
    assert!(relative_error(&est, &h) < 1e-4);
}

// ---------------------------------------------------------------- degenerate input

fn square() -> [V2; 4] {
    [
        V2::new(100.0, 100.0),
        V2::new(300.0, 110.0),
        V2::new(290.0, 320.0),
        V2::new(90.0, 300.0),
    ]
}

#[test]
fn too_few_points() {
    let p = square();
    assert_eq!(
        dlt(&p[..3], &p[..3]),
        Err(HomographyError::TooFewPoints { got: 3 })
    );
    let mut r = HomographyRansac::<16>::new(RansacParams::default()).unwrap();
    let mut mask = [true; 3];
    assert_eq!(
        r.estimate(&p[..3], &p[..3], &mut mask),
        Err(HomographyError::TooFewPoints { got: 3 })
    );
    assert_eq!(mask, [false; 3]);
}

#[test]
fn duplicate_points() {
    let mut p = square();
    p[2] = p[0];
    assert_eq!(
        from_four_points(&p, &square()),
        Err(HomographyError::DuplicatePoints)
    );
    assert_eq!(
        from_four_points(&square(), &p),
        Err(HomographyError::DuplicatePoints)
    );
    // Four points of which only three are distinct do not fix H.
    assert_eq!(dlt(&p, &square()), Err(HomographyError::Degenerate));
}

#[test]
fn collinear_points() {
    let mut p = square();
    p[3] = (p[0] + p[1]) * 0.5;
    assert_eq!(
        from_four_points(&p, &square()),
        Err(HomographyError::Collinear)
    );
    assert_eq!(
        from_four_points(&square(), &p),
        Err(HomographyError::Collinear)
    );
    // All points on a line: DLT and RANSAC refuse.
    let line: Vec<V2> = (0..20)
        .map(|i| V2::new(10.0 * i as f32, 5.0 * i as f32 + 3.0))
        .collect();
    assert_eq!(dlt(&line, &line), Err(HomographyError::Degenerate));
    let mut r = HomographyRansac::<32>::new(RansacParams::default()).unwrap();
    let mut mask = vec![false; 20];
    assert_eq!(
        r.estimate(&line, &line, &mut mask),
        Err(HomographyError::NoConsensus)
    );
}

#[test]
fn non_finite_coordinates() {
    let mut p = square();
    p[2].y = f32::INFINITY;
    assert_eq!(
        from_four_points(&square(), &p),
        Err(HomographyError::NonFinite { index: 2 })
    );
    p[2].y = f32::NAN;
    assert_eq!(
        dlt(&p, &square()),
        Err(HomographyError::NonFinite { index: 2 })
    );
    let mut r = HomographyRansac::<16>::new(RansacParams::default()).unwrap();
    let mut mask = [false; 4];
    assert_eq!(
        r.estimate(&square(), &p, &mut mask),
        Err(HomographyError::NonFinite { index: 2 })
    );
    let mut m = Matrix3::identity();
    m[(1, 1)] = f32::NAN;
    assert_eq!(
        Homography::from_matrix(&m),
        Err(HomographyError::NonFinite { index: 0 })
    );
}

#[test]
fn near_singular_results() {
    // A rank-2 matrix is not a homography.
    let m = Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0);
    assert_eq!(
        Homography::from_matrix(&m),
        Err(HomographyError::NearSingular)
    );
    assert_eq!(
        Homography::from_matrix(&Matrix3::zeros()),
        Err(HomographyError::NearSingular)
    );
    // Image 2 squashed onto a line by a singular map: the least-squares
    // solution is that singular map, and the DLT refuses it.
    let mut rng = Rng::new(1);
    let a: Vec<V2> = (0..30).map(|_| rng.in_image(0.0)).collect();
    let b: Vec<V2> = a.iter().map(|p| V2::new(p.x, 0.5 * p.x + 7.0)).collect();
    assert_eq!(dlt(&a, &b), Err(HomographyError::NearSingular));
}

#[test]
fn capacity_and_lengths_and_parameters() {
    let mut rng = Rng::new(2);
    let (a, b) = exact_points(&scene_h(0), &mut rng, 40);
    let mut r = HomographyRansac::<32>::new(RansacParams::default()).unwrap();
    let mut mask = vec![false; 40];
    assert_eq!(
        r.estimate(&a, &b, &mut mask),
        Err(HomographyError::TooManyPoints {
            got: 40,
            capacity: 32
        })
    );
    let mut short = vec![false; 10];
    assert_eq!(
        r.estimate(&a[..20], &b[..20], &mut short),
        Err(HomographyError::LengthMismatch)
    );
    assert_eq!(dlt(&a, &b[..39]), Err(HomographyError::LengthMismatch));
    assert_eq!(
        dlt_masked(&a, &b, &mask[..5]),
        Err(HomographyError::LengthMismatch)
    );
    for bad in [
        RansacParams {
            threshold_px: 0.0,
            ..RansacParams::default()
        },
        RansacParams {
            threshold_px: f32::NAN,
            ..RansacParams::default()
        },
        RansacParams {
            confidence: 1.0,
            ..RansacParams::default()
        },
        RansacParams {
            max_iterations: 0,
            ..RansacParams::default()
        },
        RansacParams {
            min_inliers: 3,
            ..RansacParams::default()
        },
    ] {
        assert_eq!(
            HomographyRansac::<8>::new(bad).err(),
            Some(HomographyError::InvalidParameter)
        );
    }
}

#[test]
fn ransac_on_unrelated_points_finds_no_consensus() {
    let mut rng = Rng::new(77);
    let a: Vec<V2> = (0..100).map(|_| rng.in_image(0.0)).collect();
    let b: Vec<V2> = (0..100).map(|_| rng.in_image(0.0)).collect();
    let mut r = HomographyRansac::<128>::new(RansacParams::default()).unwrap();
    let mut mask = vec![true; 100];
    assert_eq!(
        r.estimate(&a, &b, &mut mask),
        Err(HomographyError::NoConsensus)
    );
    assert!(mask.iter().all(|m| !*m));
}
