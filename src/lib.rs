//! # traction
//!
//! Slip-aware metric scale for monocular VSLAM and a surface-aware ego-state
//! EKF for ground robots, `#![no_std]` and allocation-free for Cortex-M4F/M7
//! firmware. This root crate re-exports the member crates; see `README.md`
//! for the crate map.
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

pub use ego_ekf;
pub use flow_sensor;
pub use vslam_core;
pub use wheel_odom;

pub mod config;
pub mod estimator;
pub mod frontend;
pub mod reorder;
