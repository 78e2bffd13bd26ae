//! ams AS5047P 14-bit absolute magnetic rotary encoder over SPI.
//!
//! Datasheet facts used (ams AS5047P, "SPI Interface", "Register
//! Description"; addresses and bits in [`crate::registers`]): 16-bit frames
//! in SPI mode 1, MSB first; even parity in bit 15 of every frame; a read
//! command's answer arrives in the next frame, so a read is the command frame
//! followed by a NOP (0x0000) frame; the answer's bit 14 (EF) says the
//! previous command failed, and reading ERRFL (0x0001) tells why (and clears
//! it): PARERR, INVCOMM, FRERR.
//!
//! # Bus transactions (what a register-level simulator sees)
//!
//! Every 16-bit frame is its own `SpiDevice::transaction` (chip select must
//! rise between frames): `[TransferInPlace([hi, lo])]`. Reading register
//! `addr` is two frames:
//!
//! 1. `[cmd >> 8, cmd & 0xFF]` with `cmd = parity | 0x4000 | addr`; the
//!    answer (to the previous command) is ignored;
//! 2. `[0x00, 0x00]` (NOP); the answer is the register: parity checked
//!    (else [`As5047pError::Parity`]), EF checked (else two more frames read
//!    ERRFL the same way and the result is [`As5047pError::ErrorFlag`]).
//!
//! [`As5047p::angle_with_diagnostics`] pipelines two reads in three frames:
//! `READ DIAAGC` (answer ignored), `READ ANGLECOM` (answer: DIAAGC), `NOP`
//! (answer: ANGLECOM); both answers are parity and EF checked, and a CORDIC
//! overflow makes the angle [`As5047pError::AngleInvalid`].
//!
//! Command words used: ANGLECOM `0xFFFF`, ANGLEUNC `0x7FFE`, MAG `0x7FFD`,
//! DIAAGC `0xFFFC`, ERRFL `0x4001`, NOP `0x0000`.

use crate::registers::*;
use core::fmt;
use embedded_hal::spi::{Operation, SpiDevice};

/// Sets bit 15 so that the 16-bit frame has an even number of ones.
pub const fn with_even_parity(frame: u16) -> u16 {
    let body = frame & !FRAME_PARITY;
    if !body.count_ones().is_multiple_of(2) {
        body | FRAME_PARITY
    } else {
        body
    }
}

/// Whether a received frame has even parity.
pub const fn has_even_parity(frame: u16) -> bool {
    frame.count_ones().is_multiple_of(2)
}

/// The read command frame for `address` (14 bits; higher bits dropped).
pub const fn read_command(address: u16) -> u16 {
    with_even_parity(FRAME_READ | (address & FRAME_DATA_MASK))
}

/// ERRFL decoded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ErrorFlags {
    /// The chip saw a command with bad parity.
    pub parity: bool,
    /// The chip saw an invalid command (address).
    pub invalid_command: bool,
    /// The chip saw a framing error (not 16 clocks).
    pub framing: bool,
}

impl ErrorFlags {
    /// Decodes the ERRFL data bits.
    pub const fn from_bits(data: u16) -> Self {
        ErrorFlags {
            parity: data & ERRFL_PARERR != 0,
            invalid_command: data & ERRFL_INVCOMM != 0,
            framing: data & ERRFL_FRERR != 0,
        }
    }
}

/// DIAAGC decoded: the magnet's health.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Diagnostics {
    /// MAGL: field too weak (AGC at maximum).
    pub field_too_weak: bool,
    /// MAGH: field too strong (AGC at minimum).
    pub field_too_strong: bool,
    /// COF: CORDIC overflow; the angle reading is invalid.
    pub cordic_overflow: bool,
    /// LF: offset compensation finished (the chip is ready).
    pub offset_compensated: bool,
    /// AGC value, 0..=255 (about 128 in the middle of the magnet's range).
    pub agc: u8,
}

impl Diagnostics {
    /// Decodes the DIAAGC data bits.
    pub const fn from_bits(data: u16) -> Self {
        Diagnostics {
            field_too_weak: data & DIAAGC_MAGL != 0,
            field_too_strong: data & DIAAGC_MAGH != 0,
            cordic_overflow: data & DIAAGC_COF != 0,
            offset_compensated: data & DIAAGC_LF != 0,
            agc: (data & DIAAGC_AGC_MASK) as u8,
        }
    }

    /// No magnet warning, no overflow, offset compensation done.
    pub const fn is_healthy(&self) -> bool {
        !self.field_too_weak
            && !self.field_too_strong
            && !self.cordic_overflow
            && self.offset_compensated
    }
}

/// What an AS5047P read can fail with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum As5047pError<E> {
    /// The SPI transaction failed.
    Spi(E),
    /// An answer frame failed the even-parity check.
    Parity {
        /// The frame received.
        frame: u16,
    },
    /// The answer's error flag was set; ERRFL (read and cleared) says why.
    ErrorFlag(ErrorFlags),
    /// DIAAGC reported a CORDIC overflow: the angle read with it is invalid.
    AngleInvalid(Diagnostics),
}

