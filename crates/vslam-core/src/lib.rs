//! # vslam-core
//!
//! The core of traction, `#![no_std]`, no allocator, `f32`:
//!
//! - the shared vocabulary every crate speaks: [`time`] (integer nanoseconds),
//!   [`geometry`] (frames and `T_BS` mountings), [`sensors`] (raw and validated
//!   samples, the sensor traits drivers implement), [`reject`] (why a sample was
//!   not fused, and the counts), [`robot`] (the robot description: wheels,
//!   mountings, sensor noise);
//! - the vision front end: [`image`] views, image [`pyramid`]s, Shi-Tomasi
//!   [`corners`], the pyramidal Lucas-Kanade tracker [`lk`], [`homography`]
//!   estimation (four-point, normalised DLT, RANSAC, refinement) and its
//!   [`decompose`]ition into `{R, t/d, n}`;
//! - metric scale: [`scale`] (transactions, slip, selection, running scale,
//!   [`scale::ScalePipeline`]), [`adverse`] (where sensors went wrong) and
//!   [`pose`] (trajectory composition).
//!
//! What it will not do: allocate, panic on data, read files or talk to a bus.
//! Failure is a value: small error enums per operation.
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

pub mod adverse;
pub mod corners;
pub mod decompose;
pub mod geometry;
pub mod homography;
pub mod image;
pub mod lk;
pub mod pose;
pub mod pyramid;
pub mod reject;
pub mod robot;
pub mod scale;
pub mod sensors;
pub mod time;

pub use reject::{Reject, SampleCounts};
pub use robot::{RobotDescription, RobotError};
pub use time::{SampleClock, Timestamp};
