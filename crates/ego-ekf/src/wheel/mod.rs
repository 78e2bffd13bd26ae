//! Wheel odometry: *when to fuse* in [`fusion`], *the maths* in [`model`].

pub mod fusion;
pub mod model;

pub use fusion::{WheelFusion, WheelInnovation};
