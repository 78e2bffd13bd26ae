//! Wheel encoders as cumulative counts, and a pair of them as
//! `vslam_core::sensors::WheelEncoderSource`.
//!
//! - [`CumulativeEncoder`]: anything that yields a cumulative signed count
//!   (the software [`QuadratureDecoder`](crate::QuadratureDecoder), a
//!   [`CounterEncoder`] over a hardware timer, an [`As5047pEncoder`]);
//! - [`RawCounter`]: what the MCU HAL provides for a timer in encoder mode;
//! - [`WheelPair`]: left and right encoders read into `WheelTicks`.

use crate::as5047p::{As5047p, As5047pError, Diagnostics};
use crate::counter::{CounterError, CounterExtender};
use crate::registers::ANGLE_BITS;
use core::fmt;
use embedded_hal::spi::SpiDevice;
use vslam_core::Timestamp;
use vslam_core::sensors::{WheelEncoderSource, WheelTicks};

/// A source of one wheel's cumulative signed count (positive = forward).
pub trait CumulativeEncoder {
    /// Why a read failed.
    type Error;
    /// The cumulative count now.
    fn read_count(&mut self) -> Result<i64, Self::Error>;
    /// Whether the count continues across a read that failed with `error`
    /// (it never reached the count: a bus error, a failed integrity check),
    /// rather than breaking (a refused jump held the count). `false` unless
    /// the encoder knows.
    fn count_continues(error: &Self::Error) -> bool {
        let _ = error;
        false
    }
}

/// A wrapping hardware counter (a timer in encoder mode), as the HAL reads it.
pub trait RawCounter {
    /// Why a read failed (`core::convert::Infallible` for a memory-mapped timer).
    type Error;
    /// The counter register now.
    fn read_raw(&mut self) -> Result<u32, Self::Error>;
}

/// Which way the count runs relative to the wheel's forward rotation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Polarity {
    /// Count increases when the wheel rolls forward.
    #[default]
    Normal,
    /// Count decreases when the wheel rolls forward (mirrored mounting).
    Reversed,
}

impl Polarity {
    /// Applies the polarity to a count.
    pub const fn apply(self, count: i64) -> i64 {
        match self {
            Polarity::Normal => count,
            Polarity::Reversed => count.saturating_neg(),
        }
    }
}

/// Why an encoder read failed: its source, or the counter extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncoderError<E> {
    /// The source (bus, device) failed.
    Source(E),
    /// The raw value was refused (impossible jump, out of range).
    Counter(CounterError),
}

