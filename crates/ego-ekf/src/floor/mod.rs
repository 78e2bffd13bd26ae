//! The robot is on a floor: a planar-motion pseudo-measurement of the robot
//! origin's height over the floor plane and of its vertical velocity.
//! *When to fuse* (every few IMU steps, the gate, re-anchoring the floor on
//! a new level) in [`fusion`], *the maths* in [`model`].
//!
//! Without it the vertical position is unobservable (the wheel and flow
//! updates measure velocities) and random-walks; with it the height stays
//! on the floor and the pose clone's rows of the covariance stay positive
//! definite. After the planar-motion constraints of wheeled VIO (Wu et al.,
//! "VINS on wheels", ICRA 2017, sec. IV-B: a stochastic constraint with a
//! noise that allows for an uneven floor).

pub mod fusion;
pub mod model;

pub use fusion::FloorFusion;
