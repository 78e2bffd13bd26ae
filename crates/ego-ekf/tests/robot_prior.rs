//! The robot description reaches the filter: the IMU's mounting places the
//! wheel contact points and the body-to-robot rotation of the prior, and an
//! invalid description is refused before a filter exists.

use ego_ekf::EgoEkf;
use ego_ekf::config::{FilterConfig, RobotPrior};
use nalgebra::{Rotation3, Vector3};
use vslam_core::geometry::Extrinsics;
use vslam_core::robot::{MountedSensor, RobotDescription, RobotError};

/// The IMU turned 90 degrees about z, tilted 5 degrees, 4 cm ahead, 2 cm
/// right of the axle and 6 cm above the floor.
fn turned_imu() -> RobotDescription {
    let mut r = RobotDescription::robot_vacuum();
    let rot = Rotation3::from_euler_angles(0.0, 0.087, core::f32::consts::FRAC_PI_2);
    r.imu.mount = Extrinsics::new(rot, Vector3::new(0.04, -0.02, 0.06)).unwrap();
    r
}

#[test]
fn imu_mounting_places_the_contact_points_and_q_rb() {
    let r = turned_imu();
    let prior = FilterConfig::from_robot(&r).unwrap().robot;
    let m = r.imu.mount;
    let half = 0.5 * r.wheels.track;
    // Back into the body frame, the contact points are where the wheels touch.
    let left_b = m.point_to_body(&prior.p_bl);
    let right_b = m.point_to_body(&prior.p_br);
    assert!(
        (left_b - Vector3::new(0.0, half, 0.0)).norm() < 1e-6,
        "{left_b}"
    );
    assert!(
        (right_b - Vector3::new(0.0, -half, 0.0)).norm() < 1e-6,
        "{right_b}"
    );
    // In the IMU frame they are not where the identity mounting puts them.
    let plain = RobotPrior::from_robot(&RobotDescription::robot_vacuum());
    assert!((prior.p_bl - plain.p_bl).norm() > 0.05);
    // q_rb turns IMU vectors into the robot (body) frame.
    let v_i = Vector3::new(0.3, -0.1, 0.2);
    assert!((prior.q_rb * v_i - m.vector_to_body(&v_i)).norm() < 1e-6);

    // The filter's wheel model (robot velocity = q_rb (v_I + w_I x p_robot))
    // gives the robot's own forward speed and no side slip for a body that
    // drives at v and turns at w, measured by the turned, offset IMU.
    let (v, w) = (0.4_f32, 0.7_f32);
    let w_b = Vector3::new(0.0, 0.0, w);
    let v_imu_b = Vector3::new(v, 0.0, 0.0) + w_b.cross(m.t_bs());
    let (v_i, w_i) = (m.vector_to_sensor(&v_imu_b), m.vector_to_sensor(&w_b));
    let p_robot = 0.5 * (prior.p_bl + prior.p_br);
    let robot_v = prior.q_rb * (v_i + w_i.cross(&p_robot));
    assert!(
        (robot_v - Vector3::new(v, 0.0, 0.0)).norm() < 1e-5,
        "{robot_v}"
    );

    // The filter starts from this prior.
    let ekf = EgoEkf::new(FilterConfig::from_robot(&r).unwrap()).unwrap();
    assert_eq!(ekf.state().p_bl, prior.p_bl);
    assert_eq!(ekf.state().q_rb, prior.q_rb);
}

#[test]
fn identity_mounting_puts_the_contact_points_on_the_axle() {
    let r = RobotDescription::robot_vacuum();
    let c = FilterConfig::from_robot(&r).unwrap();
    assert_eq!(c.robot.p_bl, Vector3::new(0.0, 0.115, 0.0));
    assert_eq!(c.robot.p_br, Vector3::new(0.0, -0.115, 0.0));
    assert_eq!(c.robot.q_rb, nalgebra::UnitQuaternion::identity());
    assert_eq!(c.robot.radius, 0.035);
    assert_eq!(c.imu.noise, r.imu.noise);
    let flow = c.flow.unwrap();
    let described = r.flow.unwrap();
    assert_eq!(flow.optics.height(), described.height);
    assert_eq!(*flow.optics.mount(), described.mount);
    assert_eq!(flow.relative_std, described.relative_std);
}

#[test]
fn invalid_descriptions_build_no_filter_config() {
    let mut r = RobotDescription::robot_vacuum();
    r.wheels.radius_left = 0.0;
    assert_eq!(
        FilterConfig::from_robot(&r),
        Err(RobotError::BadWheelRadius)
    );
    let mut r = RobotDescription::robot_vacuum();
    r.wheels.track = f32::NAN;
    assert_eq!(FilterConfig::from_robot(&r), Err(RobotError::BadTrack));
    let mut r = turned_imu();
    r.imu.noise.accel_random_walk = f32::NAN;
    assert_eq!(
        FilterConfig::from_robot(&r),
        Err(RobotError::BadNoise(Some(MountedSensor::Imu)))
    );
}
