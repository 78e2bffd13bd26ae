//! The PMW3901MB / PAA5100JE driver over an embedded-hal 1.0 `SpiDevice`.
//!
//! # Bus transactions (what a register-level simulator sees)
//!
//! Every register access is one `SpiDevice::transaction` (one chip-select
//! assertion); the delays the datasheet needs are `Operation::DelayNs`
//! inside it, so the bus implementation owns the timing:
//!
//! - write `reg <- v`: `[Write([reg | 0x80, v]), DelayNs(45_000)]`
//!   (t_SWW / t_SWR after the write);
//! - read `reg`: `[Write([reg & 0x7F]), DelayNs(35_000), TransferInPlace([0x00]),
//!   DelayNs(20_000)]` (t_SRAD between address and data, a dummy 0x00 clocks
//!   the data out, t_SRR / t_SRW after it);
//! - Motion_Burst: `[Write([0x16]), DelayNs(35_000), TransferInPlace([0x00; 12]),
//!   DelayNs(20_000)]`.
//!
//! # Power-up ([`FlowSensor::init`])
//!
//! 1. write Power_Up_Reset (0x3A) <- 0x5A, wait 5 ms (`DelayNs`);
//! 2. read Product_ID (0x00) and Inverse_Product_ID (0x5F): 0x49 / 0xB6, else
//!    [`Error::WrongProductId`];
//! 3. read 0x02, 0x03, 0x04, 0x05, 0x06 once (datasheet power-up step);
//! 4. PAA5100JE only: the calibration prologue (reads 0x67 and 0x73 in bank
//!    0x0E, and 0x70, 0x71 when 0x73 reads zero; see [`crate::config`]);
//! 5. the variant's configuration table (waits through `DelayNs`);
//! 6. read back [`Variant::readback_checks`], else [`Error::ConfigMismatch`];
//! 7. read 0x02..=0x06 once more so the first report starts from zero.
//!
//! # Shutdown and wake ([`FlowSensor::shutdown`], [`FlowSensor::wake`])
//!
//! Shutdown is one write, Shutdown (0x3B) <- 0xB6: the chip stops imaging
//! (datasheet: about 12 uA instead of the run mode's < 9 mA) and answers no
//! register but Power_Up_Reset. While shut down the driver refuses motion
//! reads with [`Error::Shutdown`] without touching the bus. Waking is the
//! whole power-up above (the datasheet's exit from shutdown is the power-up
//! reset and the configuration again), so a wake costs what `init` costs,
//! its configuration waits included.
//!
//! # Raw frame ([`FlowSensor::capture_frame`], Pimoroni `frame_capture`)
//!
//! [`crate::config::FRAME_CAPTURE_SETUP`], write 0x58 <- 0xFF, poll 0x59 until
//! bit 7 or 6 is set (at most [`MAX_GRAB_STATUS_POLLS`] reads), write
//! 0x58 <- 0x00, then read 0x58 until 1225 pixels are complete (at most
//! [`MAX_GRAB_READS`] reads): a byte tagged `01` in bits 7:6 carries pixel
//! bits 7:2 in its bits 5:0, a byte tagged `10` carries pixel bits 1:0 in
//! its bits 3:2 and completes the pixel; other tags are skipped. The chip
//! stays in raw-data mode: motion reads answer [`Error::NotInMotionMode`]
//! until [`FlowSensor::init`] runs again.

use crate::burst::MotionBurst;
use crate::config::{self, ConfigStep};
use crate::error::Error;
use crate::orientation::{Orientation, Rotation};
use crate::registers::*;
use crate::variant::Variant;
use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};
use vslam_core::Timestamp;
use vslam_core::sensors::{FLOW_FRAME_LEN, FlowFrameSource, FlowSample, FlowSource};

/// Reads of RawData_Grab_Status before a capture gives up.
pub const MAX_GRAB_STATUS_POLLS: u32 = 10_000;
/// Reads of RawData_Grab before a capture gives up (two per pixel are
/// needed; the rest is slack for bytes tagged not-ready).
pub const MAX_GRAB_READS: u32 = FLOW_FRAME_LEN as u32 * 2 * 4;

/// What the chip is doing, as far as the driver knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// `init` has not completed.
    Uninitialised,
    /// Reporting motion.
    Motion,
    /// Left in raw-data (frame grab) mode by a capture.
    RawFrame,
    /// In the chip's shutdown (low-power) state; [`FlowSensor::wake`] leaves it.
    Shutdown,
}

/// A PMW3901MB or PAA5100JE on an SPI device, with a delay provider.
#[derive(Debug)]
pub struct FlowSensor<SPI, D> {
    spi: SPI,
    delay: D,
    variant: Variant,
    rotation: Rotation,
    mode: Mode,
}

impl<SPI: SpiDevice, D: DelayNs> FlowSensor<SPI, D> {
    /// A driver for `variant`; talks to the chip only in [`FlowSensor::init`].
    pub fn new(spi: SPI, delay: D, variant: Variant) -> Self {
        FlowSensor {
            spi,
            delay,
            variant,
            rotation: Rotation::Deg0,
            mode: Mode::Uninitialised,
        }
    }

