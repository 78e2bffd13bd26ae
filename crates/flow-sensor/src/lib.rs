//! # flow-sensor
//!
//! `#![no_std]` driver for the PixArt PMW3901MB (far field, >= 80 mm) and
//! PAA5100JE (near field, 15-35 mm: the part a robot vacuum uses) optical-flow
//! sensors over an embedded-hal 1.0 [`SpiDevice`](embedded_hal::spi::SpiDevice).
//! One driver, [`FlowSensor`]; the [`Variant`] chosen at construction selects
//! the power-up configuration table. It implements `vslam-core`'s
//! [`FlowSource`](vslam_core::sensors::FlowSource) (Motion_Burst reports) and
//! [`FlowFrameSource`](vslam_core::sensors::FlowFrameSource) (raw 35x35 frames).
//!
//! - [`registers`]: every address, bit field and timing of the register map;
//! - [`config`]: the variants' configuration tables as data, with sources;
//! - [`driver`]: power-up, motion, frame grab, and the exact bus transactions;
//! - [`burst`]: Motion_Burst decoding; [`orientation`]: axis conventions;
//! - [`optics`]: counts to radians and metres through `FlowOptics`.
//!
//! Sources: PixArt PMW3901MB-TXQT datasheet; Bitcraze `Bitcraze_PMW3901`;
//! Pimoroni `pmw3901-python` (`PMW3901`, `PAA5100`, `frame_capture`); PX4
//! `pmw3901` driver (counts per radian).
//!
//! # Example: a Motion_Burst into a vocabulary sample
//!
//! The driver reads the 12 burst bytes over SPI; decoding them is a pure
//! function. The deltas come low byte first, the shutter high byte first.
//!
//! ```
//! use flow_sensor::MotionBurst;
//! use vslam_core::Timestamp;
//!
//! // Motion (MOT set), Observation, dX = -3 (LE), dY = 258 (LE), SQUAL 80,
//! // RawData_Sum, Max, Min, Shutter 0x0123 (BE).
//! let bytes = [0x80, 0xBF, 0xFD, 0xFF, 0x02, 0x01, 80, 60, 120, 10, 0x01, 0x23];
//! let burst = MotionBurst::from_bytes(&bytes);
//! assert!(burst.has_motion());
//! assert_eq!((burst.delta_x, burst.delta_y, burst.shutter), (-3, 258, 0x0123));
//!
//! let sample = burst.to_sample(Timestamp::from_nanos(10_000_000));
//! assert_eq!(sample.dx, -3);
//! assert!(sample.is_valid()); // the datasheet's SQUAL / shutter rule
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

pub mod burst;
pub mod config;
pub mod driver;
pub mod error;
pub mod optics;
pub mod orientation;
pub mod registers;
pub mod variant;

pub use burst::MotionBurst;
pub use driver::{FlowSensor, Mode};
pub use error::Error;
pub use orientation::{Orientation, Rotation};
pub use variant::Variant;
