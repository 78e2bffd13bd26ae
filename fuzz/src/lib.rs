//! Helpers shared by the fuzz targets: a bus whose answers come from the
//! fuzzer's bytes, and a scratch folder per process for file readers.

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{self, ErrorKind, ErrorType, Operation, SpiDevice};
use std::path::PathBuf;

/// The bus failed (the fuzzer asked for it, or its bytes ran out).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusError;

impl spi::Error for BusError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// An SPI device that answers from a byte script: each transaction first
/// takes a control byte (below [`ScriptedSpi::FAIL_BELOW`]: the transaction
/// fails), then every byte clocked in comes from the script. An exhausted
/// script fails every further transaction, so drivers that poll terminate.
pub struct ScriptedSpi<'a> {
    script: &'a [u8],
    /// Transactions run (failed ones included).
    pub transactions: usize,
}

impl<'a> ScriptedSpi<'a> {
    /// Control bytes below this fail the transaction (1 in 16).
    pub const FAIL_BELOW: u8 = 16;

    /// A device answering from `script`.
    pub fn new(script: &'a [u8]) -> Self {
        ScriptedSpi {
            script,
            transactions: 0,
        }
    }

    /// Bytes of the script not used yet.
    pub fn remaining(&self) -> usize {
        self.script.len()
    }

    fn take(&mut self) -> Result<u8, BusError> {
        let (&first, rest) = self.script.split_first().ok_or(BusError)?;
        self.script = rest;
        Ok(first)
    }
}

impl ErrorType for ScriptedSpi<'_> {
    type Error = BusError;
}

impl SpiDevice for ScriptedSpi<'_> {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), BusError> {
        self.transactions += 1;
        if self.take()? < Self::FAIL_BELOW {
            return Err(BusError);
        }
        for op in operations {
            match op {
                Operation::Read(buf) | Operation::TransferInPlace(buf) => {
                    for b in buf.iter_mut() {
                        *b = self.take()?;
                    }
                }
                Operation::Transfer(read, _) => {
                    for b in read.iter_mut() {
                        *b = self.take()?;
                    }
                }
                Operation::Write(_) | Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}

/// A delay that returns at once.
pub struct NoDelay;

impl DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

/// A scratch folder of this process (created once, reused every run).
pub fn scratch_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("traction-fuzz-{}-{name}", std::process::id()));
    let _ = std::fs::create_dir_all(&d);
    d
}
