//! Every register address, bit field, identity value and bus timing of the
//! PixArt PMW3901MB-TXQT / PAA5100JE-Q register map, in one place.
//!
//! Sources: PixArt PMW3901MB-TXQT datasheet (register list, Motion_Burst
//! layout, SPI AC timing), and the public drivers that use the same map:
//! Bitcraze `Bitcraze_PMW3901` (`src/Bitcraze_PMW3901.cpp`) and Pimoroni
//! `pmw3901-python` (`pmw3901/__init__.py`, classes `PMW3901` and `PAA5100`).
//! The two chips share this map; they differ only in their power-up
//! configuration tables (see [`crate::config`]).
//!
//! Register banks: writing a bank number to [`BANK_SELECT`] (0x7F) switches
//! the undocumented tuning registers the configuration tables touch. Every
//! documented register below lives in bank 0, and every configuration table
//! leaves the chip in bank 0.

/// Product_ID (read only): [`PRODUCT_ID_VALUE`].
pub const PRODUCT_ID: u8 = 0x00;
/// Revision_ID (read only).
pub const REVISION_ID: u8 = 0x01;
/// Motion: bit 7 [`MOTION_MOT`] is set when motion occurred since the last report.
pub const MOTION: u8 = 0x02;
/// Delta_X_L: low byte of the signed 16-bit X motion.
pub const DELTA_X_L: u8 = 0x03;
/// Delta_X_H: high byte of the signed 16-bit X motion.
pub const DELTA_X_H: u8 = 0x04;
/// Delta_Y_L: low byte of the signed 16-bit Y motion.
pub const DELTA_Y_L: u8 = 0x05;
/// Delta_Y_H: high byte of the signed 16-bit Y motion.
pub const DELTA_Y_H: u8 = 0x06;
/// SQUAL: surface quality.
pub const SQUAL: u8 = 0x07;
/// RawData_Sum: average raw pixel value / 2.
pub const RAW_DATA_SUM: u8 = 0x08;
/// Maximum_RawData.
pub const MAXIMUM_RAW_DATA: u8 = 0x09;
/// Minimum_RawData.
pub const MINIMUM_RAW_DATA: u8 = 0x0A;
/// Shutter_Lower: low byte of the shutter.
pub const SHUTTER_LOWER: u8 = 0x0B;
/// Shutter_Upper: high byte of the shutter.
pub const SHUTTER_UPPER: u8 = 0x0C;
/// Observation.
pub const OBSERVATION: u8 = 0x15;
/// Motion_Burst: reading it clocks out [`MOTION_BURST_LEN`] bytes.
pub const MOTION_BURST: u8 = 0x16;
/// Power_Up_Reset: write [`POWER_UP_RESET_VALUE`] to reset the chip.
pub const POWER_UP_RESET: u8 = 0x3A;
/// Shutdown: write [`SHUTDOWN_VALUE`] to enter the shutdown (low-power)
/// state. The chip then ignores the bus except for [`POWER_UP_RESET`], and
/// leaving it is the power-up sequence again (reset, motion reads, the
/// configuration table): shutdown loses the configuration.
pub const SHUTDOWN: u8 = 0x3B;
/// Resolution (PAA5100JE; written by its configuration table).
pub const RESOLUTION: u8 = 0x4E;
/// RawData_Grab: write to start a grab, read for pixel halves.
pub const RAW_DATA_GRAB: u8 = 0x58;
/// RawData_Grab_Status: bits 7:6 tell when the grab can start.
pub const RAW_DATA_GRAB_STATUS: u8 = 0x59;
/// Orientation: bits [`ORIENTATION_SWAP_XY`], [`ORIENTATION_INVERT_Y`], [`ORIENTATION_INVERT_X`].
pub const ORIENTATION: u8 = 0x5B;
/// Inverse_Product_ID (read only): [`INVERSE_PRODUCT_ID_VALUE`].
pub const INVERSE_PRODUCT_ID: u8 = 0x5F;
/// Bank select for the tuning registers of the configuration tables.
pub const BANK_SELECT: u8 = 0x7F;

/// Product_ID of both PMW3901MB and PAA5100JE.
pub const PRODUCT_ID_VALUE: u8 = 0x49;
/// Inverse_Product_ID: the bitwise complement of [`PRODUCT_ID_VALUE`].
pub const INVERSE_PRODUCT_ID_VALUE: u8 = 0xB6;
/// The value written to [`POWER_UP_RESET`].
pub const POWER_UP_RESET_VALUE: u8 = 0x5A;
/// The value written to [`SHUTDOWN`] to enter shutdown (PMW3901MB datasheet,
/// shutdown section; the same value the PixArt ADNS/PMW33xx parts take).
pub const SHUTDOWN_VALUE: u8 = 0xB6;

