//! Sample types and the sensor traits the estimator consumes.
//!
//! Raw samples (`Raw*`) are what a driver or a log reader produces; validated
//! samples are built once by a checked constructor that rejects non-finite and
//! impossible fields, so later code never checks again (the smoltcp split of
//! raw and validated types). Drivers know no time: the caller passes the time
//! stamp of the read to every trait method.
//!
//! Core crates own these traits; drivers (`flow-sensor`, `wheel-odom`) and the
//! host simulator implement them.

use crate::geometry::Vec3;
use crate::reject::Reject;
use crate::time::Timestamp;

pub mod flow_optics;

pub use flow_optics::{FlowOptics, FlowOpticsError};

/// An IMU reading as read: gyro (rad/s) and accelerometer (m/s^2) in the IMU frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawImuSample {
    /// When the sample was taken.
    pub t: Timestamp,
    /// Angular rate, rad/s, sensor frame.
    pub gyro: [f32; 3],
    /// Specific force, m/s^2, sensor frame.
    pub accel: [f32; 3],
}

/// A validated IMU reading: every field finite and inside the configured range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    t: Timestamp,
    gyro: Vec3,
    accel: Vec3,
}

impl ImuSample {
    /// Builds a sample; non-finite fields are [`Reject::NonFinite`].
    pub fn new(t: Timestamp, gyro: [f32; 3], accel: [f32; 3]) -> Result<Self, Reject> {
        if !gyro.iter().chain(accel.iter()).all(|v| v.is_finite()) {
            return Err(Reject::NonFinite);
        }
        Ok(ImuSample {
            t,
            gyro: Vec3::from(gyro),
            accel: Vec3::from(accel),
        })
    }

    /// Builds a sample and also rejects readings at or beyond the sensor's
    /// full scale as [`Reject::Saturated`] ([`ImuSample::check_range`]).
    pub fn with_range(raw: &RawImuSample, gyro_max: f32, accel_max: f32) -> Result<Self, Reject> {
        let s = ImuSample::new(raw.t, raw.gyro, raw.accel)?;
        s.check_range(gyro_max, accel_max)?;
        Ok(s)
    }

    /// The one range rule for IMU readings: any axis at or beyond the full
    /// scale (`gyro_max` rad/s, `accel_max` m/s^2) is [`Reject::Saturated`],
    /// the true value being unknown there. The estimator applies it at entry
    /// ([`ImuSample::with_range`]), the EKF to every sample it is handed.
    pub fn check_range(&self, gyro_max: f32, accel_max: f32) -> Result<(), Reject> {
        if self.gyro.amax() >= gyro_max || self.accel.amax() >= accel_max {
            return Err(Reject::Saturated);
        }
        Ok(())
    }

    /// When the sample was taken.
    pub fn t(&self) -> Timestamp {
        self.t
    }
    /// Angular rate, rad/s.
    pub fn gyro(&self) -> &Vec3 {
        &self.gyro
    }
    /// Specific force, m/s^2.
    pub fn accel(&self) -> &Vec3 {
        &self.accel
    }
}

impl TryFrom<RawImuSample> for ImuSample {
    type Error = Reject;
    fn try_from(raw: RawImuSample) -> Result<Self, Reject> {
        ImuSample::new(raw.t, raw.gyro, raw.accel)
    }
}

/// Cumulative signed encoder counts of both wheels (positive = forward).
/// Integers are always representable; jumps are judged by the odometry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WheelTicks {
    /// When the counts were latched.
    pub t: Timestamp,
    /// Left wheel cumulative count.
    pub left: i64,
    /// Right wheel cumulative count.
    pub right: i64,
}

