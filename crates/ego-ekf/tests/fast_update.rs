//! The structured (fast) covariance maths equals the straightforward dense
//! formulas within `f32` tolerance on seeded random states and covariances:
//! the update (sparse `P H^T`, `P - W W^T` on the upper triangle, structured
//! reset) against the dense Joseph form with a dense reset
//! (`ego_ekf::reference`), for the wheel, flow and ZUPT measurements and
//! random sparse ones; the reset and the propagation against their dense
//! products. Errors are measured per entry against `sqrt(P_ii P_jj)`, so
//! small and large blocks count alike.

use ego_ekf::config::{ImuNoise, RobotPrior, ZuptConfig};
use ego_ekf::covariance::{is_positive_definite, reset, reset_dense};
use ego_ekf::flow::model::flow_measurement;
use ego_ekf::grip::GripParams;
use ego_ekf::propagate::{
    Transition, process_noise, propagate_covariance, propagate_covariance_dense,
};
use ego_ekf::reference::gated_update_dense;
use ego_ekf::state::{CTH, Covariance, DIM, ErrorState, NominalState, Quat, RB, TH, Vec3};
use ego_ekf::update::{
    Measurement, Support, downdate, downdate_upper, gated_update, mirror_upper_to_lower,
};
use ego_ekf::wheel::model::wheel_measurement;
use ego_ekf::zupt::model::zupt_measurement;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig};
use nalgebra::{Matrix3, SMatrix, SVector, Vector2};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

/// A small seeded generator (splitmix64), uniform in `[-0.5, 0.5)`.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    }
    fn vec3(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * scale
    }
}

/// A random symmetric positive-definite covariance with standard deviations
/// spread over three decades, 1e-3 to 1 (as in the filter: radii in mm, attitude in
/// mrad, positions in cm) and correlations up to about 0.9.
fn random_covariance(rng: &mut Rng) -> Covariance {
    let a = SMatrix::<f32, DIM, DIM>::from_fn(|_, _| rng.next());
    let c = a * a.transpose() + Covariance::identity() * 0.3;
    let d = ErrorState::from_fn(|_, _| 10f32.powf(-3.0 + 3.0 * (rng.next() + 0.5)));
    let n = c.diagonal().map(|v| 1.0 / v.sqrt());
    let corr = c.component_mul(&(n * n.transpose()));
    let p = corr.component_mul(&(d * d.transpose()));
    // Exactly symmetric, as the filter keeps it.
    (p + p.transpose()) * 0.5
}

/// A random nominal state near a driving robot.
fn random_state(rng: &mut Rng) -> NominalState {
    let q_wb = Quat::from_scaled_axis(rng.vec3(0.2) + Vec3::new(0.0, 0.0, 6.0 * rng.next()));
    NominalState {
        p_wb: rng.vec3(4.0),
        v_wb: rng.vec3(0.6),
        q_wb,
        accel_bias: rng.vec3(0.05),
        gyro_bias: rng.vec3(0.005),
        gravity: Vec3::new(0.0, 0.0, -9.81) + rng.vec3(0.02),
        clone_p_wb: rng.vec3(4.0),
        clone_q_wb: q_wb * Quat::from_scaled_axis(rng.vec3(0.01)),
        p_bl: Vec3::new(0.0, 0.115, -0.06) + rng.vec3(0.01),
        p_br: Vec3::new(0.0, -0.115, -0.06) + rng.vec3(0.01),
        q_rb: Quat::from_scaled_axis(rng.vec3(0.05)),
        radius_left: 0.035 + 0.001 * rng.next(),
        radius_right: 0.035 + 0.001 * rng.next(),
    }
}

/// Largest `|a_ij - b_ij| / sqrt(s_i s_j)` with `s` the size of the numbers
/// the step combines into entry `i`: its variance before (`prior`; an update
/// that shrinks a variance by orders of magnitude leaves rounding of the
/// prior's size, in any `f32` formula) and after (`b`), and for a rotation
/// error the largest variance of its block (the reset mixes the block).
fn normalised_error(a: &Covariance, b: &Covariance, prior: &Covariance) -> f32 {
    let block_max = |i: usize| {
        [TH, CTH, RB]
            .into_iter()
            .filter(|r| (*r..*r + 3).contains(&i))
            .flat_map(|r| (r..r + 3).map(|k| prior[(k, k)]))
            .fold(0.0f32, f32::max)
    };
    let s = ErrorState::from_fn(|i, _| prior[(i, i)].max(b[(i, i)]).max(block_max(i)).sqrt());
    let scale = s * s.transpose();
    (a - b)
        .iter()
        .zip(scale.iter())
        .map(|(e, s)| e.abs() / s)
        .fold(0.0, f32::max)
}

