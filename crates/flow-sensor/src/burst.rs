//! Decoding the 12-byte Motion_Burst (register 0x16) of the PMW3901MB /
//! PAA5100JE (datasheet "Motion Burst" table): Motion, Observation,
//! Delta_X_L, Delta_X_H, Delta_Y_L, Delta_Y_H, SQUAL, RawData_Sum,
//! Maximum_RawData, Minimum_RawData, Shutter_Upper, Shutter_Lower.
//!
//! Note the byte orders: the deltas come low byte first, the shutter high
//! byte first.

use crate::registers::{MOTION_BURST_LEN, MOTION_MOT, burst};
use vslam_core::Timestamp;
use vslam_core::sensors::FlowSample;

/// One decoded Motion_Burst.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MotionBurst {
    /// Motion register as read (bit 7: motion since the last report).
    pub motion: u8,
    /// Observation register as read.
    pub observation: u8,
    /// X motion, counts.
    pub delta_x: i16,
    /// Y motion, counts.
    pub delta_y: i16,
    /// Surface quality.
    pub squal: u8,
    /// Average raw pixel value / 2.
    pub raw_data_sum: u8,
    /// Brightest raw pixel.
    pub max_raw_data: u8,
    /// Darkest raw pixel.
    pub min_raw_data: u8,
    /// Shutter, sensor clocks (Shutter_Upper << 8 | Shutter_Lower).
    pub shutter: u16,
}

impl MotionBurst {
    /// Decodes the burst bytes in datasheet order.
    pub const fn from_bytes(b: &[u8; MOTION_BURST_LEN]) -> Self {
        MotionBurst {
            motion: b[burst::MOTION],
            observation: b[burst::OBSERVATION],
            delta_x: i16::from_le_bytes([b[burst::DELTA_X_L], b[burst::DELTA_X_H]]),
            delta_y: i16::from_le_bytes([b[burst::DELTA_Y_L], b[burst::DELTA_Y_H]]),
            squal: b[burst::SQUAL],
            raw_data_sum: b[burst::RAW_DATA_SUM],
            max_raw_data: b[burst::MAXIMUM_RAW_DATA],
            min_raw_data: b[burst::MINIMUM_RAW_DATA],
            shutter: u16::from_be_bytes([b[burst::SHUTTER_UPPER], b[burst::SHUTTER_LOWER]]),
        }
    }

    /// Whether the chip flagged motion since the previous report.
    pub const fn has_motion(&self) -> bool {
        self.motion & MOTION_MOT != 0
    }

    /// The vocabulary sample, time-stamped `t` (no rotation applied).
    pub const fn to_sample(&self, t: Timestamp) -> FlowSample {
        FlowSample {
            t,
            dx: self.delta_x,
            dy: self.delta_y,
            squal: self.squal,
            shutter: self.shutter,
            raw_sum: self.raw_data_sum,
            raw_max: self.max_raw_data,
            raw_min: self.min_raw_data,
            motion: self.has_motion(),
        }
    }

    /// The datasheet's validity rule (SQUAL and Shutter_Upper), as
    /// [`FlowSample::is_valid`] states it.
    pub fn is_valid(&self) -> bool {
        self.to_sample(Timestamp(0)).is_valid()
    }
}