impl<E: fmt::Debug> fmt::Display for EncoderError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EncoderError::Source(e) => write!(f, "encoder source failed: {e:?}"),
            EncoderError::Counter(e) => write!(f, "{e}"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for EncoderError<E> {}

/// A hardware counter extended to `i64`.
#[derive(Clone, Copy, Debug)]
pub struct CounterEncoder<C> {
    counter: C,
    extender: CounterExtender,
    polarity: Polarity,
}

impl<C: RawCounter> CounterEncoder<C> {
    /// Wraps `counter`; `extender` fixes its width and the largest step.
    pub const fn new(counter: C, extender: CounterExtender, polarity: Polarity) -> Self {
        CounterEncoder {
            counter,
            extender,
            polarity,
        }
    }

    /// The extension state (jumps counted).
    pub const fn extender(&self) -> &CounterExtender {
        &self.extender
    }

    /// Gives the counter back.
    pub fn release(self) -> C {
        self.counter
    }
}

impl<C: RawCounter> CumulativeEncoder for CounterEncoder<C> {
    type Error = EncoderError<C::Error>;
    fn read_count(&mut self) -> Result<i64, Self::Error> {
        let raw = self.counter.read_raw().map_err(EncoderError::Source)?;
        let position = self.extender.update(raw).map_err(EncoderError::Counter)?;
        Ok(self.polarity.apply(position))
    }
    /// A source error left the extension untouched.
    fn count_continues(error: &Self::Error) -> bool {
        matches!(error, EncoderError::Source(_))
    }
}

/// An AS5047P on a wheel shaft: the 14-bit angle unwrapped into cumulative
/// counts (16384 per revolution).
#[derive(Debug)]
pub struct As5047pEncoder<SPI> {
    sensor: As5047p<SPI>,
    extender: CounterExtender,
    polarity: Polarity,
    check_magnet: bool,
    diagnostics: Option<Diagnostics>,
}

impl<SPI: SpiDevice> As5047pEncoder<SPI> {
    /// Wraps the sensor. `max_step` bounds the counts between two reads
    /// (`None`: 8191, the unambiguous limit, half a revolution).
    pub fn new(
        sensor: As5047p<SPI>,
        polarity: Polarity,
        max_step: Option<u32>,
    ) -> Result<Self, crate::counter::CounterConfigError> {
        let mut extender = CounterExtender::new(ANGLE_BITS)?;
        if let Some(m) = max_step {
            extender = extender.with_max_step(m)?;
        }
        Ok(As5047pEncoder {
            sensor,
            extender,
            polarity,
            check_magnet: false,
            diagnostics: None,
        })
    }

    /// With the check on, every read fetches DIAAGC with the angle (three
    /// frames instead of two, [`As5047p::angle_with_diagnostics`]): a CORDIC
    /// overflow refuses the sample and the magnet warnings are kept in
    /// [`As5047pEncoder::last_diagnostics`].
    pub fn with_magnet_check(mut self, on: bool) -> Self {
        self.check_magnet = on;
        self
    }

    /// The diagnostics read with the last angle (magnet check on).
    pub const fn last_diagnostics(&self) -> Option<Diagnostics> {
        self.diagnostics
    }

    /// The sensor, for diagnostics.
    pub fn sensor(&mut self) -> &mut As5047p<SPI> {
        &mut self.sensor
    }

    /// The unwrapping state (jumps counted).
    pub const fn extender(&self) -> &CounterExtender {
        &self.extender
    }

    /// Cumulative angle, radians (polarity applied).
    pub fn angle_rad(&self) -> f32 {
        let counts = self.polarity.apply(self.extender.position()) as f32;
        counts * (core::f32::consts::TAU / crate::registers::COUNTS_PER_REVOLUTION as f32)
    }

    /// Gives the sensor back.
    pub fn release(self) -> As5047p<SPI> {
        self.sensor
    }
}

impl<SPI: SpiDevice> CumulativeEncoder for As5047pEncoder<SPI> {
    type Error = EncoderError<As5047pError<SPI::Error>>;
    fn read_count(&mut self) -> Result<i64, Self::Error> {
        let angle = if self.check_magnet {
            let (angle, diagnostics) = self
                .sensor
                .angle_with_diagnostics()
                .map_err(EncoderError::Source)?;
            self.diagnostics = Some(diagnostics);
            angle
        } else {
            self.sensor.angle().map_err(EncoderError::Source)?
        };
        let position = self
            .extender
            .update(u32::from(angle))
            .map_err(EncoderError::Counter)?;
        Ok(self.polarity.apply(position))
    }
    /// A bus error, a parity or error-flag answer or a CORDIC overflow left
    /// the unwrapping untouched.
    fn count_continues(error: &Self::Error) -> bool {
        matches!(error, EncoderError::Source(_))
    }
}

/// Which wheel a pair's read failed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairError<L, R> {
    /// The left encoder failed.
    Left(L),
    /// The right encoder failed.
    Right(R),
}

impl<L: fmt::Debug, R: fmt::Debug> fmt::Display for PairError<L, R> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PairError::Left(e) => write!(f, "left wheel encoder: {e:?}"),
            PairError::Right(e) => write!(f, "right wheel encoder: {e:?}"),
        }
    }
}

impl<L: fmt::Debug, R: fmt::Debug> core::error::Error for PairError<L, R> {}

/// The two wheels' encoders, read left then right.
#[derive(Clone, Copy, Debug)]
pub struct WheelPair<L, R> {
    /// Left wheel encoder.
    pub left: L,
    /// Right wheel encoder.
    pub right: R,
}

impl<L, R> WheelPair<L, R> {
    /// Pairs two encoders.
    pub const fn new(left: L, right: R) -> Self {
        WheelPair { left, right }
    }
}

impl<L: CumulativeEncoder, R: CumulativeEncoder> WheelEncoderSource for WheelPair<L, R> {
    type Error = PairError<L::Error, R::Error>;
    /// Reads left then right, both on every call, so that each wheel's
    /// counter extension follows its wheel read by read whatever the other
    /// does (a wheel left unread for a while would see its accumulated
    /// motion refused as a jump). A failure of either is the pair's failure,
    /// the left's reported first unless only the right's breaks the count
    /// ([`CumulativeEncoder::count_continues`]). After a refused jump
    /// ([`EncoderError::Counter`]) the counts do not continue, and the
    /// odometry anchors afresh (`DiffDriveOdometry::read_failed`); a source
    /// error ([`EncoderError::Source`]: bus, parity, error flag) left the
    /// extension untouched, and the counts continue across it
    /// (`DiffDriveOdometry::read_missed`).
    fn read_ticks(&mut self, t: Timestamp) -> Result<WheelTicks, Self::Error> {
        match (self.left.read_count(), self.right.read_count()) {
            (Ok(left), Ok(right)) => Ok(WheelTicks { t, left, right }),
            (Err(l), Err(r)) if L::count_continues(&l) && !R::count_continues(&r) => {
                Err(PairError::Right(r))
            }
            (Err(l), _) => Err(PairError::Left(l)),
            (Ok(_), Err(r)) => Err(PairError::Right(r)),
        }
    }
}
