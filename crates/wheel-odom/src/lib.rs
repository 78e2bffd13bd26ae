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
//!   wheel rates and body velocity, time validated and outcomes counted; no
//!   step spans a failed encoder read that may break the counts
//!   ([`read_breaks`]), and a step across missed reads is kept only when it
//!   continues the previous one.
//!
//! # Example: one AS5047P angle read over SPI
//!
//! The driver is generic over an embedded-hal 1.0 `SpiDevice`; here a mock
//! bus plays the chip. A read is two 16-bit frames: the read command for
//! ANGLECOM (0x3FFF, with the read bit and even parity: 0xFFFF), then a NOP
//! whose answer carries the angle (0x1234, parity bit set: 0x9234).
//!
//! ```
//! use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
//! use wheel_odom::{As5047p, As5047pError};
//!
//! let frame = |tx: u16, rx: u16| {
//!     [
//!         T::transaction_start(),
//!         T::transfer_in_place(tx.to_be_bytes().to_vec(), rx.to_be_bytes().to_vec()),
//!         T::transaction_end(),
//!     ]
//! };
//! let script: Vec<T<u8>> = [frame(0xFFFF, 0x0000), frame(0x0000, 0x9234)].concat();
//! let mut spi = Mock::new(&script);
//! let mut encoder = As5047p::new(spi.clone());
//! assert_eq!(encoder.angle(), Ok(0x1234)); // counts of 16384 per turn
//!
//! // A wrapping 14-bit angle becomes a position that keeps counting.
//! let mut position = wheel_odom::CounterExtender::new(14)?;
//! assert_eq!(position.update(16_380)?, 16_380); // the first reading is the start
//! assert_eq!(position.update(6)?, 16_390); // through the wrap: 10 counts on
//! spi.done();
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

pub mod arc;
pub mod as5047p;
pub mod counter;
pub mod encoder;
pub mod odometry;
pub mod quadrature;
pub mod read_breaks;
pub mod registers;

pub use as5047p::{As5047p, As5047pError, Diagnostics, ErrorFlags};
pub use counter::{CounterConfigError, CounterError, CounterExtender};
pub use encoder::{
    As5047pEncoder, CounterEncoder, CumulativeEncoder, EncoderError, PairError, Polarity,
    RawCounter, WheelPair,
};
pub use odometry::{BodyVelocity, DiffDriveOdometry, DiffDriveParams, OdometryStep, ParamsError};
pub use quadrature::{QuadStep, QuadratureDecoder};