/// Largest difference of two error states taking `a` to `b`, for the
/// additive parts (positions, velocities, biases, gravity, contact points,
/// radii) and the rotations (angle of `a^-1 b`).
fn state_error(a: &NominalState, b: &NominalState) -> f32 {
    let v = [
        (a.p_wb - b.p_wb).amax(),
        (a.v_wb - b.v_wb).amax(),
        (a.accel_bias - b.accel_bias).amax(),
        (a.gyro_bias - b.gyro_bias).amax(),
        (a.gravity - b.gravity).amax(),
        (a.clone_p_wb - b.clone_p_wb).amax(),
        (a.p_bl - b.p_bl).amax(),
        (a.p_br - b.p_br).amax(),
        (a.radius_left - b.radius_left).abs(),
        (a.radius_right - b.radius_right).abs(),
        a.q_wb.angle_to(&b.q_wb),
        a.clone_q_wb.angle_to(&b.clone_q_wb),
        a.q_rb.angle_to(&b.q_rb),
    ];
    v.into_iter().fold(0.0, f32::max)
}

/// The dense textbook update evaluated in `f64`: `K = P H^T S^-1`, the
/// Joseph form, `dx = K y`, injection and the dense reset `G P G^T`. The
/// oracle: the `f32` dense reference ([`gated_update_dense`]) loses up to
/// 0.5 % of the NIS to the inverse of an ill-conditioned `S`, the fast
/// update (Cholesky) much less.
fn oracle<const M: usize>(
    x0: &NominalState,
    p0: &Covariance,
    m: &Measurement<M>,
) -> (NominalState, SMatrix<f64, DIM, DIM>, f64) {
    let p = p0.cast::<f64>();
    let h = m.h.cast::<f64>();
    let r = m.noise.cast::<f64>();
    let y = m.residual.cast::<f64>();
    let s_inv = (h * p * h.transpose() + r).try_inverse().unwrap();
    let nis = (y.transpose() * s_inv * y).x;
    let k = p * h.transpose() * s_inv;
    let ikh = SMatrix::<f64, DIM, DIM>::identity() - k * h;
    let joseph = ikh * p * ikh.transpose() + k * r * k.transpose();
    let dx = k * y;
    let mut g = SMatrix::<f64, DIM, DIM>::identity();
    for b in [TH, CTH, RB] {
        let a = dx.fixed_rows::<3>(b) * 0.5;
        let block = Matrix3::identity() - a.cross_matrix();
        g.fixed_view_mut::<3, 3>(b, b).copy_from(&block);
    }
    let mut x = *x0;
    x.inject(&dx.cast::<f32>());
    (x, g * joseph * g.transpose(), nis)
}

/// Runs the fast update and the `f64` oracle from the same state and checks
/// that they agree: covariance within `tol` (normalised), state within
/// `1e-5` plus `1e-3` of the correction, NIS within `1e-3` relative, and the
/// fast covariance exactly symmetric and positive definite. The `f32` dense
/// reference runs too (it must accept the update).
fn compare<const M: usize>(x0: &NominalState, p0: &Covariance, m: &Measurement<M>, tol: f32) {
    let (x_true, p_true, nis_true) = oracle(x0, p0, m);
    let p_true = p_true.cast::<f32>();
    let (mut x_fast, mut p_fast) = (*x0, *p0);
    let fast = gated_update(&mut x_fast, &mut p_fast, m, None).unwrap();
    let (mut x_dense, mut p_dense) = (*x0, *p0);
    gated_update_dense(&mut x_dense, &mut p_dense, m, None).unwrap();
    assert!(
        (f64::from(fast.nis) - nis_true).abs() <= 1e-3 * nis_true.max(1.0),
        "NIS {} vs {nis_true}",
        fast.nis
    );
    let err = normalised_error(&p_fast, &p_true, p0);
    assert!(err < tol, "covariance differs by {err} (normalised)");
    assert_eq!(p_fast, p_fast.transpose(), "fast covariance not symmetric");
    // Positive definite, unless the exact result is singular within `f32`
    // rounding (smallest eigenvalue of its correlation matrix below 1e-4;
    // a handful of the random cases, never the filter's).
    let c = p_true.cast::<f64>();
    let d = c.diagonal().map(|v| 1.0 / v.sqrt());
    let min_eig = c
        .component_mul(&(d * d.transpose()))
        .symmetric_eigenvalues()
        .min();
    if min_eig > 1e-4 {
        assert!(is_positive_definite(&p_fast), "not PD (oracle {min_eig:e})");
    }
    let correction = state_error(x0, &x_true);
    let dx_err = state_error(&x_fast, &x_true);
    assert!(
        dx_err <= 1e-5 + 1e-3 * correction,
        "state differs by {dx_err} (correction {correction})"
    );
}

