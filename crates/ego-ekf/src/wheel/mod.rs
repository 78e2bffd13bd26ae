//! Wheel odometry: *when to fuse* in [`fusion`], *the maths* in [`model`]
//! (the measurement) and [`update`] (gate and fast update); a skid steer's
//! effective track in [`skid`].

pub mod distrust;
pub mod fusion;
pub mod model;
pub mod skid;
pub mod update;

pub use fusion::{WheelFusion, WheelInnovation};
