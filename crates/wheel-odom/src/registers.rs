//! Every AS5047P register address and bit field, in one place.
//!
//! Source: ams AS5047P datasheet (v1-06), "SPI Interface": 16-bit frames,
//! SPI mode 1 (CPOL = 0, CPHA = 1), MSB first, chip select released between
//! frames (t_CSn >= 350 ns). Command frame: bit 15 PARC (even parity over
//! the frame), bit 14 R/W (1 = read), bits 13:0 address. Read data frame:
//! bit 15 PARD (even parity), bit 14 EF (error flag of the previous
//! command), bits 13:0 data. A read's answer arrives in the NEXT frame.

/// No operation: reading it is the dummy frame that clocks out answers.
pub const NOP: u16 = 0x0000;
/// Error register (cleared by reading): [`ERRFL_FRERR`], [`ERRFL_INVCOMM`], [`ERRFL_PARERR`].
pub const ERRFL: u16 = 0x0001;
/// Programming register.
pub const PROG: u16 = 0x0003;
/// Diagnostic and AGC: [`DIAAGC_MAGL`], [`DIAAGC_MAGH`], [`DIAAGC_COF`], [`DIAAGC_LF`], [`DIAAGC_AGC_MASK`].
pub const DIAAGC: u16 = 0x3FFC;
/// CORDIC magnitude.
pub const MAG: u16 = 0x3FFD;
/// Angle without dynamic angle error compensation.
pub const ANGLEUNC: u16 = 0x3FFE;
/// Angle with dynamic angle error compensation.
pub const ANGLECOM: u16 = 0x3FFF;
/// Zero position, bits 13:6 (non-volatile shadow).
pub const ZPOSM: u16 = 0x0016;
/// Zero position, bits 5:0, and diagnostic enables.
pub const ZPOSL: u16 = 0x0017;
/// Custom settings 1.
pub const SETTINGS1: u16 = 0x0018;
/// Custom settings 2.
pub const SETTINGS2: u16 = 0x0019;

/// Frame bit 15: even parity over the whole frame.
pub const FRAME_PARITY: u16 = 1 << 15;
/// Command frame bit 14: 1 = read, 0 = write.
pub const FRAME_READ: u16 = 1 << 14;
/// Response frame bit 14: the previous command failed; read [`ERRFL`].
pub const FRAME_ERROR_FLAG: u16 = 1 << 14;
/// Bits 13:0: address (command) or data (response).
pub const FRAME_DATA_MASK: u16 = 0x3FFF;

/// ERRFL bit 0: framing error.
pub const ERRFL_FRERR: u16 = 1 << 0;
/// ERRFL bit 1: invalid command.
pub const ERRFL_INVCOMM: u16 = 1 << 1;
/// ERRFL bit 2: parity error.
pub const ERRFL_PARERR: u16 = 1 << 2;

/// DIAAGC bits 7:0: automatic gain control value.
pub const DIAAGC_AGC_MASK: u16 = 0x00FF;
/// DIAAGC bit 8: offset compensation finished (LF = 1 means ready).
pub const DIAAGC_LF: u16 = 1 << 8;
/// DIAAGC bit 9: CORDIC overflow (the angle is invalid).
pub const DIAAGC_COF: u16 = 1 << 9;
/// DIAAGC bit 10: magnetic field too strong (AGC at minimum).
pub const DIAAGC_MAGH: u16 = 1 << 10;
/// DIAAGC bit 11: magnetic field too weak (AGC at maximum).
pub const DIAAGC_MAGL: u16 = 1 << 11;

/// SPI mode: CPOL = 0, CPHA = 1 (mode 1), MSB first.
pub const SPI_MODE: embedded_hal::spi::Mode = embedded_hal::spi::MODE_1;
/// Highest SPI clock, Hz.
pub const SPI_MAX_HZ: u32 = 10_000_000;

/// Angle counts per revolution (14 bits).
pub const COUNTS_PER_REVOLUTION: u32 = 1 << 14;
/// Bits of the angle.
pub const ANGLE_BITS: u8 = 14;
