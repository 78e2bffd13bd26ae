//! Decoders of the ROS 1 messages `host-sim import rosbag` reads, from their
//! serialised bytes (ROS 1 serialisation: little-endian, fixed-size fields
//! in declaration order, strings and variable arrays prefixed by a `u32`
//! length; <http://wiki.ros.org/msg>, "Serialization"). Field layouts:
//! `std_msgs/Header`, `sensor_msgs/Imu`, `nav_msgs/Odometry`,
//! `sensor_msgs/NavSatFix`, `tf2_msgs/TFMessage`. Every read is bounds
//! checked: truncated or malformed bytes are a [`MsgError`], never a panic.

use std::fmt;

/// Why a message could not be decoded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MsgError {
    /// The bytes ended inside field `field`.
    Truncated(&'static str),
    /// A string was not UTF-8.
    NotUtf8(&'static str),
    /// Bytes were left over after the last field.
    TrailingBytes(usize),
}

impl fmt::Display for MsgError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MsgError::Truncated(field) => write!(f, "message ends inside `{field}`"),
            MsgError::NotUtf8(field) => write!(f, "`{field}` is not UTF-8"),
            MsgError::TrailingBytes(n) => write!(f, "{n} bytes after the last field"),
        }
    }
}

impl std::error::Error for MsgError {}

/// A bounds-checked reader over serialised bytes.
struct Reader<'a> {
    data: &'a [u8],
}

impl<'a> Reader<'a> {
    fn bytes(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], MsgError> {
        if self.data.len() < n {
            return Err(MsgError::Truncated(field));
        }
        let (head, rest) = self.data.split_at(n);
        self.data = rest;
        Ok(head)
    }

    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], MsgError> {
        let b = self.bytes(N, field)?;
        let mut out = [0u8; N];
        out.copy_from_slice(b);
        Ok(out)
    }

    fn u32(&mut self, field: &'static str) -> Result<u32, MsgError> {
        self.array(field).map(u32::from_le_bytes)
    }

    fn f64(&mut self, field: &'static str) -> Result<f64, MsgError> {
        self.array(field).map(f64::from_le_bytes)
    }

    fn f64s<const N: usize>(&mut self, field: &'static str) -> Result<[f64; N], MsgError> {
        let mut out = [0f64; N];
        for x in &mut out {
            *x = self.f64(field)?;
        }
        Ok(out)
    }

    fn string(&mut self, field: &'static str) -> Result<String, MsgError> {
        let n = self.u32(field)? as usize;
        let b = self.bytes(n, field)?;
        std::str::from_utf8(b)
            .map(str::to_owned)
            .map_err(|_| MsgError::NotUtf8(field))
    }

    fn header(&mut self) -> Result<Header, MsgError> {
        let _seq = self.u32("header.seq")?;
        let sec = self.u32("header.stamp")?;
        let nsec = self.u32("header.stamp")?;
        Ok(Header {
            stamp_ns: u64::from(sec) * 1_000_000_000 + u64::from(nsec),
            frame_id: self.string("header.frame_id")?,
        })
    }

    fn end(self) -> Result<(), MsgError> {
        match self.data.len() {
            0 => Ok(()),
            n => Err(MsgError::TrailingBytes(n)),
        }
    }
}

/// `std_msgs/Header` without its sequence number.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Stamp, nanoseconds (`sec * 1e9 + nsec`).
    pub stamp_ns: u64,
    /// Frame of the data.
    pub frame_id: String,
}

/// `sensor_msgs/Imu`.
#[derive(Clone, Debug, PartialEq)]
pub struct Imu {
    /// Header.
    pub header: Header,
    /// Orientation `x, y, z, w`.
    pub orientation: [f64; 4],
    /// Angular velocity, rad/s.
    pub angular_velocity: [f64; 3],
    /// Row-major covariance of the angular velocity (`[0] = -1`: unknown).
    pub angular_velocity_covariance: [f64; 9],
    /// Linear acceleration (specific force), m/s^2.
    pub linear_acceleration: [f64; 3],
    /// Row-major covariance of the acceleration (`[0] = -1`: unknown).
    pub linear_acceleration_covariance: [f64; 9],
}

