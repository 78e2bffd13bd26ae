//! Register-level chip simulators on embedded-hal 1.0 `SpiDevice`, so the
//! real drivers of `flow-sensor` and `wheel-odom` read simulated sensors
//! through their real register protocols.
//!
//! A transaction is one chip-select period: the simulators see the bytes the
//! host clocks out (`Write`, `Transfer`, `TransferInPlace`; `Read` clocks out
//! zeros) as one stream and answer byte by byte, as the silicon does. Delays
//! inside a transaction are accepted and ignored (the simulators are never
//! too slow). Register addresses are restated here from the datasheets, not
//! imported from the drivers, so each side checks the other.

pub mod as5047p;
pub mod pmw3901;

use embedded_hal::spi::{ErrorKind, Operation};

/// The error a simulator returns when a bus fault is injected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimBusError;

impl embedded_hal::spi::Error for SimBusError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

impl std::fmt::Display for SimBusError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("simulated SPI bus error")
    }
}

impl std::error::Error for SimBusError {}

/// Runs `byte(index, mosi) -> miso` over every byte of a transaction, in order.
pub(crate) fn exchange(
    operations: &mut [Operation<'_, u8>],
    mut byte: impl FnMut(usize, u8) -> u8,
) {
    let mut i = 0usize;
    for op in operations.iter_mut() {
        match op {
            Operation::Read(buf) => {
                for b in buf.iter_mut() {
                    *b = byte(i, 0);
                    i += 1;
                }
            }
            Operation::Write(buf) => {
                for b in buf.iter() {
                    byte(i, *b);
                    i += 1;
                }
            }
            Operation::Transfer(read, write) => {
                let n = read.len().max(write.len());
                for k in 0..n {
                    let out = byte(i, write.get(k).copied().unwrap_or(0));
                    if let Some(r) = read.get_mut(k) {
                        *r = out;
                    }
                    i += 1;
                }
            }
            Operation::TransferInPlace(buf) => {
                for b in buf.iter_mut() {
                    *b = byte(i, *b);
                    i += 1;
                }
            }
            Operation::DelayNs(_) => {}
        }
    }
}

/// A simulator shared between the driver that owns its bus and the
/// simulation that moves it: `SpiDevice` through a `RefCell`.
pub struct Shared<T>(pub std::rc::Rc<std::cell::RefCell<T>>);

impl<T> Shared<T> {
    /// Wraps a simulator.
    pub fn new(chip: T) -> Self {
        Shared(std::rc::Rc::new(std::cell::RefCell::new(chip)))
    }
    /// Another handle to the same simulator.
    pub fn handle(&self) -> Self {
        Shared(self.0.clone())
    }
}

impl<T: embedded_hal::spi::ErrorType> embedded_hal::spi::ErrorType for Shared<T> {
    type Error = T::Error;
}

impl<T: embedded_hal::spi::SpiDevice> embedded_hal::spi::SpiDevice for Shared<T> {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), T::Error> {
        self.0.borrow_mut().transaction(operations)
    }
}

/// A delay that takes no time: the simulated chips are always ready.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoDelay;

impl embedded_hal::delay::DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}