    /// Gives the bus and the delay back.
    pub fn release(self) -> (SPI, D) {
        (self.spi, self.delay)
    }

    /// The chip variant.
    pub fn variant(&self) -> Variant {
        self.variant
    }

    /// The driver's view of the chip's mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Resets, identifies and configures the chip (see the module docs).
    pub fn init(&mut self) -> Result<(), Error<SPI::Error>> {
        self.mode = Mode::Uninitialised;
        self.write_register(POWER_UP_RESET, POWER_UP_RESET_VALUE)?;
        self.delay.delay_ms(RESET_WAIT_MS);
        let (product_id, inverse_product_id) = self.read_product_id()?;
        if product_id != PRODUCT_ID_VALUE || inverse_product_id != INVERSE_PRODUCT_ID_VALUE {
            return Err(Error::WrongProductId {
                product_id,
                inverse_product_id,
            });
        }
        self.clear_motion()?;
        if self.variant.runs_calibration_prologue() {
            self.calibration_prologue()?;
        }
        self.run_table(self.variant.configuration())?;
        for &(register, expected) in self.variant.readback_checks() {
            let read = self.read_register(register)?;
            if read != expected {
                return Err(Error::ConfigMismatch {
                    register,
                    expected,
                    read,
                });
            }
        }
        self.clear_motion()?;
        self.mode = Mode::Motion;
        Ok(())
    }

    /// Puts the chip into its shutdown (low-power) state: one write of
    /// Shutdown (0x3B) <- 0xB6. Motion reads then answer [`Error::Shutdown`]
    /// until [`FlowSensor::wake`]. A chip already shut down is not written to
    /// again (it would not listen).
    pub fn shutdown(&mut self) -> Result<(), Error<SPI::Error>> {
        if self.mode == Mode::Shutdown {
            return Ok(());
        }
        self.write_register(SHUTDOWN, SHUTDOWN_VALUE)?;
        self.mode = Mode::Shutdown;
        Ok(())
    }

    /// Wakes the chip from shutdown (or from any mode): the whole power-up
    /// of [`FlowSensor::init`], since shutdown loses the configuration.
    /// On error the mode is [`Mode::Uninitialised`].
    pub fn wake(&mut self) -> Result<(), Error<SPI::Error>> {
        self.init()
    }

    /// Whether the chip is shut down.
    pub fn is_shut_down(&self) -> bool {
        self.mode == Mode::Shutdown
    }

    /// Product_ID and Inverse_Product_ID.
    pub fn read_product_id(&mut self) -> Result<(u8, u8), Error<SPI::Error>> {
        let id = self.read_register(PRODUCT_ID)?;
        let inverse = self.read_register(INVERSE_PRODUCT_ID)?;
        Ok((id, inverse))
    }

    /// Revision_ID.
    pub fn read_revision(&mut self) -> Result<u8, Error<SPI::Error>> {
        self.read_register(REVISION_ID)
    }

    /// Reads the Motion_Burst and decodes it (no software rotation applied).
    pub fn read_motion_burst(&mut self) -> Result<MotionBurst, Error<SPI::Error>> {
        match self.mode {
            Mode::Motion => {}
            Mode::Shutdown => return Err(Error::Shutdown),
            Mode::Uninitialised | Mode::RawFrame => return Err(Error::NotInMotionMode),
        }
        let mut buf = [0u8; MOTION_BURST_LEN];
        self.spi.transaction(&mut [
            Operation::Write(&[MOTION_BURST]),
            Operation::DelayNs(T_SRAD_NS),
            Operation::TransferInPlace(&mut buf),
            Operation::DelayNs(T_SRR_NS),
        ])?;
        Ok(MotionBurst::from_bytes(&buf))
    }

    /// One motion report, time-stamped `t`, with the software rotation
    /// applied. Low quality is in the sample (`FlowSample::is_valid`), not
    /// an error.
    pub fn read_sample(&mut self, t: Timestamp) -> Result<FlowSample, Error<SPI::Error>> {
        let mut sample = self.read_motion_burst()?.to_sample(t);
        self.rotation.apply_to(&mut sample);
        Ok(sample)
    }

    /// Writes the chip's Orientation register.
    pub fn set_orientation(&mut self, orientation: Orientation) -> Result<(), Error<SPI::Error>> {
        self.write_register(ORIENTATION, orientation.to_bits())
    }

    /// Reads the chip's Orientation register.
    pub fn read_orientation(&mut self) -> Result<Orientation, Error<SPI::Error>> {
        Ok(Orientation::from_bits(self.read_register(ORIENTATION)?))
    }

    /// Sets the software rotation applied to every sample.
    pub fn set_rotation(&mut self, rotation: Rotation) {
        self.rotation = rotation;
    }

    /// The software rotation.
    pub fn rotation(&self) -> Rotation {
        self.rotation
    }

