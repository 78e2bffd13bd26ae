//! The simulated robot's build from the library's robot-vacuum preset
//! ([`RobotDescription::robot_vacuum`]), so the robot host-sim simulates and
//! the robot the estimator is configured for are written down once.
//!
//! The preset is `f32`, the simulator `f64`: each number is carried over as
//! the decimal the preset writes (`0.035_f32` becomes `0.035_f64`, not the
//! `f32`'s binary value widened), which is what a `sensor.yaml` would say.

use traction::vslam_core::robot::RobotDescription;

/// The robot-vacuum preset.
pub fn preset() -> RobotDescription {
    RobotDescription::robot_vacuum()
}

/// The decimal an `f32` is written as (its shortest round-trip form), as `f64`.
pub fn decimal(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_keeps_the_written_number() {
        assert_eq!(decimal(0.035), 0.035);
        assert_eq!(decimal(48.8), 48.8);
        assert_eq!(decimal(1.7e-3), 1.7e-3);
        assert_ne!(f64::from(0.035_f32), 0.035);
    }

    #[test]
    fn the_encoder_chip_counts_what_the_preset_says() {
        assert_eq!(
            f64::from(preset().wheels.counts_per_revolution),
            super::super::drivers::ENCODER_COUNTS
        );
    }
}
