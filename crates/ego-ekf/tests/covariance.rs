//! Covariance bookkeeping against dense references: the pose clone
//! (`J P J^T`), the error reset (`G P G^T`), and the update's symmetric form
//! against the Joseph form.

use ego_ekf::covariance::{clone_pose, is_positive_definite, reset, skew};
use ego_ekf::state::{
    CP, CTH, Covariance, DIM, ErrorState, NominalState, P, Quat, RAD, RB, TH, Vec3,
};
use ego_ekf::update::{Measurement, gated_update};
use nalgebra::{Matrix3, SMatrix, SVector};
use vslam_core::Reject;

fn random_spd(seed: u64) -> Covariance {
    let mut s = seed;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 40) as f32 / (1u64 << 24) as f32) - 0.5
    };
    let a = SMatrix::<f32, DIM, DIM>::from_fn(|_, _| next());
    a * a.transpose() * 0.1 + Covariance::identity() * 0.05
}

fn nominal() -> NominalState {
    NominalState {
        p_wb: Vec3::new(1.0, 2.0, 0.1),
        v_wb: Vec3::new(0.2, 0.0, 0.0),
        q_wb: Quat::from_euler_angles(0.01, 0.02, 0.5),
        accel_bias: Vec3::zeros(),
        gyro_bias: Vec3::zeros(),
        gravity: Vec3::new(0.0, 0.0, -9.81),
        gyro_scale: 0.004,
        clone_p_wb: Vec3::new(1.0, 2.0, 0.1),
        clone_q_wb: Quat::from_euler_angles(0.01, 0.02, 0.5),
        p_bl: Vec3::new(0.0, 0.115, -0.06),
        p_br: Vec3::new(0.0, -0.115, -0.06),
        q_rb: Quat::identity(),
        radius_left: 0.035,
        radius_right: 0.035,
    }
}

#[test]
fn clone_equals_dense_copy_jacobian() {
    for seed in 0..5 {
        let p0 = random_spd(seed);
        let mut j = Covariance::identity();
        j.fixed_view_mut::<6, 6>(CP, CP).fill(0.0);
        j.fixed_view_mut::<3, 3>(CP, P)
            .copy_from(&Matrix3::identity());
        j.fixed_view_mut::<3, 3>(CTH, TH)
            .copy_from(&Matrix3::identity());
        let mut expected = j * p0 * j.transpose();
        for k in 0..3 {
            expected[(CP + k, CP + k)] += 1e-6;
            expected[(CTH + k, CTH + k)] += 2e-6;
        }
        let mut p = p0;
        clone_pose(&mut p, 1e-6, 2e-6);
        assert!((p - expected).abs().max() < 1e-5, "seed {seed}");
        assert!(is_positive_definite(&p));
    }
}

#[test]
fn reset_equals_dense_g_p_gt() {
    let p0 = random_spd(11);
    let mut dx = ErrorState::zeros();
    dx.fixed_rows_mut::<3>(TH)
        .copy_from(&Vec3::new(0.01, -0.02, 0.03));
    dx.fixed_rows_mut::<3>(CTH)
        .copy_from(&Vec3::new(-0.01, 0.0, 0.02));
    dx.fixed_rows_mut::<3>(RB)
        .copy_from(&Vec3::new(0.0, 0.005, -0.01));
    let mut g = Covariance::identity();
    for i in [TH, CTH, RB] {
        let b = Matrix3::identity() - skew(&(dx.fixed_rows::<3>(i) * 0.5));
        g.fixed_view_mut::<3, 3>(i, i).copy_from(&b);
    }
    let expected = g * p0 * g.transpose();
    let mut p = p0;
    reset(&mut p, &dx);
    assert!((p - expected).abs().max() < 1e-5);
}

#[test]
fn update_matches_joseph_form_and_gates() {
    let p0 = random_spd(5);
    let mut h = SMatrix::<f32, 3, DIM>::zeros();
    h.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&Matrix3::identity());
    h[(0, RAD)] = -2.5;
    h[(1, 7)] = 0.3;
    let noise = SMatrix::<f32, 3, 3>::identity() * 0.01;
    let m = Measurement {
        residual: SVector::<f32, 3>::new(0.01, -0.02, 0.005),
        h,
        noise,
    };
    // Joseph form with the optimal gain, before the reset.
    let s = h * p0 * h.transpose() + noise;
    let k = p0 * h.transpose() * s.try_inverse().unwrap();
    let ikh = Covariance::identity() - k * h;
    let joseph = ikh * p0 * ikh.transpose() + k * noise * k.transpose();
    let dx = k * m.residual;
    let mut g = Covariance::identity();
    for i in [TH, CTH, RB] {
        let b = Matrix3::identity() - skew(&(dx.fixed_rows::<3>(i) * 0.5));
        g.fixed_view_mut::<3, 3>(i, i).copy_from(&b);
    }
    let expected = g * joseph * g.transpose();
    let mut x = nominal();
    let mut p = p0;
    let report = gated_update(&mut x, &mut p, &m, Some(100.0)).unwrap();
    assert!(
        (p - expected).abs().max() < 1e-4,
        "{}",
        (p - expected).abs().max()
    );
    assert!((x.v_wb - (nominal().v_wb + dx.fixed_rows::<3>(3))).norm() < 1e-5);
    let nis = (m.residual.transpose() * s.try_inverse().unwrap() * m.residual)[(0, 0)];
    assert!((report.nis - nis).abs() < 1e-3 * nis.max(1.0));
    // A gate below the NIS refuses the update and changes nothing.
    let mut x2 = nominal();
    let mut p2 = p0;
    assert_eq!(
        gated_update(&mut x2, &mut p2, &m, Some(nis * 0.5)),
        Err(Reject::Gated)
    );
    assert_eq!(p2, p0);
    assert_eq!(x2, nominal());
    // A non-finite residual is refused.
    let mut bad = m;
    bad.residual[1] = f32::NAN;
    assert_eq!(
        gated_update(&mut x2, &mut p2, &bad, None),
        Err(Reject::NonFinite)
    );
}

#[test]
fn the_initial_covariance_follows_the_state_table() {
    use ego_ekf::config::{InitConfig, RobotPrior};
    use ego_ekf::covariance::initial_variances;
    use ego_ekf::state::{BA, BG, CL, CR, G, KG, V};
    let init = InitConfig {
        position_std: 2.0,
        velocity_std: 3.0,
        tilt_std: 5.0,
        yaw_std: 7.0,
        accel_bias_std: 11.0,
        gyro_bias_std: 13.0,
        gravity_std: 17.0,
        gyro_scale_std: 31.0,
        ..InitConfig::default()
    };
    let robot = RobotPrior {
        contact_std: 19.0,
        rotation_std: 23.0,
        radius_std: 29.0,
        ..RobotPrior::default()
    };
    let d = initial_variances(&init, &robot);
    let stds = [
        (P, 3, 2.0),
        (V, 3, 3.0),
        (TH, 2, 5.0),
        (TH + 2, 1, 7.0),
        (BA, 3, 11.0),
        (BG, 3, 13.0),
        (G, 3, 17.0),
        (KG, 1, 31.0),
        (CL, 3, 19.0),
        (CR, 3, 19.0),
        (RB, 3, 23.0),
        (RAD, 2, 29.0),
        (CP, 6, 0.0),
    ];
    let mut expected = ErrorState::zeros();
    for (start, len, std) in stds {
        expected.rows_mut(start, len).fill(std * std);
    }
    assert_eq!(d, expected);
    assert_eq!(CTH, CP + 3);
}