#[test]
fn wheel_update_equals_dense_joseph_form() {
    let mut rng = Rng(1);
    for seed in 0..40 {
        let x = random_state(&mut rng);
        let p = random_covariance(&mut rng);
        let gyro = rng.vec3(1.0);
        let rates =
            WheelRates::new(Timestamp(0), 8.0 + 4.0 * rng.next(), 8.0 + 4.0 * rng.next()).unwrap();
        let grip = GripParams::default();
        let m = wheel_measurement(&x, &gyro, &rates, &grip);
        // The sparse P H^T is the dense one.
        let dense_pht = p * m.h.transpose();
        let err = (m.p_ht(&p) - dense_pht).abs().max();
        assert!(
            err <= 1e-5 * dense_pht.abs().max(),
            "seed {seed}: P H^T {err}"
        );
        compare(&x, &p, &m, 5e-4);
        // The two constraint rows alone (the gated case).
        let c = m.select([2, 3]).unwrap();
        compare(&x, &p, &c, 5e-4);
    }
}

/// The filter's own covariance after two seconds of seeded driving (the
/// benchmark's state): strongly correlated, with the clone a near copy of
/// the pose.
#[test]
fn wheel_update_on_the_filters_covariance_equals_dense_joseph_form() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    f.start(&ExplicitStart {
        t: Timestamp(0),
        p_wb: Vec3::zeros(),
        v_wb: Vec3::zeros(),
        q_wb: Quat::identity(),
        accel_bias: Vec3::zeros(),
        gyro_bias: Vec3::zeros(),
    })
    .unwrap();
    let mut rng = Rng(7);
    let dt = 4_000_000u64;
    for i in 1..=500u64 {
        let s = ImuSample::new(
            Timestamp(i * dt),
            [
                0.02 * rng.next(),
                0.02 * rng.next(),
                0.3 + 0.02 * rng.next(),
            ],
            [0.2 + 0.02 * rng.next(), 0.06, 9.81 + 0.02 * rng.next()],
        )
        .unwrap();
        f.propagate(&s).unwrap();
        if i % 5 == 0 {
            let rates = WheelRates::new(Timestamp(i * dt), 4.0, 5.0).unwrap();
            let m = wheel_measurement(f.state(), &f.angular_velocity(), &rates, &f.grip());
            compare(f.state(), f.covariance(), &m, 5e-4);
            compare(f.state(), f.covariance(), &m.select([2, 3]).unwrap(), 5e-4);
            let _ = f.fuse_wheel(&rates);
        }
    }
}

#[test]
fn flow_and_zupt_updates_equal_dense_joseph_form() {
    let mut rng = Rng(2);
    let zupt = ZuptConfig::default();
    for _ in 0..30 {
        let x = random_state(&mut rng);
        let p = random_covariance(&mut rng);
        let gyro = rng.vec3(1.0);
        let z = Vector2::new(rng.next(), rng.next());
        compare(&x, &p, &flow_measurement(&x, &gyro, &z, 0.01), 5e-4);
        compare(&x, &p, &zupt_measurement(&x, &zupt), 5e-4);
    }
}

