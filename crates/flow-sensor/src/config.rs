//! The power-up configuration tables ("performance optimisation registers")
//! of the two chip variants, and the frame-capture setup, as data.
//!
//! PixArt does not document these registers; the values are the vendor's
//! and reach us through the datasheet and public drivers:
//!
//! - [`PMW3901_TABLE`]: the PMW3901MB-TXQT datasheet's performance
//!   optimisation sequence as Bitcraze's Arduino driver writes it
//!   (`Bitcraze_PMW3901::initRegisters`, 100 ms wait in the middle). Pimoroni's
//!   `PMW3901._secret_sauce` carries a later revision of the same sequence
//!   (differences at bank 0 0x74, bank 0x14 0x65/0x63, bank 0x15 0x48, a 10 ms
//!   wait and the calibration prologue); we follow the datasheet/Bitcraze one.
//! - [`PAA5100_TABLE`] and the calibration prologue tables: Pimoroni
//!   `pmw3901-python`, class `PAA5100`, method `_secret_sauce`.
//! - [`FRAME_CAPTURE_SETUP`]: Pimoroni `frame_capture`.
//!
//! Every table ends in register bank 0 (tests check it), where all
//! documented registers live.

use crate::registers::BANK_SELECT;

/// One step of a configuration table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigStep {
    /// Write `value` to `register` (of the currently selected bank).
    Write {
        /// Register address (7 bits).
        register: u8,
        /// Value written.
        value: u8,
    },
    /// Wait this many milliseconds.
    DelayMs(u32),
}

const fn w(register: u8, value: u8) -> ConfigStep {
    ConfigStep::Write { register, value }
}

const fn bank(value: u8) -> ConfigStep {
    w(BANK_SELECT, value)
}

const fn ms(n: u32) -> ConfigStep {
    ConfigStep::DelayMs(n)
}

/// PMW3901MB performance optimisation registers (datasheet; Bitcraze).
pub const PMW3901_TABLE: &[ConfigStep] = &[
    bank(0x00),
    w(0x61, 0xAD),
    bank(0x03),
    w(0x40, 0x00),
    bank(0x05),
    w(0x41, 0xB3),
    w(0x43, 0xF1),
    w(0x45, 0x14),
    w(0x5B, 0x32),
    w(0x5F, 0x34),
    w(0x7B, 0x08),
    bank(0x06),
    w(0x44, 0x1B),
    w(0x40, 0xBF),
    w(0x4E, 0x3F),
    bank(0x08),
    w(0x65, 0x20),
    w(0x6A, 0x18),
    bank(0x09),
    w(0x4F, 0xAF),
    w(0x5F, 0x40),
    w(0x48, 0x80),
    w(0x49, 0x80),
    w(0x57, 0x77),
    w(0x60, 0x78),
    w(0x61, 0x78),
    w(0x62, 0x08),
    w(0x63, 0x50),
    bank(0x0A),
    w(0x45, 0x60),
    bank(0x00),
    w(0x4D, 0x11),
    w(0x55, 0x80),
    w(0x74, 0x1F),
    w(0x75, 0x1F),
    w(0x4A, 0x78),
    w(0x4B, 0x78),
    w(0x44, 0x08),
    w(0x45, 0x50),
    w(0x64, 0xFF),
    w(0x65, 0x1F),
    bank(0x14),
    w(0x65, 0x60),
    w(0x66, 0x08),
    w(0x63, 0x78),
    bank(0x15),
    w(0x48, 0x58),
    bank(0x07),
    w(0x41, 0x0D),
    w(0x43, 0x14),
    w(0x4B, 0x0E),
    w(0x45, 0x0F),
    w(0x44, 0x42),
    w(0x4C, 0x80),
    bank(0x10),
    w(0x5B, 0x02),
    bank(0x07),
    w(0x40, 0x41),
    w(0x70, 0x00),
    ms(100),
    w(0x32, 0x44),
    bank(0x07),
    w(0x40, 0x40),
    bank(0x06),
    w(0x62, 0xF0),
    w(0x63, 0x00),
    bank(0x0D),
    w(0x48, 0xC0),
    w(0x6F, 0xD5),
    bank(0x00),
    w(0x5B, 0xA0),
    w(0x4E, 0xA8),
    w(0x5A, 0x50),
    w(0x40, 0x80),
];

