//! The fast wheel update (`wheel::update`: `P H^T` from the 20 nonzero
//! columns, the per-row gate, sequential rows applied in one pass over the
//! upper triangle, the reset on the triangle, one mirror) against the dense
//! textbook formulas in `f64` (Joseph form, dense reset `G P G^T`), with the
//! dense `f32` reference (`ego_ekf::reference`) run on the same rows: seeded
//! proptest cases over random states, positive-definite covariances, gyro
//! rates, wheel rates and gates. Also the pieces: the triangle reset with the
//! mirror against the dense reset, and the cheap quaternion exponential
//! and the Rodrigues rotation of the IMU step against nalgebra's.

mod random_update;

use ego_ekf::covariance::{is_positive_definite, reset_dense, reset_upper};
use ego_ekf::grip::GripParams;
use ego_ekf::propagate::exp_so3;
use ego_ekf::reference::gated_update_dense;
use ego_ekf::state::{DIM, ErrorState, KG, Quat, Vec3, rotate_local};
use ego_ekf::update::mirror_upper_to_lower;
use ego_ekf::wheel::model::{SUPPORT, VERTICAL, wheel_measurement, wheel_rows};
use ego_ekf::wheel::update::{MAX_VARIANCE_REDUCTION, VERTICAL_HUBER, update};
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, RngSeed};
use random_update::{Rng, normalised_error, oracle, random_covariance, random_state, state_error};
use vslam_core::Timestamp;
use vslam_core::sensors::WheelRates;

