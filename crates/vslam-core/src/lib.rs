//! # vslam-core
//!
//! The core of traction, `#![no_std]`, no allocator, `f32`:
//!
//! - the shared vocabulary every crate speaks: [`time`] (integer nanoseconds),
//!   [`geometry`] (frames and `T_BS` mountings), [`sensors`] (raw and validated
//!   samples, the sensor traits drivers implement, flow optics), [`kinematics`]
//!   (differential drive and lever arm, one home each), [`stream`] (the sensor
//!   registry: every kind of sample, and arrays indexed by it), [`reject`] (why
//!   a sample was not fused, and the counts), [`robot`] (the robot
//!   description: wheels, mountings, sensor noise);
//! - the vision front end: [`image`] views, image [`pyramid`]s, Shi-Tomasi
//!   [`corners`], the pyramidal Lucas-Kanade tracker [`lk`], [`homography`]
//!   estimation (four-point, normalised DLT, RANSAC, refinement) and its
//!   [`decompose`]ition into `{R, t/d, n}`; [`flow_frames`]: corners and
//!   Lucas-Kanade on a flow sensor's raw 35x35 frames;
//! - metric scale: [`scale`] (transactions, slip, selection, running scale,
//!   [`scale::ScalePipeline`]), [`adverse`] (where sensors went wrong) and
//!   [`pose`] (trajectory composition).
//!
//! What it will not do: allocate (without `std`), panic on data, read files
//! or talk to a bus. Failure is a value: small error enums per operation.
//!
//! Feature `std` (off by default; it only adds): on x86-64 the Lucas-Kanade
//! row kernels get AVX2 copies, and the template fill and the mismatch sweep
//! hand-written AVX2 intrinsics (`lk::avx2`), picked at run time when the CPU
//! has AVX2, with the same results bit for bit (2.91 M against 8.07 M
//! instructions per tracking call of the `lk` bench's input,
//! `benches/README.md`). With AVX2 a tracking call also copies the coarse
//! pyramid levels its windows hang over, edges repeated, into heap buffers
//! that live for the call (`lk::borders`, with their table): the only
//! allocations `std` adds.
//!
//! # Example: a homography from four matches, and time as integers
//!
//! ```
//! use vslam_core::geometry::Vec2;
//! use vslam_core::homography::four_point::from_four_points;
//! use vslam_core::Timestamp;
//!
//! // A square seen in image 1, and the same square moved by (10, -4) px in image 2.
//! let p1 = [
//!     Vec2::new(10.0, 10.0),
//!     Vec2::new(110.0, 10.0),
//!     Vec2::new(110.0, 90.0),
//!     Vec2::new(10.0, 90.0),
//! ];
//! let p2 = p1.map(|p| p + Vec2::new(10.0, -4.0));
//! let h = from_four_points(&p1, &p2)?;
//! let moved = h.transfer(&Vec2::new(60.0, 50.0)).ok_or("point at infinity")?;
//! assert!((moved - Vec2::new(70.0, 46.0)).norm() < 1e-3);
//!
//! // Degenerate geometry is a value, not a panic.
//! let collinear = [p1[0], p1[1], Vec2::new(210.0, 10.0), Vec2::new(310.0, 10.0)];
//! assert!(from_four_points(&collinear, &p2).is_err());
//!
//! // Timestamps are integer nanoseconds; seconds only at the point of use.
//! let (t0, t1) = (Timestamp::from_nanos(1_000_000_000), Timestamp::from_nanos(1_004_000_000));
//! assert_eq!(t1.nanos_since(t0), Some(4_000_000));
//! assert_eq!(t0.nanos_since(t1), None); // out of order is refused
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
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
pub mod disagree;
pub mod flow_frames;
pub mod fsqrt;
pub mod geometry;
pub mod homography;
pub mod image;
pub mod kinematics;
pub mod lk;
pub mod pose;
pub mod pyramid;
pub mod reject;
pub mod robot;
pub mod sad;
pub mod scale;
pub mod segment;
pub mod sensors;
pub mod stream;
pub mod time;

pub use reject::{Reject, SampleCounts};
pub use robot::{RobotDescription, RobotError};
pub use stream::{PerStream, Stream, StreamCounts};
pub use time::{SampleClock, Timestamp};