#[test]
fn random_sparse_updates_equal_dense_joseph_form() {
    let mut rng = Rng(3);
    for _ in 0..40 {
        let x = random_state(&mut rng);
        let p = random_covariance(&mut rng);
        // Each column nonzero with probability one half.
        let mut h = SMatrix::<f32, 3, DIM>::zeros();
        for mut col in h.column_iter_mut() {
            if rng.next() > 0.0 {
                col.copy_from(&Vec3::new(rng.next(), rng.next(), rng.next()));
            }
        }
        let support = Support::of(&h);
        assert_eq!(
            support.len(),
            h.column_iter()
                .filter(|c| c.iter().any(|v| *v != 0.0))
                .count()
        );
        let residual = SVector::<f32, 3>::new(rng.next(), rng.next(), rng.next()) * 0.01;
        let noise = SMatrix::<f32, 3, 3>::from_diagonal(&SVector::<f32, 3>::new(0.01, 0.02, 0.005));
        compare(&x, &p, &Measurement { residual, h, noise }, 5e-4);
    }
}

#[test]
fn update_gates_like_the_dense_formula() {
    let mut rng = Rng(4);
    let x = random_state(&mut rng);
    let p = random_covariance(&mut rng);
    let m = wheel_measurement(
        &x,
        &rng.vec3(1.0),
        &WheelRates::new(Timestamp(0), 9.0, 7.0).unwrap(),
        &GripParams::default(),
    );
    let (mut xd, mut pd) = (x, p);
    let nis = gated_update_dense(&mut xd, &mut pd, &m, None).unwrap().nis;
    for gate in [nis * 0.99, nis * 1.01] {
        let (mut xf, mut pf) = (x, p);
        let (mut xd, mut pd) = (x, p);
        let fast = gated_update(&mut xf, &mut pf, &m, Some(gate)).map(|_| ());
        let dense = gated_update_dense(&mut xd, &mut pd, &m, Some(gate)).map(|_| ());
        assert_eq!(fast, dense, "gate {gate}, NIS {nis}");
        if fast.is_err() {
            assert_eq!((xf, pf), (x, p), "a gated update changed the state");
        }
    }
}

#[test]
fn reset_equals_dense_product() {
    let mut rng = Rng(5);
    for _ in 0..40 {
        let p0 = random_covariance(&mut rng);
        let dx = ErrorState::from_fn(|_, _| 0.05 * rng.next());
        let (mut fast, mut dense) = (p0, p0);
        reset(&mut fast, &dx);
        reset_dense(&mut dense, &dx);
        let err = normalised_error(&fast, &dense, &dense);
        assert!(err < 1e-5, "reset differs by {err}");
        assert_eq!(fast, fast.transpose());
    }
}

#[test]
fn propagation_equals_dense_product_on_spread_covariances() {
    let mut rng = Rng(6);
    for _ in 0..40 {
        let p0 = random_covariance(&mut rng);
        let r = Quat::from_scaled_axis(rng.vec3(3.0))
            .to_rotation_matrix()
            .into_inner();
        let accel = rng.vec3(2.0) + Vec3::new(0.0, 0.0, 9.81);
        let gyro = rng.vec3(2.0);
        let dt = 0.004 * (1.0 + rng.next());
        let f = Transition::new(&r, &accel, &gyro, dt);
        let q = process_noise(&ImuNoise::default(), &RobotPrior::default(), dt);
        let (mut fast, mut dense) = (p0, p0);
        propagate_covariance(&mut fast, &f, &q);
        propagate_covariance_dense(&mut dense, &f, &q);
        let err = normalised_error(&fast, &dense, &dense);
        assert!(err < 1e-4, "propagation differs by {err}");
        assert_eq!(fast, fast.transpose());
    }
}

#[test]
fn triangle_downdate_and_mirror_equal_the_full_downdate() {
    let mut rng = Rng(8);
    for _ in 0..10 {
        let p0 = random_covariance(&mut rng);
        let w = SMatrix::<f32, DIM, 4>::from_fn(|_, _| 0.1 * rng.next());
        let (mut full, mut triangle) = (p0, p0);
        downdate(&mut full, &w);
        downdate_upper(&mut triangle, &w);
        mirror_upper_to_lower(&mut triangle);
        assert_eq!(full, full.transpose());
        assert_eq!(triangle, triangle.transpose());
        let expected = p0 - w * w.transpose();
        assert!((full - expected).abs().max() < 1e-6);
        // Bit for bit: the same sums in the same order.
        assert_eq!(triangle, full);
    }
}
