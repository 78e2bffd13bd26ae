//! The embedded sample data: one little-endian byte stream that the host
//! generator (`cargo run --release --example firmware_data`) writes to
//! `firmware/data/sample.bin`, and that the firmware and the host check both
//! read with [`Records`].
//!
//! Layout (all integers and floats little-endian, no padding):
//!
//! - header: magic `TRSD`, version `u16`, then [`Header`]: IMU noise
//!   densities (4 `f32`), encoder counts per revolution (`u32`), left and
//!   right wheel radius and wheel base (3 `f32`), flow counts per radian and
//!   height (2 `f32`), then `T_BS` of the flow sensor, the camera and the IMU
//!   (16 `f32` each, row-major, as in an ASL `sensor.yaml`);
//! - records, in the order they are processed, each a tag byte then:
//!   - `1` IMU: `t u64`, gyro `3 f32` (rad/s), accel `3 f32` (m/s^2);
//!   - `2` wheel counts: `t u64`, left `i64`, right `i64`;
//!   - `3` flow report: `t u64`, `dx i16`, `dy i16`, `squal u8`,
//!     `shutter u16`, `raw_sum u8`, `raw_max u8`, `raw_min u8`, `motion u8`;
//!   - `4` camera motion: `t0 u64`, `t1 u64`, `R` (9 `f32`, row-major),
//!     `t/d` (3 `f32`), `inliers u16`, `inlier_ratio f32`, `residual_px f32`;
//!   - `0`: the end.
//!
//! The same module is compiled into the firmware (no_std) and, by `#[path]`,
//! into the host test and the generator, so the format is written once.

use core::fmt;

use traction::vslam_core::geometry::{Mat3, Rot3, Vec3};
use traction::vslam_core::scale::CameraMotion;
use traction::vslam_core::sensors::{FlowSample, RawImuSample, WheelTicks};
use traction::vslam_core::{Stream, Timestamp};

/// First four bytes of the stream.
pub const MAGIC: [u8; 4] = *b"TRSD";
/// Format version this code reads and writes.
pub const VERSION: u16 = 1;

const TAG_END: u8 = 0;
const TAG_IMU: u8 = 1;
const TAG_WHEEL: u8 = 2;
const TAG_FLOW: u8 = 3;
const TAG_CAMERA: u8 = 4;

/// What the configuration of the run needs to know of the robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Header {
    /// Accelerometer, gyroscope noise density; accelerometer, gyroscope random walk.
    pub imu_noise: [f32; 4],
    /// Encoder counts per wheel revolution.
    pub ticks_per_revolution: u32,
    /// Left and right wheel radius, metres.
    pub wheel_radius: [f32; 2],
    /// Distance between the wheels, metres.
    pub wheel_base: f32,
    /// Flow sensor counts per radian.
    pub flow_counts_per_radian: f32,
    /// Flow sensor height above the floor, metres.
    pub flow_height: f32,
    /// `T_BS` of the flow sensor, row-major.
    pub flow_t_bs: [f32; 16],
    /// `T_BS` of the upward camera, row-major.
    pub camera_t_bs: [f32; 16],
    /// `T_BS` of the IMU, row-major.
    pub imu_t_bs: [f32; 16],
}

/// One record of the stream.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Record {
    /// An IMU sample.
    Imu(RawImuSample),
    /// Cumulative wheel counts.
    Wheel(WheelTicks),
    /// A flow report.
    Flow(FlowSample),
    /// The motion of the upward camera between two frames.
    Camera(CameraMotion),
}

impl Record {
    /// The stream the record belongs to.
    pub const fn stream(&self) -> Stream {
        match self {
            Record::Imu(_) => Stream::Imu,
            Record::Wheel(_) => Stream::Wheel,
            Record::Flow(_) => Stream::Flow,
            Record::Camera(_) => Stream::Camera,
        }
    }
}

/// Why the stream could not be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatError {
    /// The magic or the version is wrong.
    NotSampleData,
    /// The stream ends inside the header or a record, or has no end tag.
    Truncated,
    /// A record's tag is unknown.
    UnknownTag(u8),
    /// A camera record does not make a valid motion.
    BadCamera,
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FormatError::NotSampleData => f.write_str("not sample data of this version"),
            FormatError::Truncated => f.write_str("sample data truncated"),
            FormatError::UnknownTag(t) => write!(f, "unknown record tag {t}"),
            FormatError::BadCamera => f.write_str("invalid camera motion record"),
        }
    }
}

impl core::error::Error for FormatError {}

/// A cursor over the bytes; every read is checked.
struct Cursor<'a> {
    rest: &'a [u8],
}

impl<'a> Cursor<'a> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], FormatError> {
        let (head, rest) = self
            .rest
            .split_first_chunk::<N>()
            .ok_or(FormatError::Truncated)?;
        self.rest = rest;
        Ok(*head)
    }
    fn u8(&mut self) -> Result<u8, FormatError> {
        self.take::<1>().map(|[b]| b)
    }
    fn u16(&mut self) -> Result<u16, FormatError> {
        self.take().map(u16::from_le_bytes)
    }
    fn i16(&mut self) -> Result<i16, FormatError> {
        self.take().map(i16::from_le_bytes)
    }
    fn u32(&mut self) -> Result<u32, FormatError> {
        self.take().map(u32::from_le_bytes)
    }
    fn u64(&mut self) -> Result<u64, FormatError> {
        self.take().map(u64::from_le_bytes)
    }
    fn i64(&mut self) -> Result<i64, FormatError> {
        self.take().map(i64::from_le_bytes)
    }
    fn f32(&mut self) -> Result<f32, FormatError> {
        self.take().map(f32::from_le_bytes)
    }
    fn f32s<const N: usize>(&mut self) -> Result<[f32; N], FormatError> {
        let mut out = [0.0; N];
        for v in out.iter_mut() {
            *v = self.f32()?;
        }
        Ok(out)
    }
}

