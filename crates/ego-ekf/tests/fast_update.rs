//! The structured (fast) covariance maths equals the straightforward dense
//! formulas within `f32` tolerance on seeded random states and covariances:
//! the update (sparse `P H^T`, `P - W W^T` on the upper triangle, structured
//! reset) against the dense Joseph form with a dense reset
//! (`ego_ekf::reference`), for the wheel, flow and ZUPT measurements and
//! random sparse ones; the reset and the propagation against their dense
//! products. Errors are measured per entry against `sqrt(P_ii P_jj)`, so
//! small and large blocks count alike.

mod random_update;

use ego_ekf::config::{ImuConfig, RobotPrior, ZuptConfig};
use ego_ekf::covariance::{is_positive_definite, reset, reset_dense};
use ego_ekf::flow::model::flow_measurement;
use ego_ekf::grip::GripParams;
use ego_ekf::propagate::{
    Transition, process_noise, propagate_covariance, propagate_covariance_dense,
};
use ego_ekf::reference::gated_update_dense;
use ego_ekf::state::{CP, Covariance, DIM, ErrorState, NominalState, Quat, Vec3};
use ego_ekf::update::{
    Measurement, Support, downdate, downdate_symmetric, downdate_upper, gated_update,
    mirror_upper_to_lower,
};
use ego_ekf::wheel::model::wheel_measurement;
use ego_ekf::zupt::model::zupt_measurement;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig};
use nalgebra::{SMatrix, SVector, Vector2};
use random_update::{Rng, normalised_error, oracle, random_covariance, random_state, state_error};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

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
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
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
        let q = process_noise(&ImuConfig::default(), &RobotPrior::default(), dt);
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
        let (mut full, mut triangle, mut symmetric) = (p0, p0, p0);
        downdate(&mut full, &w);
        downdate_upper(&mut triangle, &w);
        mirror_upper_to_lower(&mut triangle);
        downdate_symmetric(&mut symmetric, &w);
        assert_eq!(symmetric, full);
        assert_eq!(full, full.transpose());
        assert_eq!(triangle, triangle.transpose());
        let expected = p0 - w * w.transpose();
        assert!((full - expected).abs().max() < 1e-6);
        // Bit for bit: the same sums in the same order.
        assert_eq!(triangle, full);
    }
}

/// The mirror (in 4x4 blocks, the last three columns apart) copies every
/// entry above the diagonal below it and changes nothing above it,
/// whatever was below.
#[test]
fn mirror_copies_every_upper_entry_and_keeps_the_upper_triangle() {
    let upper = SMatrix::<f32, DIM, DIM>::from_fn(|i, j| (1000 * i + j) as f32);
    let mut p =
        SMatrix::<f32, DIM, DIM>::from_fn(|i, j| if i <= j { upper[(i, j)] } else { f32::NAN });
    mirror_upper_to_lower(&mut p);
    for j in 0..DIM {
        for i in 0..DIM {
            let expected = if i <= j { upper[(i, j)] } else { upper[(j, i)] };
            assert_eq!(p[(i, j)], expected, "entry ({i}, {j})");
        }
    }
}

/// With the clone decoupled (its cross terms zero, so `W` is zero on its
/// rows), the downdate that leaves the clone's columns alone gives the bits
/// of the full downdate, and a `W` with one nonzero clone entry is not
/// mistaken for a decoupled one.
#[test]
fn downdate_skipping_a_decoupled_clone_equals_the_full_downdate() {
    let mut rng = Rng(11);
    for case in 0..10 {
        let mut p0 = random_covariance(&mut rng);
        ego_ekf::covariance::decouple_clone(&mut p0);
        let mut w = SMatrix::<f32, DIM, 4>::from_fn(|_, _| 0.1 * rng.next());
        for r in 0..4 {
            for i in CP..CP + 6 {
                w[(i, r)] = 0.0;
            }
        }
        if case % 2 == 1 {
            w[(CP + 2, 1)] = 0.05;
        }
        let (mut full, mut triangle, mut symmetric) = (p0, p0, p0);
        downdate(&mut full, &w);
        downdate_upper(&mut triangle, &w);
        mirror_upper_to_lower(&mut triangle);
        downdate_symmetric(&mut symmetric, &w);
        assert_eq!(triangle, full, "case {case}");
        assert_eq!(symmetric, full, "case {case}");
    }
}