    /// Grabs one raw 35x35 frame, row-major, into `frame` (module docs).
    /// On error the frame holds the pixels read so far.
    pub fn capture_frame(
        &mut self,
        frame: &mut [u8; FLOW_FRAME_LEN],
    ) -> Result<(), Error<SPI::Error>> {
        if self.mode == Mode::Shutdown {
            return Err(Error::Shutdown);
        }
        self.run_table(config::FRAME_CAPTURE_SETUP)?;
        self.mode = Mode::RawFrame;
        self.write_register(RAW_DATA_GRAB, RAW_DATA_GRAB_ARM)?;
        let mut ready = false;
        for _ in 0..MAX_GRAB_STATUS_POLLS {
            if self.read_register(RAW_DATA_GRAB_STATUS)? & GRAB_STATUS_READY_MASK != 0 {
                ready = true;
                break;
            }
        }
        if !ready {
            return Err(Error::FrameNotReady);
        }
        self.write_register(RAW_DATA_GRAB, RAW_DATA_GRAB_START)?;
        let mut pixels = frame.iter_mut();
        let mut current = pixels.next();
        let mut done: u16 = 0;
        for _ in 0..MAX_GRAB_READS {
            let Some(pixel) = current.as_deref_mut() else {
                break;
            };
            let byte = self.read_register(RAW_DATA_GRAB)?;
            match byte & GRAB_TAG_MASK {
                GRAB_TAG_UPPER => {
                    *pixel = (*pixel & 0b0000_0011) | ((byte & GRAB_UPPER_DATA_MASK) << 2);
                }
                GRAB_TAG_LOWER => {
                    *pixel = (*pixel & 0b1111_1100) | ((byte & GRAB_LOWER_DATA_MASK) >> 2);
                    done = done.saturating_add(1);
                    current = pixels.next();
                }
                _ => {}
            }
        }
        if current.is_some() {
            return Err(Error::FrameTimeout { pixels: done });
        }
        Ok(())
    }

    /// Writes one register (transaction shape in the module docs).
    pub fn write_register(&mut self, register: u8, value: u8) -> Result<(), Error<SPI::Error>> {
        self.spi.transaction(&mut [
            Operation::Write(&[register | WRITE_FLAG, value]),
            Operation::DelayNs(T_SWW_NS),
        ])?;
        Ok(())
    }

    /// Reads one register (transaction shape in the module docs).
    pub fn read_register(&mut self, register: u8) -> Result<u8, Error<SPI::Error>> {
        let mut data = [0u8];
        self.spi.transaction(&mut [
            Operation::Write(&[register & ADDRESS_MASK]),
            Operation::DelayNs(T_SRAD_NS),
            Operation::TransferInPlace(&mut data),
            Operation::DelayNs(T_SRR_NS),
        ])?;
        let [value] = data;
        Ok(value)
    }

    /// Runs a configuration table: writes and waits.
    pub fn run_table(&mut self, table: &[ConfigStep]) -> Result<(), Error<SPI::Error>> {
        for step in table {
            match *step {
                ConfigStep::Write { register, value } => self.write_register(register, value)?,
                ConfigStep::DelayMs(ms) => self.delay.delay_ms(ms),
            }
        }
        Ok(())
    }

    fn clear_motion(&mut self) -> Result<(), Error<SPI::Error>> {
        for register in [MOTION, DELTA_X_L, DELTA_X_H, DELTA_Y_L, DELTA_Y_H] {
            self.read_register(register)?;
        }
        Ok(())
    }

    fn calibration_prologue(&mut self) -> Result<(), Error<SPI::Error>> {
        self.run_table(config::CALIBRATION_STEP_1)?;
        let probe = self.read_register(config::CAL_PROBE_REGISTER)?;
        let value = if probe & config::CAL_PROBE_BIT != 0 {
            config::CAL_PROBE_VALUE_SET
        } else {
            config::CAL_PROBE_VALUE_CLEAR
        };
        self.write_register(config::CAL_PROBE_TARGET, value)?;
        self.run_table(config::CALIBRATION_STEP_2)?;
        if self.read_register(config::CAL_STATUS_REGISTER)? == 0 {
            let c1 = self.read_register(config::CAL_C1_REGISTER)?;
            let c2 = self.read_register(config::CAL_C2_REGISTER)?;
            self.run_table(config::CALIBRATION_TRIM_SETUP)?;
            self.write_register(config::CAL_C1_REGISTER, config::adjusted_c1(c1))?;
            self.write_register(config::CAL_C2_REGISTER, config::adjusted_c2(c2))?;
        }
        Ok(())
    }
}

impl<SPI: SpiDevice, D: DelayNs> FlowSource for FlowSensor<SPI, D> {
    type Error = Error<SPI::Error>;
    fn read_flow(&mut self, t: Timestamp) -> Result<FlowSample, Self::Error> {
        self.read_sample(t)
    }
}

impl<SPI: SpiDevice, D: DelayNs> FlowFrameSource for FlowSensor<SPI, D> {
    type Error = Error<SPI::Error>;
    fn grab_frame(&mut self, frame: &mut [u8; FLOW_FRAME_LEN]) -> Result<(), Self::Error> {
        self.capture_frame(frame)
    }
}
