//! Axis conventions: the chip's Orientation register (0x5B: swap XY, then
//! invert Y, invert X; Pimoroni `set_orientation`) and a software rotation
//! in quarter turns applied to every sample after it is read.

use crate::registers::{ORIENTATION_INVERT_X, ORIENTATION_INVERT_Y, ORIENTATION_SWAP_XY};
use vslam_core::sensors::FlowSample;

/// The chip-side axis mapping written to the Orientation register.
/// The chip swaps X and Y first, then inverts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Orientation {
    /// Swap the X and Y axes.
    pub swap_xy: bool,
    /// Invert the X axis.
    pub invert_x: bool,
    /// Invert the Y axis.
    pub invert_y: bool,
}

impl Orientation {
    /// The register value.
    pub const fn to_bits(self) -> u8 {
        let mut v = 0;
        if self.swap_xy {
            v |= ORIENTATION_SWAP_XY;
        }
        if self.invert_y {
            v |= ORIENTATION_INVERT_Y;
        }
        if self.invert_x {
            v |= ORIENTATION_INVERT_X;
        }
        v
    }

    /// Decodes the register value; other bits are ignored.
    pub const fn from_bits(v: u8) -> Self {
        Orientation {
            swap_xy: v & ORIENTATION_SWAP_XY != 0,
            invert_x: v & ORIENTATION_INVERT_X != 0,
            invert_y: v & ORIENTATION_INVERT_Y != 0,
        }
    }
}

/// A software rotation of the reported motion vector about the sensor's z
/// axis, counter-clockwise, in quarter turns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Rotation {
    /// Leave the vector as the chip reports it.
    #[default]
    Deg0,
    /// (x, y) -> (-y, x).
    Deg90,
    /// (x, y) -> (-x, -y).
    Deg180,
    /// (x, y) -> (y, -x).
    Deg270,
}

impl Rotation {
    /// Rotates `(x, y)`; `i16::MIN` negates to `i16::MAX` (saturating, so
    /// the result stays flagged by [`FlowSample::is_saturated`]).
    pub const fn apply(self, x: i16, y: i16) -> (i16, i16) {
        match self {
            Rotation::Deg0 => (x, y),
            Rotation::Deg90 => (y.saturating_neg(), x),
            Rotation::Deg180 => (x.saturating_neg(), y.saturating_neg()),
            Rotation::Deg270 => (y, x.saturating_neg()),
        }
    }

    /// Rotates a sample's deltas in place.
    pub fn apply_to(self, sample: &mut FlowSample) {
        let (dx, dy) = self.apply(sample.dx, sample.dy);
        sample.dx = dx;
        sample.dy = dy;
    }

    /// The rotation for a whole-degree angle, if it is a multiple of 90.
    pub const fn from_degrees(deg: i32) -> Option<Self> {
        match deg.rem_euclid(360) {
            0 => Some(Rotation::Deg0),
            90 => Some(Rotation::Deg90),
            180 => Some(Rotation::Deg180),
            270 => Some(Rotation::Deg270),
            _ => None,
        }
    }
}
