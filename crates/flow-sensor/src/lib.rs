//! # flow-sensor
//!
//! `#![no_std]` driver for the PixArt PMW3901 / PAA5100JE optical-flow sensors
//! over embedded-hal 1.0 `SpiDevice`. It implements `vslam-core`'s
//! `FlowSource` and `FlowFrameSource` traits. The driver itself is built in
//! its own issue; this crate is the place it lives.
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
