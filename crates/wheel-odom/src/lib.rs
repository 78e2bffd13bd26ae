//! # wheel-odom
//!
//! `#![no_std]` wheel encoder drivers and differential-drive odometry:
//!
//! - [`quadrature`]: software x4 quadrature decoding of sampled A/B levels,
//!   illegal transitions counted, never guessed;
//! - [`counter`]: wrapping 16/32-bit (or 14-bit angle) counts extended to
//!   `i64`, impossible jumps refused and counted;
//! - [`as5047p`]: the ams AS5047P 14-bit magnetic encoder over an
//!   embedded-hal 1.0 `SpiDevice` (parity, error flags, DIAAGC), with the
//!   register map in [`registers`];
//! - [`encoder`]: encoders as cumulative counts and a pair of them as
//!   `vslam-core`'s `WheelEncoderSource`;
//! - [`arc`] and [`odometry`]: exact arc integration of a differential drive,
//!   wheel rates and body velocity, time validated and outcomes counted.
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

pub mod arc;
pub mod as5047p;
pub mod counter;
pub mod encoder;
pub mod odometry;
pub mod quadrature;
pub mod registers;

pub use as5047p::{As5047p, As5047pError, Diagnostics, ErrorFlags};
pub use counter::{CounterConfigError, CounterError, CounterExtender};
pub use encoder::{
    As5047pEncoder, CounterEncoder, CumulativeEncoder, EncoderError, PairError, Polarity,
    RawCounter, WheelPair,
};
pub use odometry::{BodyVelocity, DiffDriveOdometry, DiffDriveParams, OdometryStep, ParamsError};
pub use quadrature::{QuadStep, QuadratureDecoder};
