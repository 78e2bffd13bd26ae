//! Propagation: the block-structured covariance step equals the dense
//! reference `F P F^T + Q`, and `F` equals finite differences of the
//! nominal propagation.

use ego_ekf::config::{ImuConfig, ImuNoise, RobotPrior};
use ego_ekf::propagate::{
    Transition, process_noise, propagate_covariance, propagate_covariance_dense, propagate_nominal,
};
use ego_ekf::state::{Covariance, DIM, ErrorState, NominalState, Quat, Vec3};
use nalgebra::SMatrix;

fn state() -> NominalState {
    let q_wb = Quat::from_euler_angles(0.05, -0.03, 1.2);
    NominalState {
        p_wb: Vec3::new(1.0, -2.0, 0.06),
        v_wb: Vec3::new(0.25, 0.12, -0.02),
        q_wb,
        accel_bias: Vec3::new(0.01, -0.02, 0.03),
        gyro_bias: Vec3::new(0.001, 0.002, -0.003),
        gravity: Vec3::new(0.01, -0.02, -9.81),
        gyro_scale: 0.012,
        clone_p_wb: Vec3::new(1.0, -2.0, 0.06),
        clone_q_wb: q_wb,
        p_bl: Vec3::new(0.0, 0.115, -0.06),
        p_br: Vec3::new(0.0, -0.115, -0.06),
        q_rb: Quat::identity(),
        radius_left: 0.035,
        radius_right: 0.035,
    }
}

/// Error state taking `a` to `b` (`b = a [+] dx`), IMU part.
fn boxminus(b: &NominalState, a: &NominalState) -> ErrorState {
    let mut dx = ErrorState::zeros();
    dx.fixed_rows_mut::<3>(0).copy_from(&(b.p_wb - a.p_wb));
    dx.fixed_rows_mut::<3>(3).copy_from(&(b.v_wb - a.v_wb));
    dx.fixed_rows_mut::<3>(6)
        .copy_from(&(a.q_wb.inverse() * b.q_wb).scaled_axis());
    dx.fixed_rows_mut::<3>(9)
        .copy_from(&(b.accel_bias - a.accel_bias));
    dx.fixed_rows_mut::<3>(12)
        .copy_from(&(b.gyro_bias - a.gyro_bias));
    dx.fixed_rows_mut::<3>(15)
        .copy_from(&(b.gravity - a.gravity));
    dx[18] = b.gyro_scale - a.gyro_scale;
    dx
}

/// A random symmetric positive-definite matrix from a seed.
fn random_spd(seed: u64) -> Covariance {
    let mut s = seed;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32 / (1u64 << 24) as f32) - 0.5
    };
    let a = SMatrix::<f32, DIM, DIM>::from_fn(|_, _| next());
    a * a.transpose() * 0.1 + Covariance::identity() * 0.01
}

#[test]
fn block_propagation_equals_dense_reference() {
    let x = state();
    let accel = Vec3::new(0.3, -0.4, 9.9);
    let gyro = Vec3::new(0.1, -0.05, 1.3);
    let r = x.q_wb.to_rotation_matrix().into_inner();
    for seed in 0..20 {
        let dt = 0.004 * (1.0 + seed as f32 * 0.1);
        let f =
            Transition::new(&r, &accel, &gyro, dt).with_gyro_scale(&x.gyro_scale_jacobian(&gyro));
        let q = process_noise(&ImuConfig::default(), &RobotPrior::default(), dt);
        let p0 = random_spd(seed);
        let mut fast = p0;
        let mut dense = p0;
        propagate_covariance(&mut fast, &f, &q);
        propagate_covariance_dense(&mut dense, &f, &q);
        let err = (fast - dense).abs().max();
        assert!(
            err < 1e-5 * dense.abs().max(),
            "seed {seed}: max error {err}"
        );
        // The rest-to-rest block only gained Q.
        let rest = fast.fixed_view::<17, 17>(19, 19) - p0.fixed_view::<17, 17>(19, 19);
        let q_rest = Covariance::from_diagonal(&q)
            .fixed_view::<17, 17>(19, 19)
            .into_owned();
        assert!((rest - q_rest).abs().max() < 1e-6);
    }
}

#[test]
fn transition_matches_finite_differences() {
    let x0 = state();
    let accel_m = Vec3::new(0.3, -0.4, 9.9);
    let gyro_m = Vec3::new(0.1, -0.05, 1.3);
    let dt = 0.004;
    let r = x0.q_wb.to_rotation_matrix().into_inner();
    let gyro = x0.corrected_gyro(&gyro_m);
    let f = Transition::new(&r, &(accel_m - x0.accel_bias), &gyro, dt)
        .with_gyro_scale(&x0.gyro_scale_jacobian(&gyro))
        .dense();
    let step = |x: &NominalState| {
        let mut y = *x;
        propagate_nominal(
            &mut y,
            &(accel_m - x.accel_bias),
            &x.corrected_gyro(&gyro_m),
            dt,
        );
        y
    };
    let y0 = step(&x0);
    let eps = 1e-2f32;
    for j in 0..19 {
        let mut dx = ErrorState::zeros();
        dx[j] = eps;
        let mut xp = x0;
        xp.inject(&dx);
        let mut xm = x0;
        xm.inject(&(-dx));
        let d = (boxminus(&step(&xp), &y0) - boxminus(&step(&xm), &y0)) / (2.0 * eps);
        for i in 0..19 {
            assert!(
                (d[i] - f[(i, j)]).abs() < 1e-3,
                "F[{i},{j}]: numeric {} analytic {}",
                d[i],
                f[(i, j)]
            );
        }
    }
}

#[test]
fn process_noise_follows_the_state_table() {
    use ego_ekf::state::{BA, BG, CL, CP, CR, G, KG, P, RAD, RB, TH, V};
    let imu = ImuConfig {
        noise: ImuNoise {
            accel_density: 2.0,
            gyro_density: 3.0,
            accel_random_walk: 5.0,
            gyro_random_walk: 7.0,
        },
        gyro_scale_random_walk: 19.0,
        ..ImuConfig::default()
    };
    let robot = RobotPrior {
        contact_random_walk: 11.0,
        rotation_random_walk: 13.0,
        radius_random_walk: 17.0,
        ..RobotPrior::default()
    };
    let q = process_noise(&imu, &robot, 0.5);
    let expected = [
        (P, 3, 0.0),
        (V, 3, 2.0),
        (TH, 3, 3.0),
        (BA, 3, 5.0),
        (BG, 3, 7.0),
        (G, 3, 0.0),
        (KG, 1, 19.0),
        (CL, 3, 11.0),
        (CR, 3, 11.0),
        (RB, 3, 13.0),
        (RAD, 2, 17.0),
        (CP, 6, 0.0),
    ];
    let mut covered = 0;
    for (start, len, density) in expected {
        for i in start..start + len {
            assert_eq!(q[i], density * density * 0.5, "row {i}");
        }
        covered += len;
    }
    assert_eq!(covered, DIM);
}
