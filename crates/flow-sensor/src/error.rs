//! The flow driver's error: bus failure or a chip that does not answer as
//! a PMW3901/PAA5100 should. Low image quality is never an error.

use core::fmt;

/// What a driver operation can fail with; `E` is the SPI device's error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<E> {
    /// The SPI transaction failed.
    Spi(E),
    /// Product_ID / Inverse_Product_ID are not 0x49 / 0xB6: wrong chip or a dead bus.
    WrongProductId {
        /// Product_ID read.
        product_id: u8,
        /// Inverse_Product_ID read.
        inverse_product_id: u8,
    },
    /// A configured register read back a different value.
    ConfigMismatch {
        /// Register (bank 0).
        register: u8,
        /// Value written by the configuration table.
        expected: u8,
        /// Value read back.
        read: u8,
    },
    /// RawData_Grab_Status did not become ready within the poll budget.
    FrameNotReady,
    /// The pixel stream stalled: the read budget ran out after `pixels` pixels.
    FrameTimeout {
        /// Pixels completed before the budget ran out.
        pixels: u16,
    },
    /// Motion was requested but the sensor is not in motion mode (not
    /// initialised yet, or left in raw-frame mode by a capture): call `init`.
    NotInMotionMode,
    /// Motion was requested while the chip is shut down: call `wake`.
    Shutdown,
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::Spi(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Spi(e) => write!(f, "SPI bus error: {e:?}"),
            Error::WrongProductId {
                product_id,
                inverse_product_id,
            } => write!(
                f,
                "wrong product id 0x{product_id:02X} / inverse 0x{inverse_product_id:02X} (expected 0x49 / 0xB6)"
            ),
            Error::ConfigMismatch {
                register,
                expected,
                read,
            } => write!(
                f,
                "register 0x{register:02X} read back 0x{read:02X}, configured 0x{expected:02X}"
            ),
            Error::FrameNotReady => f.write_str("raw frame grab never became ready"),
            Error::FrameTimeout { pixels } => {
                write!(f, "raw frame stream stalled after {pixels} pixels")
            }
            Error::NotInMotionMode => f.write_str("sensor not in motion mode; call init"),
            Error::Shutdown => f.write_str("sensor shut down; call wake"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
