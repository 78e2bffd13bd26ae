//! Bus-script helpers for the AS5047P mock tests; frame bits restated from
//! the datasheet, not imported.
#![allow(dead_code)]

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};

/// Even parity in bit 15 over a 16-bit frame.
pub fn parity(x: u16) -> u16 {
    let body = x & 0x7FFF;
    if body.count_ones() % 2 == 1 {
        body | 0x8000
    } else {
        body
    }
}

/// A bus script of 16-bit frames, one transaction each.
#[derive(Default)]
pub struct Frames(pub Vec<T<u8>>);

impl Frames {
    pub fn new() -> Self {
        Frames(Vec::new())
    }
    /// Expect one frame: the driver sends `tx`, the chip answers `rx`.
    pub fn f(mut self, tx: u16, rx: u16) -> Self {
        self.0.extend([
            T::transaction_start(),
            T::transfer_in_place(tx.to_be_bytes().to_vec(), rx.to_be_bytes().to_vec()),
            T::transaction_end(),
        ]);
        self
    }
    /// Expect a register read: the read command then a NOP answered `rx`.
    pub fn read(self, command: u16, rx: u16) -> Self {
        self.f(command, 0x0000).f(0x0000, rx)
    }
    pub fn mock(self) -> Mock<u8> {
        Mock::new(&self.0)
    }
}

/// Forwards to a mock and fails the `fail_at`-th transaction (0-based)
/// without forwarding it: the eh1 SPI mock has no error injection.
pub struct FaultySpi {
    pub inner: Mock<u8>,
    pub fail_at: usize,
    pub seen: usize,
}

impl ErrorType for FaultySpi {
    type Error = ErrorKind;
}

impl SpiDevice for FaultySpi {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        let n = self.seen;
        self.seen += 1;
        if n == self.fail_at {
            return Err(ErrorKind::Other);
        }
        self.inner.transaction(ops)
    }
}
