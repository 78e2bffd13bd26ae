//! # ego-ekf
//!
//! `#![no_std]` 250 Hz error-state EKF for a ground robot: IMU state, a pose
//! clone and robot state (wheel contact points, body-to-robot rotation, wheel
//! radii), with surface-aware wheel-velocity fusion. Built in its own issue.
#![no_std]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod grip;
pub use grip::{GripError, GripParams};
pub mod events;
pub mod surface;
