//! ams AS5047P 14-bit magnetic rotary encoder at register level.
//!
//! Protocol (AS5047P datasheet, SPI interface, mode 1, 16-bit frames MSB
//! first, one frame per chip-select period): a command frame is
//! `PARC | R/W | ADDR[13:0]` with even parity in bit 15 over bits 14:0 and
//! bit 14 set for a read; the response to a command arrives in the *next*
//! frame as `PARD | EF | DATA[13:0]` (even parity, EF = an error happened in
//! the previous frame, see ERRFL). A write is a command frame followed by a
//! data frame. ERRFL (0x0001) holds PARERR (bit 2), INVCOMM (bit 1) and FRERR
//! (bit 0) and clears on read. DIAAGC (0x3FFC): MAGL (bit 11), MAGH (bit 10),
//! COF (bit 9), LF (bit 8), AGC (bits 7:0). ANGLEUNC 0x3FFE, ANGLECOM 0x3FFF.

use super::{SimBusError, exchange};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

const NOP: u16 = 0x0000;
const ERRFL: u16 = 0x0001;
const DIAAGC: u16 = 0x3FFC;
const MAG: u16 = 0x3FFD;
const ANGLEUNC: u16 = 0x3FFE;
const ANGLECOM: u16 = 0x3FFF;

const PARERR: u16 = 1 << 2;
const FRERR: u16 = 1 << 0;

/// Counts per revolution.
pub const COUNTS: u32 = 1 << 14;

fn with_even_parity(v: u16) -> u16 {
    let low = v & 0x7FFF;
    low | (((low.count_ones() & 1) as u16) << 15)
}

/// Faults the simulator can be told to show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncoderFault {
    /// The next `n` transactions fail on the bus.
    BusErrors(u32),
    /// The next response frame has its parity bit flipped.
    CorruptParity,
    /// The magnet is too weak (DIAAGC MAGL, AGC at its top).
    WeakMagnet,
    /// The chip saw a framing error: EF set in the next response, FRERR in ERRFL.
    FramingError,
    /// The answer to the next read command (the frame after it) arrives
    /// with its parity bit flipped: what a driver checks.
    CorruptAnswer,
}

/// The simulated encoder.
pub struct EncoderSim {
    angle: u16,
    pending: u16,
    errfl: u16,
    write_to: Option<u16>,
    regs: std::collections::HashMap<u16, u16>,
    fault: Option<EncoderFault>,
    weak_magnet: bool,
}

impl Default for EncoderSim {
    fn default() -> Self {
        EncoderSim::new()
    }
}

impl EncoderSim {
    /// An encoder at angle zero, magnet fine.
    pub fn new() -> Self {
        EncoderSim {
            angle: 0,
            pending: 0,
            errfl: 0,
            write_to: None,
            regs: Default::default(),
            fault: None,
            weak_magnet: false,
        }
    }

    /// Sets the shaft angle from a cumulative angle in radians.
    pub fn set_angle_radians(&mut self, radians: f64) {
        let turns = radians / std::f64::consts::TAU;
        let counts = (turns.rem_euclid(1.0) * COUNTS as f64).floor() as u32 % COUNTS;
        self.angle = counts as u16;
    }

    /// Sets the shaft angle in counts (taken modulo 2^14).
    pub fn set_angle_counts(&mut self, counts: u32) {
        self.angle = (counts % COUNTS) as u16;
    }

    /// Injects a fault.
    pub fn inject(&mut self, fault: EncoderFault) {
        if fault == EncoderFault::WeakMagnet {
            self.weak_magnet = true;
        }
        self.fault = Some(fault);
    }

    /// Clears a weak-magnet condition.
    pub fn magnet_ok(&mut self) {
        self.weak_magnet = false;
    }

    fn register(&mut self, addr: u16) -> u16 {
        match addr {
            NOP => 0,
            ERRFL => std::mem::take(&mut self.errfl),
            DIAAGC => {
                if self.weak_magnet {
                    (1 << 11) | (1 << 8) | 0xFF
                } else {
                    (1 << 8) | 0x80
                }
            }
            MAG => 0x0800,
            ANGLEUNC | ANGLECOM => self.angle,
            a => self.regs.get(&a).copied().unwrap_or(0),
        }
    }

    fn frame(&mut self, cmd: u16) -> u16 {
        let mut response = self.pending;
        if self.fault == Some(EncoderFault::CorruptParity) {
            response ^= 0x8000;
            self.fault = None;
        }
        let parity_ok = cmd.count_ones().is_multiple_of(2);
        let mut ef = false;
        if !parity_ok {
            self.errfl |= PARERR;
            ef = true;
        }
        if self.fault == Some(EncoderFault::FramingError) {
            self.errfl |= FRERR;
            ef = true;
            self.fault = None;
        }
        let corrupt_answer = self.fault == Some(EncoderFault::CorruptAnswer)
            && parity_ok
            && cmd & 0x4000 != 0
            && self.write_to.is_none();
        if corrupt_answer {
            self.fault = None;
        }
        let data = if let Some(addr) = self.write_to.take() {
            if parity_ok {
                self.regs.insert(addr, cmd & 0x3FFF);
            }
            self.register(addr)
        } else if !parity_ok {
            0
        } else if cmd & 0x4000 != 0 {
            self.register(cmd & 0x3FFF)
        } else if cmd & 0x3FFF == NOP {
            // NOP (0x0000): dummy frame that clocks out the previous answer; no data frame follows.
            0
        } else {
            self.write_to = Some(cmd & 0x3FFF);
            0
        };
        self.pending = with_even_parity((if ef { 0x4000 } else { 0 }) | (data & 0x3FFF));
        if corrupt_answer {
            self.pending ^= 0x8000;
        }
        response
    }
}