/// Decodes a `sensor_msgs/Imu`.
pub fn decode_imu(data: &[u8]) -> Result<Imu, MsgError> {
    let mut r = Reader { data };
    let header = r.header()?;
    let orientation = r.f64s::<4>("orientation")?;
    let _ = r.f64s::<9>("orientation_covariance")?;
    let angular_velocity = r.f64s::<3>("angular_velocity")?;
    let angular_velocity_covariance = r.f64s::<9>("angular_velocity_covariance")?;
    let linear_acceleration = r.f64s::<3>("linear_acceleration")?;
    let linear_acceleration_covariance = r.f64s::<9>("linear_acceleration_covariance")?;
    r.end()?;
    Ok(Imu {
        header,
        orientation,
        angular_velocity,
        angular_velocity_covariance,
        linear_acceleration,
        linear_acceleration_covariance,
    })
}

/// `nav_msgs/Odometry`: the parts the importer uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Odometry {
    /// Header (frame of the pose).
    pub header: Header,
    /// Frame of the twist.
    pub child_frame_id: String,
    /// Position, m.
    pub position: [f64; 3],
    /// Orientation `x, y, z, w`.
    pub orientation: [f64; 4],
    /// Linear velocity in the child frame, m/s.
    pub linear: [f64; 3],
    /// Angular velocity in the child frame, rad/s.
    pub angular: [f64; 3],
}

/// Decodes a `nav_msgs/Odometry`.
pub fn decode_odometry(data: &[u8]) -> Result<Odometry, MsgError> {
    let mut r = Reader { data };
    let header = r.header()?;
    let child_frame_id = r.string("child_frame_id")?;
    let position = r.f64s::<3>("pose.position")?;
    let orientation = r.f64s::<4>("pose.orientation")?;
    let _ = r.f64s::<36>("pose.covariance")?;
    let linear = r.f64s::<3>("twist.linear")?;
    let angular = r.f64s::<3>("twist.angular")?;
    let _ = r.f64s::<36>("twist.covariance")?;
    r.end()?;
    Ok(Odometry {
        header,
        child_frame_id,
        position,
        orientation,
        linear,
        angular,
    })
}

/// `sensor_msgs/NavSatFix`: the parts the importer uses.
#[derive(Clone, Debug, PartialEq)]
pub struct NavSatFix {
    /// Header.
    pub header: Header,
    /// Fix status (-1: no fix, 0: fix, 1: SBAS, 2: GBAS).
    pub status: i8,
    /// Latitude, degrees.
    pub latitude: f64,
    /// Longitude, degrees.
    pub longitude: f64,
    /// Altitude above the WGS 84 ellipsoid, m.
    pub altitude: f64,
}

/// Decodes a `sensor_msgs/NavSatFix`.
pub fn decode_navsatfix(data: &[u8]) -> Result<NavSatFix, MsgError> {
    let mut r = Reader { data };
    let header = r.header()?;
    let [status] = r.array::<1>("status.status")?;
    let _service = r.array::<2>("status.service")?;
    let latitude = r.f64("latitude")?;
    let longitude = r.f64("longitude")?;
    let altitude = r.f64("altitude")?;
    let _ = r.f64s::<9>("position_covariance")?;
    let _ = r.array::<1>("position_covariance_type")?;
    r.end()?;
    Ok(NavSatFix {
        header,
        status: i8::from_le_bytes([status]),
        latitude,
        longitude,
        altitude,
    })
}

/// One `geometry_msgs/TransformStamped`: `p_parent = R p_child + t`.
#[derive(Clone, Debug, PartialEq)]
pub struct Transform {
    /// Parent frame (`header.frame_id`).
    pub parent: String,
    /// Child frame.
    pub child: String,
    /// Translation, m.
    pub translation: [f64; 3],
    /// Rotation `x, y, z, w`.
    pub rotation: [f64; 4],
}

/// Decodes a `tf2_msgs/TFMessage` (or `tf/tfMessage`, the same layout).
pub fn decode_tf(data: &[u8]) -> Result<Vec<Transform>, MsgError> {
    let mut r = Reader { data };
    let n = r.u32("transforms")? as usize;
    // Each transform is at least 12 + 4 + 4 + 56 bytes: a count beyond the
    // bytes left is truncated, not a huge allocation.
    let mut out = Vec::with_capacity(n.min(r.data.len() / 76));
    for _ in 0..n {
        let header = r.header()?;
        let child = r.string("child_frame_id")?;
        let translation = r.f64s::<3>("transform.translation")?;
        let rotation = r.f64s::<4>("transform.rotation")?;
        out.push(Transform {
            parent: header.frame_id,
            child,
            translation,
            rotation,
        });
    }
    r.end()?;
    Ok(out)
}

