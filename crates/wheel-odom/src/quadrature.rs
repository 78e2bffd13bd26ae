//! Software x4 quadrature decoding from sampled A/B levels.
//!
//! The two channels form the Gray sequence `00 -> 10 -> 11 -> 01 -> 00`
//! (as `AB`) when A leads B, which this decoder counts as forward (+1 per
//! edge, four per line). A sample where both bits changed at once is an
//! illegal transition: the direction is unknowable (the sampling was too
//! slow or a line glitched), so it is counted in
//! [`QuadratureDecoder::illegal_transitions`] and not guessed; the decoder
//! re-synchronises on the new state.

use core::convert::Infallible;

/// What one A/B sample did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuadStep {
    /// First sample, or no change.
    Idle,
    /// One edge forward.
    Forward,
    /// One edge backward.
    Backward,
    /// Both channels changed: counted as an error, count unchanged.
    Illegal,
}

/// Transition table, indexed by `prev << 2 | next` with states `A << 1 | B`.
/// 0 = no change, 1 = forward, -1 = backward, 2 = illegal.
const TABLE: [i8; 16] = [
    // prev 00: next 00, 01, 10, 11
    0, -1, 1, 2, //
    // prev 01
    1, 0, 2, -1, //
    // prev 10
    -1, 2, 0, 1, //
    // prev 11
    2, 1, -1, 0,
];

/// An x4 quadrature decoder fed with sampled channel levels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QuadratureDecoder {
    state: Option<u8>,
    count: i64,
    illegal: u32,
}

impl QuadratureDecoder {
    /// A decoder at count 0 that has seen no sample.
    pub const fn new() -> Self {
        QuadratureDecoder {
            state: None,
            count: 0,
            illegal: 0,
        }
    }

    /// Feeds one sample of the A and B levels.
    pub fn update(&mut self, a: bool, b: bool) -> QuadStep {
        let next = (u8::from(a) << 1) | u8::from(b);
        let Some(prev) = self.state.replace(next) else {
            return QuadStep::Idle;
        };
        match TABLE.get(usize::from((prev << 2) | next)).copied() {
            Some(1) => {
                self.count = self.count.wrapping_add(1);
                QuadStep::Forward
            }
            Some(-1) => {
                self.count = self.count.wrapping_sub(1);
                QuadStep::Backward
            }
            Some(0) => QuadStep::Idle,
            _ => {
                self.illegal = self.illegal.saturating_add(1);
                QuadStep::Illegal
            }
        }
    }

    /// Cumulative count, edges (four per encoder line).
    pub const fn count(&self) -> i64 {
        self.count
    }

    /// Illegal transitions seen (both channels changed between samples).
    pub const fn illegal_transitions(&self) -> u32 {
        self.illegal
    }

    /// Forgets the state and the counts.
    pub fn reset(&mut self) {
        *self = QuadratureDecoder::new();
    }
}

impl crate::encoder::CumulativeEncoder for QuadratureDecoder {
    type Error = Infallible;
    fn read_count(&mut self) -> Result<i64, Infallible> {
        Ok(self.count)
    }
}