impl ErrorType for EncoderSim {
    type Error = SimBusError;
}

impl SpiDevice for EncoderSim {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), SimBusError> {
        if let Some(EncoderFault::BusErrors(n)) = self.fault {
            self.fault = if n > 1 {
                Some(EncoderFault::BusErrors(n - 1))
            } else {
                None
            };
            return Err(SimBusError);
        }
        // Collect the frame first (MSB first), then answer with the previous response.
        let mut mosi = Vec::with_capacity(2);
        exchange(operations, |_, b| {
            mosi.push(b);
            0
        });
        if mosi.len() != 2 {
            self.errfl |= FRERR;
            self.pending = with_even_parity(0x4000);
            return Ok(());
        }
        let cmd = u16::from_be_bytes([mosi[0], mosi[1]]);
        let response = self.frame(cmd).to_be_bytes();
        exchange(operations, |i, _| response.get(i).copied().unwrap_or(0));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(sim: &mut EncoderSim, cmd: u16) -> u16 {
        let mut buf = cmd.to_be_bytes();
        sim.transaction(&mut [Operation::TransferInPlace(&mut buf)])
            .unwrap();
        u16::from_be_bytes(buf)
    }

    const READ_ANGLECOM: u16 = 0xFFFF; // parity 1, read, 0x3FFF: 16 ones, even
    const READ_NOP: u16 = 0xC000; // parity 1, read, 0x0000
    const READ_ERRFL: u16 = 0x4001; // parity 0, read, 0x0001

    #[test]
    fn read_arrives_in_the_next_frame() {
        let mut s = EncoderSim::new();
        s.set_angle_counts(12_345);
        frame(&mut s, READ_ANGLECOM);
        let r = frame(&mut s, READ_NOP);
        assert_eq!(r & 0x3FFF, 12_345);
        assert_eq!(r & 0x4000, 0);
        assert_eq!(r.count_ones() % 2, 0, "even parity");
    }

    #[test]
    fn parity_error_sets_ef_and_errfl() {
        let mut s = EncoderSim::new();
        frame(&mut s, READ_ANGLECOM ^ 0x8000);
        let r = frame(&mut s, READ_ERRFL);
        assert_ne!(r & 0x4000, 0, "EF set");
        let r = frame(&mut s, READ_NOP);
        assert_eq!(r & 0x3FFF, PARERR);
        // ERRFL cleared on read.
        frame(&mut s, READ_ERRFL);
        assert_eq!(frame(&mut s, READ_NOP) & 0x3FFF, 0);
    }

    #[test]
    fn corrupt_parity_and_weak_magnet() {
        let mut s = EncoderSim::new();
        s.inject(EncoderFault::CorruptParity);
        let r = frame(&mut s, READ_NOP);
        assert_eq!(r.count_ones() % 2, 1, "odd parity delivered");
        s.inject(EncoderFault::WeakMagnet);
        frame(&mut s, with_even_parity(0x4000 | DIAAGC));
        let r = frame(&mut s, READ_NOP);
        assert_ne!(r & (1 << 11), 0, "MAGL");
    }

    #[test]
    fn angle_from_radians_wraps() {
        let mut s = EncoderSim::new();
        s.set_angle_radians(std::f64::consts::TAU * 3.25);
        assert_eq!(s.angle, 4096);
        s.set_angle_radians(-std::f64::consts::TAU * 0.25);
        assert_eq!(s.angle, 12_288);
    }
}

#[cfg(test)]
mod answer_tests {
    use super::*;

    #[test]
    fn a_corrupt_answer_is_the_one_a_read_returns() {
        let mut s = EncoderSim::new();
        s.set_angle_counts(77);
        let frame = |s: &mut EncoderSim, cmd: u16| {
            let mut b = cmd.to_be_bytes();
            s.transaction(&mut [Operation::TransferInPlace(&mut b)])
                .unwrap();
            u16::from_be_bytes(b)
        };
        s.inject(EncoderFault::CorruptAnswer);
        let first = frame(&mut s, 0xFFFF); // READ ANGLECOM
        assert_eq!(
            first.count_ones() % 2,
            0,
            "the command's own frame is clean"
        );
        let answer = frame(&mut s, 0x0000);
        assert_eq!(answer.count_ones() % 2, 1, "odd parity on the answer");
        assert_eq!(answer & 0x3FFF, 77);
        frame(&mut s, 0xFFFF);
        assert_eq!(frame(&mut s, 0x0000).count_ones() % 2, 0, "one answer only");
    }
}

#[cfg(test)]
mod nop_tests {
    use super::*;

    #[test]
    fn a_zero_nop_frame_is_not_a_write() {
        let mut s = EncoderSim::new();
        s.set_angle_counts(1234);
        let mut frame = |cmd: u16| {
            let mut b = cmd.to_be_bytes();
            s.transaction(&mut [Operation::TransferInPlace(&mut b)])
                .unwrap();
            u16::from_be_bytes(b)
        };
        for _ in 0..3 {
            frame(0xFFFF); // READ ANGLECOM
            assert_eq!(frame(0x0000) & 0x3FFF, 1234);
        }
    }
}