/// Encoders of the same layouts, for tests and fuzz seeds.
pub mod encode {
    fn header(out: &mut Vec<u8>, stamp_ns: u64, frame: &str) {
        out.extend(0u32.to_le_bytes());
        out.extend(((stamp_ns / 1_000_000_000) as u32).to_le_bytes());
        out.extend(((stamp_ns % 1_000_000_000) as u32).to_le_bytes());
        string(out, frame);
    }

    fn string(out: &mut Vec<u8>, s: &str) {
        out.extend((s.len() as u32).to_le_bytes());
        out.extend(s.as_bytes());
    }

    fn f64s(out: &mut Vec<u8>, v: &[f64]) {
        for x in v {
            out.extend(x.to_le_bytes());
        }
    }

    /// A `sensor_msgs/Imu` (identity orientation, covariances `var`).
    pub fn imu(stamp_ns: u64, frame: &str, gyro: [f64; 3], accel: [f64; 3], var: f64) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, stamp_ns, frame);
        f64s(&mut out, &[0.0, 0.0, 0.0, 1.0]);
        f64s(&mut out, &[0.0; 9]);
        f64s(&mut out, &gyro);
        f64s(&mut out, &[var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, var]);
        f64s(&mut out, &accel);
        f64s(&mut out, &[var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, var]);
        out
    }

    /// A `nav_msgs/Odometry` with twist `(v, 0, 0)`, `(0, 0, w)`.
    pub fn odometry(stamp_ns: u64, child: &str, v: f64, w: f64) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, stamp_ns, "odom");
        string(&mut out, child);
        f64s(&mut out, &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        f64s(&mut out, &[0.0; 36]);
        f64s(&mut out, &[v, 0.0, 0.0, 0.0, 0.0, w]);
        f64s(&mut out, &[0.0; 36]);
        out
    }

    /// A `sensor_msgs/NavSatFix` with a fix.
    pub fn navsatfix(stamp_ns: u64, lat: f64, lon: f64, alt: f64) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, stamp_ns, "gps");
        out.push(0);
        out.extend(1u16.to_le_bytes());
        f64s(&mut out, &[lat, lon, alt]);
        f64s(&mut out, &[0.0; 9]);
        out.push(0);
        out
    }

    /// A `tf2_msgs/TFMessage` with one transform.
    pub fn tf(parent: &str, child: &str, t: [f64; 3], q_xyzw: [f64; 4]) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend(1u32.to_le_bytes());
        header(&mut out, 0, parent);
        string(&mut out, child);
        f64s(&mut out, &t);
        f64s(&mut out, &q_xyzw);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_decode_what_was_encoded() {
        let m = decode_imu(&encode::imu(
            47_580_000_001,
            "base_link",
            [0.1, 0.2, 0.3],
            [0.0, 0.1, 9.8],
            2.5e-5,
        ))
        .unwrap();
        assert_eq!(m.header.stamp_ns, 47_580_000_001);
        assert_eq!(m.header.frame_id, "base_link");
        assert_eq!(m.angular_velocity, [0.1, 0.2, 0.3]);
        assert_eq!(m.linear_acceleration_covariance[4], 2.5e-5);
        let o = decode_odometry(&encode::odometry(5, "base_link", 1.5, -0.5)).unwrap();
        assert_eq!(
            (o.linear[0], o.angular[2], o.child_frame_id.as_str()),
            (1.5, -0.5, "base_link")
        );
        let f = decode_navsatfix(&encode::navsatfix(9, 46.8, -71.2, 100.0)).unwrap();
        assert_eq!(
            (f.status, f.latitude, f.longitude, f.altitude),
            (0, 46.8, -71.2, 100.0)
        );
        let t = decode_tf(&encode::tf(
            "base_link",
            "imu_link",
            [0.1, 0.0, 0.2],
            [0.0, 0.0, 0.0, 1.0],
        ))
        .unwrap();
        assert_eq!(t[0].parent, "base_link");
        assert_eq!(t[0].child, "imu_link");
    }

    #[test]
    fn truncated_and_padded_messages_are_refused() {
        let b = encode::imu(1, "imu", [0.0; 3], [0.0; 3], 1.0);
        for n in 0..b.len() {
            assert!(decode_imu(b.get(..n).unwrap()).is_err(), "{n} bytes");
        }
        let mut padded = b.clone();
        padded.push(0);
        assert_eq!(decode_imu(&padded), Err(MsgError::TrailingBytes(1)));
        let mut tf = encode::tf("a", "b", [0.0; 3], [0.0, 0.0, 0.0, 1.0]);
        tf.splice(0..4, u32::MAX.to_le_bytes());
        assert!(matches!(decode_tf(&tf), Err(MsgError::Truncated(_))));
    }
}
