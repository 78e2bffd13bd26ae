//! PixArt PMW3901MB / PAA5100JE optical-flow chip at register level.
//!
//! Protocol (PMW3901MB-TXQT datasheet, SPI section): the first byte of a
//! chip-select period is the address, bit 7 set for a write; a write's second
//! byte is the data; a read clocks the register out on the following bytes.
//! Reading `Motion` (0x02) latches the accumulated deltas into
//! `Delta_X/Y_L/H`; `Motion_Burst` (0x16) latches and streams the 12 burst
//! bytes. A write of 0x5A to `Power_Up_Reset` (0x3A) restores the defaults.
//! A write of 0xB6 to `Shutdown` (0x3B) shuts the chip down: it images
//! nothing (motion added meanwhile is lost), reads answer 0x00 (MISO is
//! high-impedance) and only a power-up reset is heard, which wakes it with
//! the defaults. `0x7F` selects the register bank used by the configuration tables. The raw
//! frame grab: a write to `RawData_Grab` (0x58) starts it, `RawData_Grab_Status`
//! (0x59) bits 7:6 say it is ready, then each read of 0x58 returns, per pixel,
//! a byte `01dddddd` with the upper six bits and a byte `10xxLLxx` with the lower two.

use super::{SimBusError, exchange};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use std::collections::HashMap;

const PRODUCT_ID: u8 = 0x00;
const REVISION_ID: u8 = 0x01;
const MOTION: u8 = 0x02;
const DELTA_X_L: u8 = 0x03;
const DELTA_X_H: u8 = 0x04;
const DELTA_Y_L: u8 = 0x05;
const DELTA_Y_H: u8 = 0x06;
const SQUAL: u8 = 0x07;
const RAW_DATA_SUM: u8 = 0x08;
const MAXIMUM_RAW_DATA: u8 = 0x09;
const MINIMUM_RAW_DATA: u8 = 0x0A;
const SHUTTER_LOWER: u8 = 0x0B;
const SHUTTER_UPPER: u8 = 0x0C;
const OBSERVATION: u8 = 0x15;
const MOTION_BURST: u8 = 0x16;
const POWER_UP_RESET: u8 = 0x3A;
const SHUTDOWN: u8 = 0x3B;
const SHUTDOWN_VALUE: u8 = 0xB6;
const RAWDATA_GRAB: u8 = 0x58;
const RAWDATA_GRAB_STATUS: u8 = 0x59;
const INVERSE_PRODUCT_ID: u8 = 0x5F;
const BANK_SELECT: u8 = 0x7F;

/// Pixels of a raw frame (35 x 35).
pub const FRAME_LEN: usize = 35 * 35;

/// Faults the simulator can be told to show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlowChipFault {
    /// The next `n` transactions fail on the bus.
    BusErrors(u32),
    /// A brown-out: the chip answers 0x00 to every read until a power-up reset.
    Brownout,
}

/// The simulated chip.
pub struct FlowChipSim {
    regs: HashMap<(u8, u8), u8>,
    bank: u8,
    acc: [i64; 2],
    squal: u8,
    shutter: u16,
    frame: [u8; FRAME_LEN],
    grab_index: usize,
    grab_upper_next: bool,
    fault: Option<FlowChipFault>,
    shut_down: bool,
    transactions: u64,
}

impl Default for FlowChipSim {
    fn default() -> Self {
        FlowChipSim::new()
    }
}

impl FlowChipSim {
    /// A chip just powered: defaults, no motion.
    pub fn new() -> Self {
        let mut s = FlowChipSim {
            regs: HashMap::new(),
            bank: 0,
            acc: [0; 2],
            squal: 0,
            shutter: 0,
            frame: [0; FRAME_LEN],
            grab_index: 0,
            grab_upper_next: true,
            fault: None,
            shut_down: false,
            transactions: 0,
        };
        s.reset();
        s
    }

    fn reset(&mut self) {
        self.regs.clear();
        self.shut_down = false;
        self.bank = 0;
        self.acc = [0; 2];
        self.regs.insert((0, PRODUCT_ID), 0x49);
        self.regs.insert((0, REVISION_ID), 0x00);
        self.regs.insert((0, INVERSE_PRODUCT_ID), 0xB6);
        self.regs.insert((0, OBSERVATION), 0xBF);
    }