/// SPI address byte: bit 7 set means write.
pub const WRITE_FLAG: u8 = 0x80;
/// SPI address byte: the low 7 bits are the address.
pub const ADDRESS_MASK: u8 = 0x7F;

/// Motion register: motion occurred since the last read.
pub const MOTION_MOT: u8 = 1 << 7;

/// Orientation register: swap X and Y (applied before the inversions).
pub const ORIENTATION_SWAP_XY: u8 = 1 << 7;
/// Orientation register: invert Y.
pub const ORIENTATION_INVERT_Y: u8 = 1 << 6;
/// Orientation register: invert X.
pub const ORIENTATION_INVERT_X: u8 = 1 << 5;

/// Length of the Motion_Burst read.
pub const MOTION_BURST_LEN: usize = 12;
/// Motion_Burst byte offsets (datasheet burst table).
pub mod burst {
    /// Motion register.
    pub const MOTION: usize = 0;
    /// Observation register.
    pub const OBSERVATION: usize = 1;
    /// Delta_X_L.
    pub const DELTA_X_L: usize = 2;
    /// Delta_X_H.
    pub const DELTA_X_H: usize = 3;
    /// Delta_Y_L.
    pub const DELTA_Y_L: usize = 4;
    /// Delta_Y_H.
    pub const DELTA_Y_H: usize = 5;
    /// SQUAL.
    pub const SQUAL: usize = 6;
    /// RawData_Sum.
    pub const RAW_DATA_SUM: usize = 7;
    /// Maximum_RawData.
    pub const MAXIMUM_RAW_DATA: usize = 8;
    /// Minimum_RawData.
    pub const MINIMUM_RAW_DATA: usize = 9;
    /// Shutter_Upper (the shutter's high byte comes FIRST in the burst).
    pub const SHUTTER_UPPER: usize = 10;
    /// Shutter_Lower.
    pub const SHUTTER_LOWER: usize = 11;
}

/// RawData_Grab_Status: either of bits 7:6 set means the grab may start.
pub const GRAB_STATUS_READY_MASK: u8 = 0b1100_0000;
/// Value written to [`RAW_DATA_GRAB`] to arm a capture.
pub const RAW_DATA_GRAB_ARM: u8 = 0xFF;
/// Value written to [`RAW_DATA_GRAB`] to start reading pixels.
pub const RAW_DATA_GRAB_START: u8 = 0x00;
/// RawData_Grab read: bits 7:6 say which half of a pixel the byte carries.
pub const GRAB_TAG_MASK: u8 = 0b1100_0000;
/// Tag: bits 5:0 hold the pixel's upper six bits (7:2).
pub const GRAB_TAG_UPPER: u8 = 0b0100_0000;
/// Tag: bits 3:2 hold the pixel's lower two bits (1:0).
pub const GRAB_TAG_LOWER: u8 = 0b1000_0000;
/// Data bits of an upper-half byte.
pub const GRAB_UPPER_DATA_MASK: u8 = 0b0011_1111;
/// Data bits of a lower-half byte.
pub const GRAB_LOWER_DATA_MASK: u8 = 0b0000_1100;

/// SPI mode: CPOL = 1, CPHA = 1 (mode 3), MSB first (Bitcraze `SPI_MODE3`).
pub const SPI_MODE: embedded_hal::spi::Mode = embedded_hal::spi::MODE_3;
/// Highest SPI clock, Hz (PX4 `PixArt_PMW3901MB_Registers.hpp`: 2 MHz).
pub const SPI_MAX_HZ: u32 = 2_000_000;

/// SPI timing, nanoseconds (PMW3901MB datasheet, AC electrical
/// specifications; Bitcraze's driver waits a more generous 50 us around
/// every access). Read address to data: t_SRAD.
pub const T_SRAD_NS: u32 = 35_000;
/// After a write, before the next write or read: max(t_SWW, t_SWR).
pub const T_SWW_NS: u32 = 45_000;
/// After a read, before the next read or write: max(t_SRR, t_SRW).
pub const T_SRR_NS: u32 = 20_000;

/// Wait after [`POWER_UP_RESET`], milliseconds (datasheet power-up sequence;
/// Bitcraze waits 5 ms too).
pub const RESET_WAIT_MS: u32 = 5;
