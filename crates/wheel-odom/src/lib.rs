//! # wheel-odom
//!
//! `#![no_std]` wheel encoder drivers (software quadrature, hardware counter
//! extension, AS5047P over SPI) and differential-drive odometry. It implements
//! `vslam-core`'s `WheelEncoderSource`. Built in its own issue.
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