/// One motion report of a downward optical-flow sensor (PixArt PMW3901 /
/// PAA5100JE family): counts since the previous report and image quality.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FlowSample {
    /// When the report was read.
    pub t: Timestamp,
    /// Counts along the sensor's +x since the previous report.
    pub dx: i16,
    /// Counts along the sensor's +y since the previous report.
    pub dy: i16,
    /// Surface quality (number of features), 0..=255.
    pub squal: u8,
    /// Shutter (exposure) in sensor clocks; high means a dark or featureless floor.
    pub shutter: u16,
    /// Average raw pixel value / 2 (`RawData_Sum`), when the source knows it.
    pub raw_sum: u8,
    /// Brightest raw pixel, when the source knows it.
    pub raw_max: u8,
    /// Darkest raw pixel, when the source knows it.
    pub raw_min: u8,
    /// The chip's motion flag.
    pub motion: bool,
}

impl FlowSample {
    /// SQUAL below which, with the shutter at its top, PixArt marks motion
    /// data unreliable (PMW3901MB-TXQT datasheet, Motion_Burst notes).
    pub const SQUAL_MIN: u8 = 0x19;
    /// Shutter upper byte that means "maximum exposure".
    pub const SHUTTER_UPPER_MAX: u8 = 0x1F;

    /// The datasheet's validity rule: unreliable when SQUAL is below
    /// [`Self::SQUAL_MIN`] and the shutter's upper byte equals
    /// [`Self::SHUTTER_UPPER_MAX`]. Low quality otherwise is noise, not invalidity.
    pub fn is_valid(&self) -> bool {
        let shutter_upper = (self.shutter >> 8) as u8;
        !(self.squal < Self::SQUAL_MIN && shutter_upper == Self::SHUTTER_UPPER_MAX)
    }

    /// Whether either delta sits at the 16-bit limit (the true motion is unknown).
    pub fn is_saturated(&self) -> bool {
        [self.dx, self.dy]
            .iter()
            .any(|d| *d == i16::MAX || *d == i16::MIN)
    }

    /// The one rule for a report whose motion cannot be used as a
    /// measurement: [`Reject::Saturated`] ([`Self::is_saturated`]), else
    /// [`Reject::LowQuality`] (not [`Self::is_valid`]). Such a report still
    /// ends the interval of the next one's counts, so it is judged after the
    /// reader's clock has taken its time stamp; the EKF refuses it, the scale
    /// pipeline grades it to zero confidence.
    pub fn check_motion(&self) -> Result<(), Reject> {
        if self.is_saturated() {
            return Err(Reject::Saturated);
        }
        if !self.is_valid() {
            return Err(Reject::LowQuality);
        }
        Ok(())
    }
}

/// Wheel angular rates as a robot reports them instead of encoder counts
/// (rad/s, positive = forward; e.g. a motor controller's measured speeds),
/// unvalidated: the odometry refuses non-finite and impossible values.
/// Each is the rate at `t`; the odometry integrates consecutive samples by
/// the trapezoidal rule.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RawWheelRates {
    /// When the rates were measured.
    pub t: Timestamp,
    /// Left wheel angular rate, rad/s.
    pub left: f32,
    /// Right wheel angular rate, rad/s.
    pub right: f32,
}

/// Wheel angular rates (rad/s, positive = forward) over an interval, as
/// `wheel-odom` derives them from encoder counts; the EKF's wheel
/// measurement. Validated: both rates are finite (the fields are private,
/// so no later code checks again).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelRates {
    t: Timestamp,
    left: f32,
    right: f32,
}

impl WheelRates {
    /// Builds the rates; non-finite values are [`Reject::NonFinite`].
    pub fn new(t: Timestamp, left: f32, right: f32) -> Result<Self, Reject> {
        if !(left.is_finite() && right.is_finite()) {
            return Err(Reject::NonFinite);
        }
        Ok(WheelRates { t, left, right })
    }
    /// End of the interval the rates were measured over.
    pub fn t(&self) -> Timestamp {
        self.t
    }
    /// Left wheel angular rate, rad/s (finite).
    pub fn left(&self) -> f32 {
        self.left
    }
    /// Right wheel angular rate, rad/s (finite).
    pub fn right(&self) -> f32 {
        self.right
    }
}

