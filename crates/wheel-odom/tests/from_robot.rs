//! Odometry parameters from a robot description: the description's wheels,
//! and its refusals.

use vslam_core::robot::{RobotDescription, RobotError};
use wheel_odom::odometry::DiffDriveParams;

#[test]
fn the_described_wheels_become_the_parameters() {
    let mut r = RobotDescription::robot_vacuum();
    r.wheels.radius_left = 0.036;
    r.wheels.track_factor = 1.25;
    let p = DiffDriveParams::from_robot(&r).unwrap();
    assert_eq!(p.ticks_per_revolution(), 16_384);
    assert_eq!(p.left_radius(), 0.036);
    assert_eq!(p.right_radius(), 0.035);
    // A skid steer turns as if its wheels were further apart.
    assert_eq!(p.wheel_base(), 0.23 * 1.25);
    assert_eq!(p.max_wheel_speed(), 3.0);
    assert_eq!(p.max_step_ns(), DiffDriveParams::MAX_STEP_NS);
}

#[test]
fn a_bad_description_is_refused_with_its_reason() {
    let mut r = RobotDescription::robot_vacuum();
    r.wheels.radius_right = f32::NAN;
    assert_eq!(
        DiffDriveParams::from_robot(&r),
        Err(RobotError::BadWheelRadius)
    );
    let mut r = RobotDescription::robot_vacuum();
    r.wheels.counts_per_revolution = 0;
    assert_eq!(
        DiffDriveParams::from_robot(&r),
        Err(RobotError::BadEncoderResolution)
    );
    // A broken flow mounting is refused here too: one description, one check.
    let mut r = RobotDescription::robot_vacuum();
    r.flow.as_mut().unwrap().height = -0.03;
    assert_eq!(
        DiffDriveParams::from_robot(&r),
        Err(RobotError::FlowBelowFloor)
    );
}
