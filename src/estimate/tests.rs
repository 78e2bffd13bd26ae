//! The body pose is the IMU pose moved by the mounting; the covariance is
//! the EKF's carried through that map (checked against finite differences).

use super::*;
use crate::{Estimator, EstimatorConfig, RobotDescription};
use nalgebra::{Rotation3, SMatrix};
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{RawImuSample, WheelTicks};

const G: f32 = 9.806_65;

/// A robot vacuum whose IMU sits 6 cm above the floor, 5 cm ahead of and
/// 2 cm right of the axle's middle, turned 30 degrees in yaw and 3 in roll.
fn mounted_robot() -> (RobotDescription, Extrinsics) {
    let mut robot = RobotDescription::robot_vacuum();
    let mount = Extrinsics::new(
        Rotation3::from_euler_angles(0.05, 0.0, 30f32.to_radians()),
        Vec3::new(0.05, -0.02, 0.06),
    )
    .unwrap();
    robot.imu.mount = mount;
    (robot, mount)
}

/// `seconds` of IMU at 250 Hz and wheels at 50 Hz: 1 s standing, then the
/// body speeds up along its x axis at 0.5 m/s^2 for 0.2 s and rolls on at
/// 0.1 m/s.
fn drive(robot: &RobotDescription, seconds: f32) -> Estimator<'static> {
    let mount = robot.imu.mount;
    let config = EstimatorConfig::from_robot(robot).unwrap();
    let mut est = Estimator::new(&config, None).unwrap();
    let counts_per_metre = robot.wheels.counts_per_revolution as f32
        / (2.0 * core::f32::consts::PI * robot.wheels.radius_left);
    let steps = (seconds * 250.0) as u64;
    for k in 0..steps {
        let t = Timestamp::from_nanos(k * 4_000_000);
        let s = (k as f32 * 0.004 - 1.0).max(0.0);
        let ax = if s > 0.0 && s <= 0.2 { 0.5 } else { 0.0 };
        let x = if s <= 0.2 {
            0.25 * s * s
        } else {
            0.01 + 0.1 * (s - 0.2)
        };
        let a_i = mount.vector_to_sensor(&Vec3::new(ax, 0.0, G));
        est.offer_imu(RawImuSample {
            t,
            gyro: [0.0; 3],
            accel: [a_i.x, a_i.y, a_i.z],
        });
        if k % 5 == 0 {
            let ticks = (x * counts_per_metre) as i64;
            est.offer_wheel(WheelTicks {
                t,
                left: ticks,
                right: ticks,
            });
        }
        while est.poll().is_some() {}
    }
    est.finish();
    while est.poll().is_some() {}
    est
}

/// Where B is, seen from the IMU pose and the description's mounting:
/// `p_WB = p_WI + R_WI R_BS^T (0 - t_BS)`, `R_WB = R_WI R_BS^T`.
fn body_from_imu(p_wi: Vec3, q_wi: Quat, mount: &Extrinsics) -> (Vec3, Quat) {
    let r_bs = Quat::from_rotation_matrix(mount.r_bs());
    (
        p_wi + q_wi * (r_bs.inverse() * -mount.t_bs()),
        q_wi * r_bs.inverse(),
    )
}

#[test]
fn no_estimate_before_the_filter_starts() {
    let (robot, _) = mounted_robot();
    let est = drive(&robot, 0.1);
    assert!(est.estimate().is_none());
}