    /// Adds motion the sensor saw (counts along its own x and y); a chip
    /// that is shut down sees none.
    pub fn add_motion(&mut self, dx: i64, dy: i64) {
        if self.shut_down {
            return;
        }
        self.acc[0] += dx;
        self.acc[1] += dy;
    }

    /// Sets the image quality the next reports show.
    pub fn set_quality(&mut self, squal: u8, shutter: u16) {
        self.squal = squal;
        self.shutter = shutter;
    }

    /// Sets the raw frame the next grab returns.
    pub fn set_frame(&mut self, frame: &[u8; FRAME_LEN]) {
        self.frame = *frame;
    }

    /// Injects a fault.
    pub fn inject(&mut self, fault: FlowChipFault) {
        self.fault = Some(fault);
    }

    /// The value last written to register `addr` of bank 0, if any (for tests of the init tables).
    pub fn register(&self, bank: u8, addr: u8) -> Option<u8> {
        self.regs.get(&(bank, addr)).copied()
    }

    /// Whether the chip is shut down (Shutdown <- 0xB6 since the last reset).
    pub fn is_shut_down(&self) -> bool {
        self.shut_down
    }

    /// Transactions seen so far.
    pub fn transactions(&self) -> u64 {
        self.transactions
    }

    fn latch(&mut self) {
        let clamp = |v: i64| v.clamp(i16::MIN as i64, i16::MAX as i64) as i16;
        let (dx, dy) = (clamp(self.acc[0]), clamp(self.acc[1]));
        self.acc = [0; 2];
        let moved = dx != 0 || dy != 0;
        let [xl, xh] = dx.to_le_bytes();
        let [yl, yh] = dy.to_le_bytes();
        let raw_sum =
            (self.frame.iter().map(|&p| p as u32).sum::<u32>() / FRAME_LEN as u32 / 2) as u8;
        let max = self.frame.iter().copied().max().unwrap_or(0);
        let min = self.frame.iter().copied().min().unwrap_or(0);
        for (a, v) in [
            (MOTION, if moved { 0x80 } else { 0x00 }),
            (DELTA_X_L, xl),
            (DELTA_X_H, xh),
            (DELTA_Y_L, yl),
            (DELTA_Y_H, yh),
            (SQUAL, self.squal),
            (RAW_DATA_SUM, raw_sum),
            (MAXIMUM_RAW_DATA, max),
            (MINIMUM_RAW_DATA, min),
            (SHUTTER_LOWER, (self.shutter & 0xFF) as u8),
            (SHUTTER_UPPER, (self.shutter >> 8) as u8),
        ] {
            self.regs.insert((0, a), v);
        }
    }

    fn burst_byte(&self, k: usize) -> u8 {
        const ORDER: [u8; 12] = [
            MOTION,
            OBSERVATION,
            DELTA_X_L,
            DELTA_X_H,
            DELTA_Y_L,
            DELTA_Y_H,
            SQUAL,
            RAW_DATA_SUM,
            MAXIMUM_RAW_DATA,
            MINIMUM_RAW_DATA,
            SHUTTER_UPPER,
            SHUTTER_LOWER,
        ];
        ORDER
            .get(k)
            .and_then(|a| self.regs.get(&(0, *a)))
            .copied()
            .unwrap_or(0)
    }

    fn grab_byte(&mut self) -> u8 {
        let Some(&p) = self.frame.get(self.grab_index) else {
            return 0;
        };
        if self.grab_upper_next {
            self.grab_upper_next = false;
            0b0100_0000 | (p >> 2)
        } else {
            self.grab_upper_next = true;
            self.grab_index += 1;
            0b1000_0000 | ((p & 0b11) << 2)
        }
    }

    fn read(&mut self, addr: u8) -> u8 {
        match (self.bank, addr) {
            (0, MOTION) => {
                self.latch();
                self.regs.get(&(0, MOTION)).copied().unwrap_or(0)
            }
            (0, RAWDATA_GRAB) => self.grab_byte(),
            (0, RAWDATA_GRAB_STATUS) => 0xC0,
            (bank, a) => self.regs.get(&(bank, a)).copied().unwrap_or(0),
        }
    }

