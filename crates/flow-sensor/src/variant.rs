//! The two chip variants sharing the register map: PMW3901MB (far field,
//! 80 mm to infinity, drones) and PAA5100JE (near field, 15-35 mm above the
//! floor, robot vacuums). They differ in their power-up configuration.

use crate::config::{self, ConfigStep};
use crate::registers::{ORIENTATION, RESOLUTION};

/// Which chip the driver talks to; chosen at construction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Variant {
    /// PixArt PMW3901MB-TXQT, working range 80 mm to infinity.
    Pmw3901,
    /// PixArt PAA5100JE-Q, working range 15 mm to 35 mm.
    Paa5100je,
}

impl Variant {
    /// The configuration table written at power-up (after the calibration
    /// prologue where [`Variant::runs_calibration_prologue`]).
    pub const fn configuration(self) -> &'static [ConfigStep] {
        match self {
            Variant::Pmw3901 => config::PMW3901_TABLE,
            Variant::Paa5100je => config::PAA5100_TABLE,
        }
    }

    /// Whether power-up runs the trim-adjusting calibration prologue
    /// (Pimoroni `PAA5100`; the PMW3901 datasheet sequence has none).
    pub const fn runs_calibration_prologue(self) -> bool {
        matches!(self, Variant::Paa5100je)
    }

    /// Bank-0 registers read back after configuration, with the value the
    /// table last wrote to them: the documented read/write registers only.
    pub const fn readback_checks(self) -> &'static [(u8, u8)] {
        match self {
            Variant::Pmw3901 => &[(ORIENTATION, 0xA0)],
            Variant::Paa5100je => &[(ORIENTATION, 0xA0), (RESOLUTION, 0xA8)],
        }
    }

    /// Counts per radian of angular flow, where a public source gives one.
    ///
    /// PMW3901: 500 counts/rad, the scale of PX4's `pmw3901` driver
    /// (`PMW3901.cpp`: "`x_raw / 500.0f` ... convert from pixels to radians").
    /// PAA5100JE: no public driver or datasheet figure; calibrate it
    /// (`None`).
    pub const fn default_counts_per_radian(self) -> Option<f32> {
        match self {
            Variant::Pmw3901 => Some(500.0),
            Variant::Paa5100je => None,
        }
    }

    /// Working range above the surface, metres: `(min, max)`, `None` = unbounded.
    pub const fn working_range_m(self) -> (f32, Option<f32>) {
        match self {
            Variant::Pmw3901 => (0.080, None),
            Variant::Paa5100je => (0.015, Some(0.035)),
        }
    }
}