/// Reads the header; gives it and the record reader.
pub fn open(bytes: &[u8]) -> Result<(Header, Records<'_>), FormatError> {
    let mut c = Cursor { rest: bytes };
    if c.take::<4>()? != MAGIC || c.u16()? != VERSION {
        return Err(FormatError::NotSampleData);
    }
    let header = Header {
        imu_noise: c.f32s()?,
        ticks_per_revolution: c.u32()?,
        wheel_radius: c.f32s()?,
        wheel_base: c.f32()?,
        flow_counts_per_radian: c.f32()?,
        flow_height: c.f32()?,
        flow_t_bs: c.f32s()?,
        camera_t_bs: c.f32s()?,
        imu_t_bs: c.f32s()?,
    };
    Ok((
        header,
        Records {
            cursor: c,
            done: false,
        },
    ))
}

/// The records after the header, in stream order; stops at the end tag.
pub struct Records<'a> {
    cursor: Cursor<'a>,
    done: bool,
}

impl Records<'_> {
    fn record(&mut self) -> Result<Option<Record>, FormatError> {
        let c = &mut self.cursor;
        let record = match c.u8()? {
            TAG_END => return Ok(None),
            TAG_IMU => Record::Imu(RawImuSample {
                t: Timestamp(c.u64()?),
                gyro: c.f32s()?,
                accel: c.f32s()?,
            }),
            TAG_WHEEL => Record::Wheel(WheelTicks {
                t: Timestamp(c.u64()?),
                left: c.i64()?,
                right: c.i64()?,
            }),
            TAG_FLOW => Record::Flow(FlowSample {
                t: Timestamp(c.u64()?),
                dx: c.i16()?,
                dy: c.i16()?,
                squal: c.u8()?,
                shutter: c.u16()?,
                raw_sum: c.u8()?,
                raw_max: c.u8()?,
                raw_min: c.u8()?,
                motion: c.u8()? != 0,
            }),
            TAG_CAMERA => {
                let t0 = Timestamp(c.u64()?);
                let t1 = Timestamp(c.u64()?);
                let [r00, r01, r02, r10, r11, r12, r20, r21, r22] = c.f32s()?;
                let r = Rot3::from_matrix_unchecked(Mat3::new(
                    r00, r01, r02, r10, r11, r12, r20, r21, r22,
                ));
                let t = Vec3::from(c.f32s::<3>()?);
                let inliers = c.u16()?;
                let ratio = c.f32()?;
                let residual = c.f32()?;
                let m = CameraMotion::new(t0, t1, r, t, inliers, ratio, residual)
                    .map_err(|_| FormatError::BadCamera)?;
                Record::Camera(m)
            }
            tag => return Err(FormatError::UnknownTag(tag)),
        };
        Ok(Some(record))
    }
}

impl Iterator for Records<'_> {
    type Item = Result<Record, FormatError>;
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.record();
        // Stop at the end tag and after the first error.
        self.done = !matches!(r, Ok(Some(_)));
        r.transpose()
    }
}

/// Writes the header through `out`.
pub fn write_header(h: &Header, out: &mut impl FnMut(&[u8])) {
    out(&MAGIC);
    out(&VERSION.to_le_bytes());
    let floats = |out: &mut dyn FnMut(&[u8]), v: &[f32]| {
        for x in v {
            out(&x.to_le_bytes());
        }
    };
    floats(out, &h.imu_noise);
    out(&h.ticks_per_revolution.to_le_bytes());
    floats(out, &h.wheel_radius);
    floats(
        out,
        &[h.wheel_base, h.flow_counts_per_radian, h.flow_height],
    );
    floats(out, &h.flow_t_bs);
    floats(out, &h.camera_t_bs);
    floats(out, &h.imu_t_bs);
}

/// Writes one record through `out`.
pub fn write_record(r: &Record, out: &mut impl FnMut(&[u8])) {
    match r {
        Record::Imu(s) => {
            out(&[TAG_IMU]);
            out(&s.t.0.to_le_bytes());
            for v in s.gyro.iter().chain(s.accel.iter()) {
                out(&v.to_le_bytes());
            }
        }
        Record::Wheel(w) => {
            out(&[TAG_WHEEL]);
            out(&w.t.0.to_le_bytes());
            out(&w.left.to_le_bytes());
            out(&w.right.to_le_bytes());
        }
        Record::Flow(f) => {
            out(&[TAG_FLOW]);
            out(&f.t.0.to_le_bytes());
            out(&f.dx.to_le_bytes());
            out(&f.dy.to_le_bytes());
            out(&[f.squal]);
            out(&f.shutter.to_le_bytes());
            out(&[f.raw_sum, f.raw_max, f.raw_min, u8::from(f.motion)]);
        }
        Record::Camera(m) => {
            out(&[TAG_CAMERA]);
            out(&m.t0().0.to_le_bytes());
            out(&m.t1().0.to_le_bytes());
            // Row-major, as read back.
            let r = m.r().matrix();
            for row in r.row_iter() {
                for v in row.iter() {
                    out(&v.to_le_bytes());
                }
            }
            for v in m.t_over_d().iter() {
                out(&v.to_le_bytes());
            }
            out(&m.inliers().to_le_bytes());
            out(&m.inlier_ratio().to_le_bytes());
            out(&m.residual_px().to_le_bytes());
        }
    }
}

/// Writes the end tag through `out`.
pub fn write_end(out: &mut impl FnMut(&[u8])) {
    out(&[TAG_END]);
}