    fn write(&mut self, addr: u8, value: u8) {
        match addr {
            POWER_UP_RESET if value == 0x5A => {
                self.reset();
                if self.fault == Some(FlowChipFault::Brownout) {
                    self.fault = None;
                }
            }
            SHUTDOWN if value == SHUTDOWN_VALUE => {
                self.shut_down = true;
                self.acc = [0; 2];
            }
            BANK_SELECT => self.bank = value,
            RAWDATA_GRAB if self.bank == 0 => {
                self.grab_index = 0;
                self.grab_upper_next = true;
            }
            a => {
                self.regs.insert((self.bank, a), value);
            }
        }
    }
}

impl ErrorType for FlowChipSim {
    type Error = SimBusError;
}

impl SpiDevice for FlowChipSim {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), SimBusError> {
        self.transactions += 1;
        match self.fault {
            Some(FlowChipFault::BusErrors(n)) if n > 0 => {
                self.fault = if n > 1 {
                    Some(FlowChipFault::BusErrors(n - 1))
                } else {
                    None
                };
                return Err(SimBusError);
            }
            _ => {}
        }
        // A browned-out or shut-down chip only hears the reset.
        let brownout = self.fault == Some(FlowChipFault::Brownout) || self.shut_down;
        let mut addr = 0u8;
        let mut is_write = false;
        let mut burst = false;
        let mut reg_value = 0u8;
        exchange(operations, |i, mosi| {
            if i == 0 {
                addr = mosi & 0x7F;
                is_write = mosi & 0x80 != 0;
                burst = !is_write && !self.shut_down && addr == MOTION_BURST && self.bank == 0;
                if burst {
                    self.latch();
                }
                return 0;
            }
            if brownout && !is_write {
                return 0;
            }
            if is_write {
                if i == 1 {
                    if brownout {
                        if addr == POWER_UP_RESET {
                            self.write(addr, mosi);
                        }
                    } else {
                        self.write(addr, mosi);
                    }
                }
                0
            } else if burst {
                self.burst_byte(i - 1)
            } else if addr == RAWDATA_GRAB && self.bank == 0 {
                self.grab_byte()
            } else {
                if i == 1 {
                    reg_value = self.read(addr);
                }
                reg_value
            }
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(chip: &mut FlowChipSim, addr: u8) -> u8 {
        let mut buf = [addr, 0];
        chip.transaction(&mut [Operation::TransferInPlace(&mut buf)])
            .unwrap();
        buf[1]
    }

    fn write(chip: &mut FlowChipSim, addr: u8, v: u8) {
        chip.transaction(&mut [Operation::Write(&[addr | 0x80, v])])
            .unwrap();
    }

    #[test]
    fn ids_burst_and_reset() {
        let mut c = FlowChipSim::new();
        assert_eq!(read(&mut c, 0x00), 0x49);
        assert_eq!(read(&mut c, 0x5F), 0xB6);
        c.add_motion(300, -2);
        c.set_quality(0x40, 0x1F23);
        let mut burst = [0u8; 12];
        c.transaction(&mut [
            Operation::Write(&[0x16]),
            Operation::DelayNs(35_000),
            Operation::Read(&mut burst),
        ])
        .unwrap();
        assert_eq!(burst[0] & 0x80, 0x80);
        assert_eq!(i16::from_le_bytes([burst[2], burst[3]]), 300);
        assert_eq!(i16::from_le_bytes([burst[4], burst[5]]), -2);
        assert_eq!(burst[6], 0x40);
        assert_eq!((burst[10], burst[11]), (0x1F, 0x23));
        // Latched and cleared: the next read shows no motion.
        assert_eq!(read(&mut c, 0x02) & 0x80, 0);
        write(&mut c, 0x7F, 0x07);
        write(&mut c, 0x40, 0x41);
        assert_eq!(c.register(7, 0x40), Some(0x41));
        write(&mut c, 0x7F, 0x00);
        write(&mut c, 0x3A, 0x5A);
        assert_eq!(c.register(7, 0x40), None);
    }

    #[test]
    fn faults() {
        let mut c = FlowChipSim::new();
        c.inject(FlowChipFault::BusErrors(2));
        let mut buf = [0u8, 0];
        assert!(
            c.transaction(&mut [Operation::TransferInPlace(&mut buf)])
                .is_err()
        );
        assert!(
            c.transaction(&mut [Operation::TransferInPlace(&mut buf)])
                .is_err()
        );
        assert_eq!(read(&mut c, 0x00), 0x49);
        c.inject(FlowChipFault::Brownout);
        assert_eq!(read(&mut c, 0x00), 0x00);
        write(&mut c, 0x3A, 0x5A);
        assert_eq!(read(&mut c, 0x00), 0x49);
    }

    #[test]
    fn shutdown_hears_only_the_reset_and_sees_no_motion() {
        let mut c = FlowChipSim::new();
        write(&mut c, 0x7F, 0x07);
        write(&mut c, 0x40, 0x41);
        write(&mut c, 0x7F, 0x00);
        write(&mut c, 0x3B, 0xB6);
        assert!(c.is_shut_down());
        c.add_motion(500, 500);
        c.set_quality(0x40, 0x0100);
        assert_eq!(read(&mut c, 0x00), 0x00);
        let mut burst = [0xAAu8; 12];
        c.transaction(&mut [Operation::Write(&[0x16]), Operation::Read(&mut burst)])
            .unwrap();
        assert_eq!(burst, [0; 12]);
        // Writes other than the reset are not heard.
        write(&mut c, 0x7F, 0x05);
        write(&mut c, 0x3B, 0x00);
        assert!(c.is_shut_down());
        write(&mut c, 0x3A, 0x5A);
        assert!(!c.is_shut_down());
        assert_eq!(read(&mut c, 0x00), 0x49);
        assert_eq!(c.register(7, 0x40), None, "the reset restored the defaults");
        // Motion from before the wake is gone; motion after it is seen.
        assert_eq!(read(&mut c, 0x02) & 0x80, 0);
        c.add_motion(3, 0);
        assert_eq!(read(&mut c, 0x02) & 0x80, 0x80);
        assert_eq!(read(&mut c, 0x03), 3);
    }

    #[test]
    fn the_driver_shuts_the_chip_down_and_wakes_it() {
        use crate::chips::{NoDelay, Shared};
        use traction::flow_sensor::{Error, FlowSensor, Variant};
        use traction::vslam_core::Timestamp;
        let chip = Shared::new(FlowChipSim::new());
        let handle = chip.handle();
        let mut s = FlowSensor::new(chip, NoDelay, Variant::Paa5100je);
        s.init().unwrap();
        handle.0.borrow_mut().set_quality(0x40, 0x0100);
        handle.0.borrow_mut().add_motion(7, -2);
        let before = s.read_sample(Timestamp(1)).unwrap();
        assert_eq!((before.dx, before.dy), (7, -2));
        s.shutdown().unwrap();
        assert!(handle.0.borrow().is_shut_down());
        handle.0.borrow_mut().add_motion(100, 100);
        assert_eq!(s.read_sample(Timestamp(2)), Err(Error::Shutdown));
        s.wake().unwrap();
        assert!(!handle.0.borrow().is_shut_down());
        // The configuration table ran again (its last PAA5100 write in bank 0).
        assert_eq!(handle.0.borrow().register(0, 0x73), Some(0x00));
        let woken = s.read_sample(Timestamp(3)).unwrap();
        assert!(
            !woken.motion,
            "no motion reported from while it was shut down"
        );
        assert_eq!((woken.dx, woken.dy), (0, 0));
        handle.0.borrow_mut().add_motion(-4, 9);
        let after = s.read_sample(Timestamp(4)).unwrap();
        assert_eq!((after.dx, after.dy), (-4, 9));
    }

    #[test]
    fn frame_grab_encoding() {
        let mut c = FlowChipSim::new();
        let mut f = [0u8; FRAME_LEN];
        for (i, p) in f.iter_mut().enumerate() {
            *p = (i * 7 % 256) as u8;
        }
        c.set_frame(&f);
        write(&mut c, 0x58, 0xFF);
        assert_eq!(read(&mut c, 0x59) & 0xC0, 0xC0);
        let mut out = Vec::new();
        let mut upper = 0u8;
        while out.len() < FRAME_LEN {
            let d = read(&mut c, 0x58);
            match d & 0xC0 {
                0x40 => upper = (d & 0x3F) << 2,
                0x80 => out.push(upper | ((d & 0x0C) >> 2)),
                _ => panic!("bad grab byte {d:#x}"),
            }
        }
        assert_eq!(out[..], f[..]);
    }
}