fn config() -> Config {
    Config {
        cases: 200,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x7768_6565_6c66_6173),
        failure_persistence: Some(Box::new(FileFailurePersistence::Off)),
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// The fast wheel update gates like the dense formulas (a failed
    /// differential row alone keeps the forward row) and, fused or gated,
    /// leaves the state and covariance of the `f64` textbook update.
    #[test]
    fn fast_wheel_update_equals_dense_reference(
        seed in any::<u64>(),
        left in -12.0f32..12.0,
        right in -12.0f32..12.0,
        gate in 0.5f32..30.0,
    ) {
        let mut rng = Rng(seed);
        let x0 = random_state(&mut rng);
        let p0 = random_covariance(&mut rng);
        let gyro = rng.vec3(1.0);
        let rates = WheelRates::new(Timestamp(0), left, right).unwrap();
        let grip = GripParams::default();
        let rows = wheel_rows(&x0, &gyro, &rates, &grip);
        let m = rows.measurement();
        // The compact rows are the dense measurement, zero off the support
        // and the gyro scale factor's column.
        prop_assert_eq!(m, wheel_measurement(&x0, &gyro, &rates, &grip));
        for j in (0..DIM).filter(|j| !SUPPORT.contains(j) && *j != KG) {
            prop_assert!(m.h.column(j).iter().all(|v| *v == 0.0));
        }
        // The per-row gate, in f64.
        let mut m = m;
        // No row's variance shrinks more than `MAX_VARIANCE_REDUCTION` times
        // in one update: its noise is raised to the prior's share.
        let prior = m.h.cast::<f64>() * p0.cast::<f64>() * m.h.transpose().cast::<f64>();
        for i in 0..4 {
            let floor = prior[(i, i)] / f64::from(MAX_VARIANCE_REDUCTION);
            if f64::from(m.noise[(i, i)]) < floor {
                m.noise[(i, i)] = floor as f32;
            }
        }
        let s = prior + m.noise.cast::<f64>();
        let ratio = |r: usize| f64::from(m.residual[r]).powi(2) / s[(r, r)] / f64::from(gate);
        // Cases within 0.1 % of the gate may fall either way in f32.
        prop_assume!((ratio(0) - 1.0).abs() > 1e-3 && (ratio(1) - 1.0).abs() > 1e-3);
        let gated = ratio(0) > 1.0 || ratio(1) > 1.0;
        // A failed differential row alone keeps the forward row.
        let forward_fused = ratio(0) < 1.0;
        // The vertical row's Huber weight: its noise raised until its
        // innovation is at `VERTICAL_HUBER` standard deviations.
        let (y_v, huber2) = (f64::from(m.residual[VERTICAL]), f64::from(VERTICAL_HUBER).powi(2));
        if y_v * y_v > huber2 * s[(VERTICAL, VERTICAL)] {
            m.noise[(VERTICAL, VERTICAL)] += (y_v * y_v / huber2 - s[(VERTICAL, VERTICAL)]) as f32;
        }
        let (mut x, mut p) = (x0, p0);
        let out = update(&mut x, &mut p, &rows, gate).unwrap();
        prop_assert_eq!(out.gated, gated);
        prop_assert_eq!(out.forward_fused, forward_fused);
        prop_assert!((f64::from(out.forward_var) - s[(0, 0)]).abs() <= 1e-4 * s[(0, 0)]);
        let (x_true, p_true, nis) = if forward_fused && gated {
            let c = m.select([0, 2, 3]).unwrap();
            let (mut xd, mut pd) = (x0, p0);
            gated_update_dense(&mut xd, &mut pd, &c, None).unwrap();
            oracle(&x0, &p0, &c)
        } else if gated {
            let c = m.select([2, 3]).unwrap();
            let (mut xd, mut pd) = (x0, p0);
            gated_update_dense(&mut xd, &mut pd, &c, None).unwrap();
            oracle(&x0, &p0, &c)
        } else {
            let (mut xd, mut pd) = (x0, p0);
            gated_update_dense(&mut xd, &mut pd, &m, None).unwrap();
            oracle(&x0, &p0, &m)
        };
        let p_true = p_true.cast::<f32>();
        prop_assert!(nis.is_finite());
        let err = normalised_error(&p, &p_true, &p0);
        prop_assert!(err < 5e-4, "covariance differs by {} (normalised)", err);
        prop_assert_eq!(p, p.transpose());
        let correction = state_error(&x0, &x_true);
        let dx_err = state_error(&x, &x_true);
        prop_assert!(dx_err <= 1e-5 + 1e-3 * correction, "state differs by {} (correction {})", dx_err, correction);
        prop_assert!(x.q_wb.quaternion().norm_squared() - 1.0 < 1e-6);
    }

    /// The reset on the upper triangle, mirrored, is the dense `G P G^T`
    /// (whatever the stale lower triangle held).
    #[test]
    fn triangle_reset_and_mirror_equal_the_dense_reset(seed in any::<u64>(), angle in 0.0f32..0.2) {
        let mut rng = Rng(seed);
        let p0 = random_covariance(&mut rng);
        let dx = ErrorState::from_fn(|_, _| angle * rng.next());
        let mut dense = p0;
        reset_dense(&mut dense, &dx);
        let mut fast = p0;
        // Garbage below the diagonal must not matter.
        for j in 0..DIM {
            for i in (j + 1)..DIM {
                fast[(i, j)] = f32::NAN;
            }
        }
        reset_upper(&mut fast, &dx);
        mirror_upper_to_lower(&mut fast);
        let err = normalised_error(&fast, &dense, &dense);
        prop_assert!(err < 1e-5, "reset differs by {}", err);
        prop_assert_eq!(fast, fast.transpose());
        prop_assert!(is_positive_definite(&fast));
    }

    /// The Rodrigues series of the IMU step's rotation is nalgebra's
    /// `Rotation3::new`, for small and large angles.
    #[test]
    fn rotation_exponential_equals_nalgebra(
        axis in prop::array::uniform3(-1.0f32..1.0),
        angle in prop_oneof![0.0f32..0.06, 0.0f32..3.0],
    ) {
        let phi = Vec3::from(axis) * angle;
        let fast = exp_so3(&phi);
        let exact = nalgebra::Rotation3::new(phi).into_inner();
        prop_assert!((fast - exact).amax() < 2e-7, "differs by {}", (fast - exact).amax());
    }

    /// The series and the Newton renormalisation give nalgebra's
    /// `q Exp(dtheta)`, for small and large angles.
    #[test]
    fn quaternion_exponential_equals_nalgebra(
        axis in prop::array::uniform3(-1.0f32..1.0),
        angle in prop_oneof![0.0f32..0.06, 0.0f32..3.0],
        start in prop::array::uniform3(-3.0f32..3.0),
    ) {
        let dtheta = Vec3::from(axis) * angle;
        let q = Quat::from_scaled_axis(Vec3::from(start));
        let fast = rotate_local(&q, &dtheta);
        let exact = q * Quat::from_scaled_axis(dtheta);
        prop_assert!(fast.angle_to(&exact) < 1e-6, "{} rad apart", fast.angle_to(&exact));
        prop_assert!((fast.quaternion().norm() - 1.0).abs() < 1e-6);
    }
}

/// A quaternion kept through many small rotations stays unit: the Newton
/// step corrects the rounding drift of every product.
#[test]
fn many_small_rotations_stay_unit() {
    let mut rng = Rng(9);
    let mut q = Quat::identity();
    let mut reference = nalgebra::UnitQuaternion::<f64>::identity();
    for _ in 0..250_000 {
        let d = rng.vec3(2e-3);
        q = rotate_local(&q, &d);
        reference *= nalgebra::UnitQuaternion::from_scaled_axis(d.cast::<f64>());
    }
    assert!((q.quaternion().norm() - 1.0).abs() < 1e-6);
    assert!(q.cast::<f64>().angle_to(&reference) < 1e-3);
}
