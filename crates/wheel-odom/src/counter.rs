//! Extending a wrapping hardware count (a 16- or 32-bit timer in encoder
//! mode, the AS5047P's 14-bit angle) into an `i64` position.
//!
//! Between two samples the counter can move by less than half its range in
//! either direction and still be told apart from a wrap; the signed wrapped
//! difference is the motion. A difference larger than the configured
//! maximum step (by default half the range less one count, the largest that
//! is not ambiguous) cannot be real: it is a [`CounterError::Jump`], counted,
//! the position is held and the extender re-anchors on the new raw value so
//! the stream recovers with its next sample.

use core::fmt;

/// Why a counter configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CounterConfigError {
    /// The counter width must be 2..=32 bits.
    BadWidth,
    /// The maximum step must be 1..half the range.
    BadMaxStep,
}

impl fmt::Display for CounterConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CounterConfigError::BadWidth => "counter width must be 2..=32 bits",
            CounterConfigError::BadMaxStep => {
                "max step must be at least 1 and below half the range"
            }
        })
    }
}

impl core::error::Error for CounterConfigError {}

/// Why a raw sample was not used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CounterError {
    /// The raw value does not fit the counter's width.
    OutOfRange {
        /// The raw value given.
        raw: u32,
    },
    /// The wrapped difference exceeds the maximum step: an impossible jump.
    Jump {
        /// The signed wrapped difference that was refused, counts.
        delta: i64,
    },
}

impl fmt::Display for CounterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CounterError::OutOfRange { raw } => {
                write!(f, "raw count {raw} exceeds the counter width")
            }
            CounterError::Jump { delta } => write!(f, "counter jumped by {delta} counts"),
        }
    }
}

impl core::error::Error for CounterError {}

/// Extends a wrapping `bits`-wide counter into an `i64` position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CounterExtender {
    bits: u8,
    max_step: u32,
    last: Option<u32>,
    position: i64,
    jumps: u32,
}

impl CounterExtender {
    /// An extender for a `bits`-wide counter (2..=32), accepting steps up to
    /// half the range less one.
    pub const fn new(bits: u8) -> Result<Self, CounterConfigError> {
        if bits < 2 || bits > 32 {
            return Err(CounterConfigError::BadWidth);
        }
        Ok(CounterExtender {
            bits,
            max_step: (1u32 << (bits - 1)) - 1,
            last: None,
            position: 0,
            jumps: 0,
        })
    }

    /// For a 16-bit timer.
    pub const fn bits16() -> Self {
        CounterExtender {
            bits: 16,
            max_step: (1 << 15) - 1,
            last: None,
            position: 0,
            jumps: 0,
        }
    }

    /// For a 32-bit timer.
    pub const fn bits32() -> Self {
        CounterExtender {
            bits: 32,
            max_step: (1 << 31) - 1,
            last: None,
            position: 0,
            jumps: 0,
        }
    }

    /// Refuses steps larger than `max_step` counts (from the fastest
    /// possible motion between two reads); 1..half the range.
    pub const fn with_max_step(mut self, max_step: u32) -> Result<Self, CounterConfigError> {
        if max_step == 0 || max_step >= (1u32 << (self.bits - 1)) {
            return Err(CounterConfigError::BadMaxStep);
        }
        self.max_step = max_step;
        Ok(self)
    }

    /// Counter width, bits.
    pub const fn bits(&self) -> u8 {
        self.bits
    }

    /// The largest accepted step, counts.
    pub const fn max_step(&self) -> u32 {
        self.max_step
    }

    /// The extended position; the first sample's raw value is its start.
    pub const fn position(&self) -> i64 {
        self.position
    }

    /// Samples refused as impossible jumps.
    pub const fn jumps(&self) -> u32 {
        self.jumps
    }

    /// The raw value the next sample is compared with.
    pub const fn last_raw(&self) -> Option<u32> {
        self.last
    }

    /// Forgets the anchor: the next sample starts again at its raw value.
    pub fn reset(&mut self) {
        self.last = None;
        self.position = 0;
    }

    /// The mask of a raw value's valid bits.
    pub const fn mask(&self) -> u32 {
        u32::MAX >> (32 - self.bits as u32)
    }

    /// Takes one raw reading; returns the extended position.
    pub fn update(&mut self, raw: u32) -> Result<i64, CounterError> {
        let mask = self.mask();
        if raw & !mask != 0 {
            return Err(CounterError::OutOfRange { raw });
        }
        let Some(last) = self.last.replace(raw) else {
            self.position = i64::from(raw);
            return Ok(self.position);
        };
        let diff = raw.wrapping_sub(last) & mask;
        let half = 1u32 << (self.bits - 1);
        let delta = if diff >= half {
            i64::from(diff) - (1i64 << self.bits)
        } else {
            i64::from(diff)
        };
        if delta.unsigned_abs() > u64::from(self.max_step) {
            self.jumps = self.jumps.saturating_add(1);
            return Err(CounterError::Jump { delta });
        }
        self.position = self.position.wrapping_add(delta);
        Ok(self.position)
    }
}