impl<E> From<E> for As5047pError<E> {
    fn from(e: E) -> Self {
        As5047pError::Spi(e)
    }
}

impl<E: fmt::Debug> fmt::Display for As5047pError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            As5047pError::Spi(e) => write!(f, "SPI bus error: {e:?}"),
            As5047pError::Parity { frame } => {
                write!(f, "AS5047P answer 0x{frame:04X} failed the parity check")
            }
            As5047pError::ErrorFlag(flags) => write!(
                f,
                "AS5047P error flag: parity {}, invalid command {}, framing {}",
                flags.parity, flags.invalid_command, flags.framing
            ),
            As5047pError::AngleInvalid(d) => write!(
                f,
                "AS5047P CORDIC overflow (field too weak {}, too strong {}, AGC {})",
                d.field_too_weak, d.field_too_strong, d.agc
            ),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for As5047pError<E> {}

/// An AS5047P on an SPI device (mode 1, MSB first, at most 10 MHz).
#[derive(Debug)]
pub struct As5047p<SPI> {
    spi: SPI,
}

impl<SPI: SpiDevice> As5047p<SPI> {
    /// Wraps the device; no bus traffic.
    pub const fn new(spi: SPI) -> Self {
        As5047p { spi }
    }

    /// Gives the device back.
    pub fn release(self) -> SPI {
        self.spi
    }

    /// Compensated angle (ANGLECOM), counts 0..16384.
    pub fn angle(&mut self) -> Result<u16, As5047pError<SPI::Error>> {
        self.read_register(ANGLECOM)
    }

    /// Uncompensated angle (ANGLEUNC), counts 0..16384.
    pub fn angle_uncompensated(&mut self) -> Result<u16, As5047pError<SPI::Error>> {
        self.read_register(ANGLEUNC)
    }

    /// CORDIC magnitude (MAG).
    pub fn magnitude(&mut self) -> Result<u16, As5047pError<SPI::Error>> {
        self.read_register(MAG)
    }

    /// Magnet diagnostics (DIAAGC).
    pub fn diagnostics(&mut self) -> Result<Diagnostics, As5047pError<SPI::Error>> {
        Ok(Diagnostics::from_bits(self.read_register(DIAAGC)?))
    }

    /// The compensated angle and the diagnostics of the same moment, in
    /// three frames (module docs). Magnet warnings (MAGH, MAGL) come back in
    /// the diagnostics; a CORDIC overflow is [`As5047pError::AngleInvalid`].
    pub fn angle_with_diagnostics(
        &mut self,
    ) -> Result<(u16, Diagnostics), As5047pError<SPI::Error>> {
        self.frame(read_command(DIAAGC))?;
        let diag = self.frame(read_command(ANGLECOM))?;
        let angle = self.frame(NOP)?;
        for answer in [diag, angle] {
            if !has_even_parity(answer) {
                return Err(As5047pError::Parity { frame: answer });
            }
        }
        if (diag | angle) & FRAME_ERROR_FLAG != 0 {
            let flags = self.error_flags()?;
            return Err(As5047pError::ErrorFlag(flags));
        }
        let diagnostics = Diagnostics::from_bits(diag & FRAME_DATA_MASK);
        if diagnostics.cordic_overflow {
            return Err(As5047pError::AngleInvalid(diagnostics));
        }
        Ok((angle & FRAME_DATA_MASK, diagnostics))
    }

    /// Reads (and so clears) ERRFL.
    pub fn error_flags(&mut self) -> Result<ErrorFlags, As5047pError<SPI::Error>> {
        let data = self.read_unchecked_flag(ERRFL)?;
        Ok(ErrorFlags::from_bits(data))
    }

    /// Reads a register's 14 data bits (two frames; module docs).
    pub fn read_register(&mut self, address: u16) -> Result<u16, As5047pError<SPI::Error>> {
        let answer = self.read_frame(address)?;
        if answer & FRAME_ERROR_FLAG != 0 {
            let flags = self.error_flags()?;
            return Err(As5047pError::ErrorFlag(flags));
        }
        Ok(answer & FRAME_DATA_MASK)
    }

    fn read_unchecked_flag(&mut self, address: u16) -> Result<u16, As5047pError<SPI::Error>> {
        Ok(self.read_frame(address)? & FRAME_DATA_MASK)
    }

    /// Command frame then NOP frame; the NOP's answer, parity checked.
    fn read_frame(&mut self, address: u16) -> Result<u16, As5047pError<SPI::Error>> {
        self.frame(read_command(address))?;
        let answer = self.frame(NOP)?;
        if !has_even_parity(answer) {
            return Err(As5047pError::Parity { frame: answer });
        }
        Ok(answer)
    }

    fn frame(&mut self, word: u16) -> Result<u16, As5047pError<SPI::Error>> {
        let mut buf = word.to_be_bytes();
        self.spi
            .transaction(&mut [Operation::TransferInPlace(&mut buf)])?;
        Ok(u16::from_be_bytes(buf))
    }
}