#[test]
fn the_body_pose_is_the_imu_pose_moved_by_the_mounting() {
    let (robot, mount) = mounted_robot();
    // Standing: the filter's robot states are still the description's.
    let est = drive(&robot, 0.9);
    let e = est.estimate().unwrap();
    let ekf = est.ekf();
    assert_eq!(e.t, ekf.time().unwrap());
    let (p, q) = body_from_imu(ekf.position(), ekf.attitude(), &mount);
    assert!((e.p_wb - p).norm() < 1e-5, "{} vs {p}", e.p_wb);
    assert!(e.q_wb.angle_to(&q) < 1e-5, "{:?} vs {q:?}", e.q_wb);
    // The IMU started at the origin, level after its roll: the body is
    // 6 cm below it, its yaw the mounting's 30 degrees the other way.
    assert!((e.p_wb.z + 0.06).abs() < 2e-3, "{}", e.p_wb);
    assert!((e.yaw() + 30f32.to_radians()).abs() < 2e-3, "{}", e.yaw());
    assert!(e.aids.zero_velocity && !e.aids.flow, "{:?}", e.aids);

    // Driving: the filter refines the contact points by millimetres at most.
    let est = drive(&robot, 3.0);
    let e = est.estimate().unwrap();
    let ekf = est.ekf();
    let (p, q) = body_from_imu(ekf.position(), ekf.attitude(), &mount);
    assert!((e.p_wb - p).norm() < 5e-3, "{} vs {p}", e.p_wb);
    assert!(e.q_wb.angle_to(&q) < 5e-3);
    // B moves along its own x axis at 0.1 m/s.
    assert!(
        (e.v_b - Vec3::new(0.1, 0.0, 0.0)).norm() < 0.02,
        "{}",
        e.v_b
    );
    assert!(e.aids.wheels && !e.aids.zero_velocity, "{:?}", e.aids);
}

#[test]
fn the_body_pose_is_not_the_imu_pose() {
    // Fails if the lever arm or the mounting rotation is dropped.
    let (robot, mount) = mounted_robot();
    let est = drive(&robot, 3.0);
    let e = est.estimate().unwrap();
    let ekf = est.ekf();
    let d = e.p_wb - ekf.position();
    assert!(
        (d.norm() - mount.t_bs().norm()).abs() < 5e-3,
        "body {} imu {}",
        e.p_wb,
        ekf.position()
    );
    assert!((e.q_wb.angle_to(&ekf.attitude()) - 30f32.to_radians()).abs() < 0.06);
}

/// B's pose of a nominal state, by the module's formula.
fn pose_of(x: &ego_ekf::state::NominalState) -> (Vec3, Quat) {
    (x.p_wb + x.q_wb * x.p_b_robot(), x.q_wb * x.q_rb.inverse())
}

#[test]
fn the_jacobian_matches_finite_differences() {
    let (robot, _) = mounted_robot();
    let est = drive(&robot, 3.0);
    let x0 = *est.ekf().state();
    let (p0, q0) = pose_of(&x0);
    let r_wi = x0.q_wb.to_rotation_matrix().into_inner();
    let j = jacobian(&r_wi, &x0.p_b_robot());
    let h = 1e-3;
    for (col, i) in SUPPORT.iter().flat_map(|&s| [s, s + 1, s + 2]).enumerate() {
        let mut dx = ego_ekf::state::ErrorState::zeros();
        dx[i] = h;
        let mut x = x0;
        x.inject(&dx);
        let (p, q) = pose_of(&x);
        let dp = (p - p0) / h;
        let eps = (q * q0.inverse()).scaled_axis() / h;
        for r in 0..3 {
            assert!((dp[r] - j[(r, col)]).abs() < 2e-3, "dp[{r}] column {i}");
            assert!(
                (eps[r] - j[(r + 3, col)]).abs() < 2e-3,
                "eps[{r}] column {i}"
            );
        }
    }
}

#[test]
fn the_covariance_is_symmetric_positive_semi_definite() {
    let (robot, _) = mounted_robot();
    let est = drive(&robot, 3.0);
    let c = est.estimate().unwrap().covariance;
    assert_eq!(c, c.transpose());
    let c64: SMatrix<f64, 6, 6> = c.cast();
    let eig = c64.symmetric_eigenvalues();
    assert!(eig.iter().all(|&v| v >= -1e-12), "{eig}");
    assert!(eig.iter().all(|&v| v.is_finite()));
    // The planar part is the same numbers.
    let e = est.estimate().unwrap();
    let pc = e.planar_covariance();
    assert_eq!(pc[(0, 0)], c[(0, 0)]);
    assert_eq!(pc[(2, 2)], c[(5, 5)]);
    assert_eq!(pc[(0, 2)], c[(0, 5)]);
}
