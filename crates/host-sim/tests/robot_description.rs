//! The simulated robot is the preset: a simulated dataset's `sensor.yaml`
//! files describe exactly `RobotDescription::robot_vacuum()`, so the replay's
//! configuration of simulated data is the preset's.

mod common;

use host_sim::asl::{read_dataset, write_dataset};
use host_sim::replay::robot_description;
use host_sim::sim::scenario::{Scenario, generate};
use traction::estimator::EstimatorConfig;
use traction::vslam_core::robot::{RobotDescription, RobotError};

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-robot", name)
}

fn simulated(name: &str) -> (common::Scratch, host_sim::asl::Dataset) {
    let root = tmp(name);
    let mut sc = Scenario::by_name("short").unwrap();
    sc.script.duration = 0.5;
    let (ds, _) = generate(&sc, 1, &root).unwrap();
    write_dataset(&root, &ds).unwrap();
    let ds = read_dataset(&root).unwrap();
    (root, ds)
}

#[test]
fn the_simulated_dataset_describes_the_preset() {
    let (root, ds) = simulated("preset");
    let robot = robot_description(&ds, &root).unwrap();
    assert_eq!(robot, RobotDescription::robot_vacuum());
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_bad_sensor_yaml_is_refused_naming_the_file() {
    let (root, mut ds) = simulated("bad");
    ds.wheel.as_mut().unwrap().0.wheel_radius_left = 0.0;
    let e = robot_description(&ds, &root).unwrap_err().to_string();
    assert!(e.contains("wheel0"), "{e}");
    assert!(e.contains(&RobotError::BadWheelRadius.to_string()), "{e}");
    let (root2, mut ds) = simulated("bad-flow");
    ds.flow.as_mut().unwrap().0.height = -0.03;
    let e = robot_description(&ds, &root2).unwrap_err().to_string();
    assert!(e.contains("flow0"), "{e}");
    // Without the flow sensor, the configuration has none.
    ds.flow = None;
    let robot = robot_description(&ds, &root2).unwrap();
    let config = EstimatorConfig::from_robot(&robot).unwrap();
    assert!(config.filter.flow.is_none() && config.scale.flow_optics.is_none());
    let _ = std::fs::remove_dir_all(&root);
    let _ = std::fs::remove_dir_all(&root2);
}