/// Planar body motion between two time stamps, expressed in the body frame
/// at the start `t0` (x forward, y left, z up): what wheel odometry reports
/// and what the scale pipeline integrates into the wheel transaction `Tw`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryDelta {
    /// Start of the interval.
    pub t0: Timestamp,
    /// End of the interval (`t1 > t0`).
    pub t1: Timestamp,
    /// Displacement of the body origin, metres, body frame at `t0`.
    pub translation: Vec3,
    /// Heading change, radians (counter-clockwise seen from above).
    pub dyaw: f32,
    /// Path length travelled (>= |translation|), metres.
    pub path_length: f32,
}

/// Side length of a raw PixArt flow frame (35 x 35 pixels).
pub const FLOW_FRAME_SIDE: usize = 35;
/// Pixels in a raw PixArt flow frame.
pub const FLOW_FRAME_LEN: usize = FLOW_FRAME_SIDE * FLOW_FRAME_SIDE;

/// A source of IMU samples.
pub trait ImuSource {
    /// Why a read failed.
    type Error;
    /// Reads one sample, time-stamped `t` by the caller.
    fn read_imu(&mut self, t: Timestamp) -> Result<RawImuSample, Self::Error>;
}

/// A source of cumulative wheel encoder counts.
pub trait WheelEncoderSource {
    /// Why a read failed.
    type Error;
    /// Reads both wheels' cumulative counts, time-stamped `t` by the caller.
    fn read_ticks(&mut self, t: Timestamp) -> Result<WheelTicks, Self::Error>;
}

/// A downward optical-flow sensor's motion reports.
pub trait FlowSource {
    /// Why a read failed.
    type Error;
    /// Reads one motion report, time-stamped `t` by the caller.
    fn read_flow(&mut self, t: Timestamp) -> Result<FlowSample, Self::Error>;
}

/// A flow sensor that can hand out its raw 35x35 frame, row-major, one byte a pixel.
pub trait FlowFrameSource {
    /// Why a capture failed.
    type Error;
    /// Captures one raw frame into `frame`.
    fn grab_frame(&mut self, frame: &mut [u8; FLOW_FRAME_LEN]) -> Result<(), Self::Error>;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imu_rejects_non_finite_and_saturated() {
        let t = Timestamp(5);
        assert_eq!(
            ImuSample::new(t, [0.0, f32::NAN, 0.0], [0.0; 3]),
            Err(Reject::NonFinite)
        );
        assert_eq!(
            ImuSample::new(t, [0.0; 3], [f32::INFINITY, 0.0, 0.0]),
            Err(Reject::NonFinite)
        );
        let raw = RawImuSample {
            t,
            gyro: [0.0, 0.0, 34.9],
            accel: [0.0, 0.0, 9.8],
        };
        assert_eq!(
            ImuSample::with_range(&raw, 34.9, 156.0),
            Err(Reject::Saturated)
        );
        assert!(ImuSample::with_range(&raw, 35.0, 156.0).is_ok());
    }

    #[test]
    fn flow_validity_follows_the_datasheet_rule() {
        let mut s = FlowSample {
            squal: 0x18,
            shutter: 0x1F00,
            ..FlowSample::default()
        };
        assert!(!s.is_valid());
        s.squal = 0x19;
        assert!(s.is_valid());
        s.squal = 0;
        s.shutter = 0x1E00;
        assert!(s.is_valid());
        assert_eq!(s.check_motion(), Ok(()));
        s.dx = i16::MIN;
        assert!(s.is_saturated());
        assert_eq!(s.check_motion(), Err(Reject::Saturated));
        s.dx = 0;
        s.shutter = 0x1F00;
        assert_eq!(s.check_motion(), Err(Reject::LowQuality));
    }
}