/// PAA5100JE configuration after the calibration prologue (Pimoroni `PAA5100`).
pub const PAA5100_TABLE: &[ConfigStep] = &[
    bank(0x00),
    w(0x61, 0xAD),
    bank(0x03),
    w(0x40, 0x00),
    bank(0x05),
    w(0x41, 0xB3),
    w(0x43, 0xF1),
    w(0x45, 0x14),
    w(0x5F, 0x34),
    w(0x7B, 0x08),
    w(0x5E, 0x34),
    w(0x5B, 0x11),
    w(0x6D, 0x11),
    w(0x45, 0x17),
    w(0x70, 0xE5),
    w(0x71, 0xE5),
    bank(0x06),
    w(0x44, 0x1B),
    w(0x40, 0xBF),
    w(0x4E, 0x3F),
    bank(0x08),
    w(0x66, 0x44),
    w(0x65, 0x20),
    w(0x6A, 0x3A),
    w(0x61, 0x05),
    w(0x62, 0x05),
    bank(0x09),
    w(0x4F, 0xAF),
    w(0x5F, 0x40),
    w(0x48, 0x80),
    w(0x49, 0x80),
    w(0x57, 0x77),
    w(0x60, 0x78),
    w(0x61, 0x78),
    w(0x62, 0x08),
    w(0x63, 0x50),
    bank(0x0A),
    w(0x45, 0x60),
    bank(0x00),
    w(0x4D, 0x11),
    w(0x55, 0x80),
    w(0x74, 0x21),
    w(0x75, 0x1F),
    w(0x4A, 0x78),
    w(0x4B, 0x78),
    w(0x44, 0x08),
    w(0x45, 0x50),
    w(0x64, 0xFF),
    w(0x65, 0x1F),
    bank(0x14),
    w(0x65, 0x67),
    w(0x66, 0x08),
    w(0x63, 0x70),
    w(0x6F, 0x1C),
    bank(0x15),
    w(0x48, 0x48),
    bank(0x07),
    w(0x41, 0x0D),
    w(0x43, 0x14),
    w(0x4B, 0x0E),
    w(0x45, 0x0F),
    w(0x44, 0x42),
    w(0x4C, 0x80),
    bank(0x10),
    w(0x5B, 0x02),
    bank(0x07),
    w(0x40, 0x41),
    ms(10),
    bank(0x00),
    w(0x32, 0x00),
    bank(0x07),
    w(0x40, 0x40),
    bank(0x06),
    w(0x68, 0xF0),
    w(0x69, 0x00),
    bank(0x0D),
    w(0x48, 0xC0),
    w(0x6F, 0xD5),
    bank(0x00),
    w(0x5B, 0xA0),
    w(0x4E, 0xA8),
    w(0x5A, 0x90),
    w(0x40, 0x80),
    w(0x73, 0x1F),
    ms(10),
    w(0x73, 0x00),
];

/// Calibration prologue, first part: ends in bank 0x0E, where register
/// [`CAL_PROBE_REGISTER`] is read to choose [`CAL_PROBE_TARGET`]'s value.
pub const CALIBRATION_STEP_1: &[ConfigStep] = &[
    bank(0x00),
    w(0x55, 0x01),
    w(0x50, 0x07),
    bank(0x0E),
    w(0x43, 0x10),
];
/// Read in bank 0x0E after [`CALIBRATION_STEP_1`].
pub const CAL_PROBE_REGISTER: u8 = 0x67;
/// Bit of [`CAL_PROBE_REGISTER`] that selects [`CAL_PROBE_VALUE_SET`].
pub const CAL_PROBE_BIT: u8 = 1 << 7;
/// Written in bank 0x0E after the probe.
pub const CAL_PROBE_TARGET: u8 = 0x48;
/// Value for [`CAL_PROBE_TARGET`] when the probe bit is set.
pub const CAL_PROBE_VALUE_SET: u8 = 0x04;
/// Value for [`CAL_PROBE_TARGET`] when the probe bit is clear.
pub const CAL_PROBE_VALUE_CLEAR: u8 = 0x02;
/// Calibration prologue, second part: ends in bank 0x0E.
pub const CALIBRATION_STEP_2: &[ConfigStep] = &[
    bank(0x00),
    w(0x51, 0x7B),
    w(0x50, 0x00),
    w(0x55, 0x00),
    bank(0x0E),
];
/// Read in bank 0x0E: zero means the factory trim `C1`/`C2` must be adjusted.
pub const CAL_STATUS_REGISTER: u8 = 0x73;
/// Trim value C1 (bank 0x0E).
pub const CAL_C1_REGISTER: u8 = 0x70;
/// Trim value C2 (bank 0x0E).
pub const CAL_C2_REGISTER: u8 = 0x71;
/// Written before the adjusted trims; ends in bank 0x0E.
pub const CALIBRATION_TRIM_SETUP: &[ConfigStep] =
    &[bank(0x00), w(0x61, 0xAD), w(0x51, 0x70), bank(0x0E)];

/// The adjusted C1 trim: +14 up to 28, +11 above, capped at 0x3F (the
/// datasheet's either/or branch; Pimoroni's Python writes two sequential
/// `if`s, which adds both for C1 in 15..=28, other ports use `else`).
pub const fn adjusted_c1(c1: u8) -> u8 {
    let v = if c1 <= 28 {
        c1 as u16 + 14
    } else {
        c1 as u16 + 11
    };
    if v > 0x3F { 0x3F } else { v as u8 }
}

/// The adjusted C2 trim: 45 % of the factory value.
pub const fn adjusted_c2(c2: u8) -> u8 {
    ((c2 as u16 * 45) / 100) as u8
}

/// Register writes before a raw frame grab (Pimoroni `frame_capture`),
/// ending in bank 0; the driver then arms `RawData_Grab`.
pub const FRAME_CAPTURE_SETUP: &[ConfigStep] = &[
    bank(0x07),
    w(0x4C, 0x00),
    bank(0x08),
    w(0x6A, 0x38),
    bank(0x00),
    w(0x55, 0x04),
    w(0x40, 0x80),
    w(0x4D, 0x11),
    ms(10),
    bank(0x00),
];
