//! ROS 1 bag files (format 2.0, <http://wiki.ros.org/Bags/Format/2.0>) read
//! with the `rosbag` crate (chunks stored plain, bz2 or lz4), without ROS.
//!
//! - `sensor_msgs/Imu` (header stamps) to `imu0`: angular velocity and
//!   linear acceleration as they are (REP 103: specific force, +g on z when
//!   level). `T_BS` from the static transforms (`/tf_static`) between the
//!   base frame (the odometry's `child_frame_id`, else `base_link`) and the
//!   IMU's `frame_id`; identity when they are the same frame or no
//!   transform is found (a note says which). Noise densities from the
//!   message covariances when given (`sqrt(var / rate)`).
//! - `nav_msgs/Odometry` to the `wheel0` rates variant: the twist's forward
//!   speed `v` and yaw rate `w` as the wheel angular rates of a differential
//!   drive with the given radius `r` and track `b`:
//!   `left = (v - w b / 2) / r`, `right = (v + w b / 2) / r`. These are the
//!   odometry's own wheel model, not measured wheel speeds.
//! - `sensor_msgs/NavSatFix` (fixes only, `status >= 0`) to
//!   `state_groundtruth_estimate0` in east-north-up metres about the first
//!   fix ([`super::enu`]), with `reference: gps` in `labels.yaml`: position
//!   only (attitude written as identity), in ENU rather than the robot's
//!   start frame.
//!
//! Messages are taken in header-stamp order; a stamp equal to the one
//! before is dropped (counted in a note). Before the `rosbag` crate reads a
//! file, its bag header is checked here (the crate slices the file at the
//! header's `index_pos` without a bounds check).

use super::ros_msg::{self, Transform};
use super::{enu::Enu, median_rate_hz, yaw_quaternion};
use crate::asl::{Dataset, GroundTruth, ImuMeta, Labels, WheelMeta};
use crate::error::CliError;
use rosbag::{ChunkRecord, IndexRecord, MessageRecord, RosBag};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;
use vslam_core::Timestamp;
use vslam_core::robot::ImuNoise;
use vslam_core::sensors::{RawImuSample, RawWheelRates};

/// How to read a bag.
#[derive(Clone, Debug, PartialEq)]
pub struct BagOptions {
    /// IMU topic (default: the only `sensor_msgs/Imu` topic).
    pub imu_topic: Option<String>,
    /// Odometry topic (default: the only `nav_msgs/Odometry` topic).
    pub odom_topic: Option<String>,
    /// GPS topic (default: the only `sensor_msgs/NavSatFix` topic).
    pub gps_topic: Option<String>,
    /// Wheel radius for the odometry's wheel rates, m.
    pub wheel_radius: f64,
    /// Track for the odometry's wheel rates, m.
    pub track: f64,
}

impl Default for BagOptions {
    /// Topics chosen by type; a Clearpath Jackal's wheels (radius 0.098 m,
    /// track 0.37559 m, from `jackal_description`).
    fn default() -> Self {
        BagOptions {
            imu_topic: None,
            odom_topic: None,
            gps_topic: None,
            wheel_radius: 0.098,
            track: 0.37559,
        }
    }
}

const IMU_TYPE: &str = "sensor_msgs/Imu";
const ODOM_TYPE: &str = "nav_msgs/Odometry";
const GPS_TYPE: &str = "sensor_msgs/NavSatFix";
const TF_TYPES: [&str; 2] = ["tf2_msgs/TFMessage", "tf/tfMessage"];
const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// Checks the bag header record: the version line, and an `index_pos` inside
/// the file after the header. `head` is the file's first bytes (at least
/// the header record), `len` the file's length.
pub fn check_bag_header(head: &[u8], len: u64) -> Result<(), String> {
    let rest = head
        .strip_prefix(MAGIC)
        .ok_or("not a ROS 1 bag of format 2.0 (no `#ROSBAG V2.0` line)")?;
    let u32_at = |b: &[u8], i: usize| -> Option<u32> {
        b.get(i..i + 4)
            .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    };
    let hlen = u32_at(rest, 0).ok_or("bag header truncated")? as usize;
    let header = rest.get(4..4 + hlen).ok_or("bag header truncated")?;
    let dlen = u32_at(rest, 4 + hlen).ok_or("bag header truncated")? as u64;
    let start = MAGIC.len() as u64 + 8 + hlen as u64 + dlen;
    let mut i = 0;
    let mut index_pos = None;
    while i < header.len() {
        let flen = u32_at(header, i).ok_or("bag header field truncated")? as usize;
        let field = header
            .get(i + 4..i + 4 + flen)
            .ok_or("bag header field truncated")?;
        if let Some(v) = field.strip_prefix(b"index_pos=") {
            let b: [u8; 8] = v
                .try_into()
                .map_err(|_| "bag header `index_pos` is not 8 bytes")?;
            index_pos = Some(u64::from_le_bytes(b));
        }
        i += 4 + flen;
    }
    let index_pos = index_pos.ok_or("bag header has no `index_pos`")?;
    if index_pos < start || index_pos > len {
        return Err(format!(
            "bag header's index_pos {index_pos} is outside the file's records ({start}..{len}): truncated or unindexed bag (`rosbag reindex` fixes one)"
        ));
    }
    Ok(())
}

/// One connection of a bag.
#[derive(Clone, Debug, PartialEq)]
pub struct Connection {
    /// Topic.
    pub topic: String,
    /// Message type.
    pub tp: String,
}

fn bag_error(path: &Path, what: &str, e: impl std::fmt::Display) -> CliError {
    CliError::file(path, format!("{what}: {e}"))
}

/// The messages of the chosen connections, decoded.
#[derive(Default)]
struct Decoded {
    imu: Vec<ros_msg::Imu>,
    odom: Vec<ros_msg::Odometry>,
    gps: Vec<ros_msg::NavSatFix>,
    tf: Vec<Transform>,
}

/// The topic of type `tp` to read: `flag` when given (it must exist and be
/// of that type), else the only topic of that type (none: `None`; several:
/// the flag is needed).
fn choose(
    path: &Path,
    conns: &BTreeMap<u32, Connection>,
    flag: Option<&str>,
    tp: &str,
    flag_name: &str,
) -> Result<Option<String>, CliError> {
    let mut topics: Vec<&str> = conns
        .values()
        .filter(|c| c.tp == tp)
        .map(|c| c.topic.as_str())
        .collect();
    topics.dedup();
    match flag {
        Some(f) => match conns.values().find(|c| c.topic == f) {
            Some(c) if c.tp == tp => Ok(Some(f.to_string())),
            Some(c) => Err(CliError::Usage(format!(
                "{flag_name} {f}: the topic has type {}, not {tp}",
                c.tp
            ))),
            None => Err(bag_error(
                path,
                flag_name,
                format!("no topic `{f}` in the bag"),
            )),
        },
        None => match topics.as_slice() {
            [] => Ok(None),
            [one] => Ok(Some((*one).to_string())),
            many => Err(CliError::Usage(format!(
                "several {tp} topics ({}): choose one with {flag_name}",
                many.join(", ")
            ))),
        },
    }
}

/// Reads a bag into a dataset.
pub fn read(path: &Path, o: &BagOptions) -> Result<Dataset, CliError> {
    let mut head = Vec::new();
    let len = std::fs::metadata(path)
        .map_err(|e| CliError::file(path, format!("cannot read: {e}")))?
        .len();
    std::fs::File::open(path)
        .and_then(|f| f.take(64 * 1024).read_to_end(&mut head))
        .map_err(|e| CliError::file(path, format!("cannot read: {e}")))?;
    check_bag_header(&head, len).map_err(|e| CliError::file(path, e))?;
    let bag = RosBag::new(path).map_err(|e| bag_error(path, "cannot open the bag", e))?;

    let mut conns: BTreeMap<u32, Connection> = BTreeMap::new();
    for rec in bag.index_records() {
        if let IndexRecord::Connection(c) = rec.map_err(|e| bag_error(path, "index", e))? {
            conns.insert(
                c.id,
                Connection {
                    topic: c.topic.to_string(),
                    tp: c.tp.to_string(),
                },
            );
        }
    }
    let imu_topic = choose(
        path,
        &conns,
        o.imu_topic.as_deref(),
        IMU_TYPE,
        "--imu-topic",
    )?;
    let odom_topic = choose(
        path,
        &conns,
        o.odom_topic.as_deref(),
        ODOM_TYPE,
        "--odom-topic",
    )?;
    let gps_topic = choose(
        path,
        &conns,
        o.gps_topic.as_deref(),
        GPS_TYPE,
        "--gps-topic",
    )?;
    if imu_topic.is_none() && odom_topic.is_none() {
        return Err(CliError::file(
            path,
            format!("no {IMU_TYPE} or {ODOM_TYPE} topic in the bag"),
        ));
    }
    let decoded = decode_all(path, &bag, &conns, [&imu_topic, &odom_topic, &gps_topic])?;
    to_dataset(path, decoded, o, [imu_topic, odom_topic, gps_topic])
}

fn decode_all(
    path: &Path,
    bag: &RosBag,
    conns: &BTreeMap<u32, Connection>,
    [imu, odom, gps]: [&Option<String>; 3],
) -> Result<Decoded, CliError> {
    let is =
        |id: u32, t: &Option<String>| conns.get(&id).is_some_and(|c| Some(&c.topic) == t.as_ref());
    let is_tf = |id: u32| {
        conns
            .get(&id)
            .is_some_and(|c| c.topic == "/tf_static" && TF_TYPES.contains(&c.tp.as_str()))
    };
    let mut d = Decoded::default();
    for (k, rec) in bag.chunk_records().enumerate() {
        let ChunkRecord::Chunk(chunk) =
            rec.map_err(|e| bag_error(path, &format!("chunk record {k}"), e))?
        else {
            continue;
        };
        for (j, msg) in chunk.messages().enumerate() {
            let what = || format!("chunk record {k}, record {j}");
            let MessageRecord::MessageData(m) = msg.map_err(|e| bag_error(path, &what(), e))?
            else {
                continue;
            };
            let id = m.conn_id;
            let bad = |e: ros_msg::MsgError| {
                let c = conns
                    .get(&id)
                    .map_or(String::new(), |c| format!(" ({} on {})", c.tp, c.topic));
                bag_error(path, &format!("{}{c}", what()), e)
            };
            if is(id, imu) {
                d.imu.push(ros_msg::decode_imu(m.data).map_err(bad)?);
            } else if is(id, odom) {
                d.odom.push(ros_msg::decode_odometry(m.data).map_err(bad)?);
            } else if is(id, gps) {
                d.gps.push(ros_msg::decode_navsatfix(m.data).map_err(bad)?);
            } else if is_tf(id) {
                d.tf.extend(ros_msg::decode_tf(m.data).map_err(bad)?);
            }
        }
    }
    Ok(d)
}

/// Sorts by stamp and drops repeated stamps; gives how many were dropped.
fn in_stamp_order<T>(v: &mut Vec<T>, stamp: impl Fn(&T) -> u64) -> usize {
    v.sort_by_key(|x| stamp(x));
    let before = v.len();
    v.dedup_by_key(|x| stamp(x));
    before - v.len()
}

/// Row-major `T_BS` from a rotation `x, y, z, w` and a translation.
fn matrix(q: [f64; 4], t: [f64; 3]) -> [f32; 16] {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let [x, y, z, w] = if n > 0.0 {
        q.map(|v| v / n)
    } else {
        [0.0, 0.0, 0.0, 1.0]
    };
    let r = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    let mut m = [0f32; 16];
    for i in 0..3 {
        for j in 0..3 {
            m[4 * i + j] = r[i][j] as f32;
        }
        m[4 * i + 3] = t[i] as f32;
    }
    m[15] = 1.0;
    m
}

/// `T_BS` of the IMU frame `imu` in the base frame `base`, and how it was found.
fn imu_mount(tf: &[Transform], base: &str, imu: &str) -> ([f32; 16], String) {
    if imu == base || imu.is_empty() {
        return (
            matrix([0.0, 0.0, 0.0, 1.0], [0.0; 3]),
            format!("IMU frame is the base frame `{base}`: T_BS identity"),
        );
    }
    if let Some(t) = tf.iter().find(|t| t.parent == base && t.child == imu) {
        return (
            matrix(t.rotation, t.translation),
            format!("T_BS from /tf_static {base} -> {imu}"),
        );
    }
    if let Some(t) = tf.iter().find(|t| t.parent == imu && t.child == base) {
        // Inverse: R' = R^T, t' = -R^T t.
        let [x, y, z, w] = t.rotation;
        let m = matrix([-x, -y, -z, w], [0.0; 3]);
        let r = |i: usize, j: usize| f64::from(m[4 * i + j]);
        let tt: [f64; 3] =
            std::array::from_fn(|i| -(0..3).map(|j| r(i, j) * t.translation[j]).sum::<f64>());
        return (
            matrix([-x, -y, -z, w], tt),
            format!("T_BS from /tf_static {imu} -> {base}, inverted"),
        );
    }
    (
        matrix([0.0, 0.0, 0.0, 1.0], [0.0; 3]),
        format!("no static transform between `{base}` and the IMU frame `{imu}`: T_BS identity"),
    )
}

fn to_dataset(
    path: &Path,
    mut d: Decoded,
    o: &BagOptions,
    topics: [Option<String>; 3],
) -> Result<Dataset, CliError> {
    if !(o.wheel_radius.is_finite() && o.wheel_radius > 0.0 && o.track.is_finite() && o.track > 0.0)
    {
        return Err(CliError::Usage(
            "--wheel-radius and --track must be positive numbers of metres".into(),
        ));
    }
    let [imu_topic, odom_topic, gps_topic] = topics;
    let mut labels = Labels::default();
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let used: Vec<String> = [
        ("imu", &imu_topic),
        ("odometry", &odom_topic),
        ("gps", &gps_topic),
    ]
    .iter()
    .filter_map(|(k, t)| t.as_ref().map(|t| format!("{k} {t}")))
    .collect();
    labels.set("source", format!("rosbag {name}: {}", used.join(", ")));
    let mut ds = Dataset::default();
    let dropped = in_stamp_order(&mut d.imu, |m| m.header.stamp_ns)
        + in_stamp_order(&mut d.odom, |m| m.header.stamp_ns)
        + in_stamp_order(&mut d.gps, |m| m.header.stamp_ns);
    if dropped > 0 {
        labels.note(format!(
            "{dropped} messages repeating the stamp before them were dropped"
        ));
    }
    let base = d
        .odom
        .first()
        .map_or("base_link".to_string(), |m| m.child_frame_id.clone());

    if d.imu.len() >= 2 {
        let rate = median_rate_hz(d.imu.iter().map(|m| m.header.stamp_ns)).unwrap_or(1.0);
        let (t_bs, how) = imu_mount(&d.tf, &base, &d.imu[0].header.frame_id);
        labels.note(how);
        let defaults = ImuNoise::default();
        let density = |var: f64, default: f32| {
            if var.is_finite() && var > 0.0 {
                (var / rate).sqrt()
            } else {
                f64::from(default)
            }
        };
        let first = &d.imu[0];
        let given = first.angular_velocity_covariance[0] > 0.0
            && first.linear_acceleration_covariance[0] > 0.0;
        labels.note(if given {
            "IMU noise densities from the message covariances; random walks a consumer MEMS IMU's"
        } else {
            "IMU noise not in the messages: a consumer MEMS IMU's figures are written"
        });
        let meta = ImuMeta {
            t_bs,
            rate_hz: rate,
            gyroscope_noise_density: density(
                first.angular_velocity_covariance[0],
                defaults.gyro_density,
            ),
            gyroscope_random_walk: f64::from(defaults.gyro_random_walk),
            accelerometer_noise_density: density(
                first.linear_acceleration_covariance[0],
                defaults.accel_density,
            ),
            accelerometer_random_walk: f64::from(defaults.accel_random_walk),
        };
        let samples = d
            .imu
            .iter()
            .map(|m| RawImuSample {
                t: Timestamp(m.header.stamp_ns),
                gyro: m.angular_velocity.map(|v| v as f32),
                accel: m.linear_acceleration.map(|v| v as f32),
            })
            .collect();
        ds.imu = Some((meta, samples));
    } else {
        labels.note(
            "no IMU messages: the EKF does not run; the wheel-only trajectory is the estimate",
        );
    }

    if d.odom.len() >= 2 {
        let rate = median_rate_hz(d.odom.iter().map(|m| m.header.stamp_ns)).unwrap_or(1.0);
        let (r, b) = (o.wheel_radius, o.track);
        let rates = d
            .odom
            .iter()
            .map(|m| {
                let (v, w) = (m.linear[0], m.angular[2]);
                RawWheelRates {
                    t: Timestamp(m.header.stamp_ns),
                    left: ((v - 0.5 * w * b) / r) as f32,
                    right: ((v + 0.5 * w * b) / r) as f32,
                }
            })
            .collect();
        labels.note(format!(
            "wheel0 holds the odometry twist (v, w) as wheel rates with radius {r} m and track {b} m: the odometry's own wheel model, not measured wheel speeds"
        ));
        ds.wheel_rates = Some((
            WheelMeta {
                rate_hz: rate,
                ticks_per_revolution: None,
                wheel_radius_left: r,
                wheel_radius_right: r,
                wheel_base: b,
                track_factor: 1.0,
                steering: vslam_core::robot::Steering::Differential,
                wheel_type: "soft_rubber".into(),
            },
            rates,
        ));
    } else {
        labels.note("no odometry messages: no wheel0");
    }

    let fixes: Vec<&ros_msg::NavSatFix> = d
        .gps
        .iter()
        .filter(|f| {
            f.status >= 0
                && [f.latitude, f.longitude, f.altitude]
                    .iter()
                    .all(|v| v.is_finite())
        })
        .collect();
    if let Some(origin) = fixes.first() {
        let enu = Enu::at(origin.latitude, origin.longitude, origin.altitude);
        ds.groundtruth = Some(
            fixes
                .iter()
                .map(|f| GroundTruth {
                    t: Timestamp(f.header.stamp_ns),
                    p: enu.of(f.latitude, f.longitude, f.altitude),
                    q_wxyz: yaw_quaternion(0.0),
                    v: [0.0; 3],
                    bias_gyro: [0.0; 3],
                    bias_accel: [0.0; 3],
                })
                .collect(),
        );
        labels.set("reference", "gps").note(format!(
            "reference: {} GPS fixes in east-north-up metres about the first fix (position only; the estimates start at yaw 0, so align before comparing, e.g. evo_ape --align); {} without a fix left out",
            fixes.len(),
            d.gps.len() - fixes.len()
        ));
    } else {
        labels.set("reference", "none");
    }
    ds.labels = Some(labels);
    Ok(ds)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header_bytes(index_pos: u64, data_len: u32) -> Vec<u8> {
        let mut fields = Vec::new();
        for f in [
            &b"op=\x03"[..],
            &[b"index_pos=".as_slice(), &index_pos.to_le_bytes()].concat(),
        ] {
            fields.extend((f.len() as u32).to_le_bytes());
            fields.extend(f);
        }
        let mut out = MAGIC.to_vec();
        out.extend((fields.len() as u32).to_le_bytes());
        out.extend(&fields);
        out.extend(data_len.to_le_bytes());
        out.extend(vec![b' '; data_len as usize]);
        out
    }

    #[test]
    fn the_bag_header_is_checked_before_the_crate_slices_the_file() {
        let h = header_bytes(100, 10);
        assert_eq!(check_bag_header(&h, 200), Ok(()));
        assert!(check_bag_header(&h, 50).unwrap_err().contains("outside"));
        assert!(
            check_bag_header(&header_bytes(5, 10), 200)
                .unwrap_err()
                .contains("outside")
        );
        assert!(
            check_bag_header(b"#ROSBAG V1.2\n", 100)
                .unwrap_err()
                .contains("format 2.0")
        );
        assert!(check_bag_header(&h[..20], 200).is_err());
    }

    #[test]
    fn a_mounted_imu_gets_its_transform_either_way_round() {
        let q = [
            0.0,
            0.0,
            (0.25f64 * std::f64::consts::PI).sin(),
            (0.25f64 * std::f64::consts::PI).cos(),
        ];
        let tf = vec![Transform {
            parent: "base_link".into(),
            child: "imu".into(),
            translation: [0.1, 0.0, 0.2],
            rotation: q,
        }];
        let (m, how) = imu_mount(&tf, "base_link", "imu");
        assert!(how.contains("base_link -> imu"));
        // A quarter turn about z: sensor x is body y.
        assert!(
            (m[4] - 1.0).abs() < 1e-6 && (m[1] + 1.0).abs() < 1e-6 && (m[3] - 0.1).abs() < 1e-6,
            "{m:?}"
        );
        let inv = vec![Transform {
            parent: "imu".into(),
            child: "base_link".into(),
            translation: [0.0, 0.1, -0.2],
            rotation: [0.0, 0.0, -q[2], q[3]],
        }];
        let (m2, how) = imu_mount(&inv, "base_link", "imu");
        assert!(how.contains("inverted"), "{how}");
        for (a, b) in m.iter().zip(&m2) {
            assert!((a - b).abs() < 1e-6, "{m:?} vs {m2:?}");
        }
        assert!(
            imu_mount(&[], "base_link", "imu")
                .1
                .contains("no static transform")
        );
    }

    #[test]
    fn odometry_twist_becomes_wheel_rates_and_fixes_enu() {
        let o = BagOptions::default();
        let d = Decoded {
            odom: vec![
                ros_msg::decode_odometry(&ros_msg::encode::odometry(
                    2_000_000_000,
                    "base_link",
                    1.0,
                    0.5,
                ))
                .unwrap(),
                ros_msg::decode_odometry(&ros_msg::encode::odometry(
                    1_000_000_000,
                    "base_link",
                    1.0,
                    0.5,
                ))
                .unwrap(),
                ros_msg::decode_odometry(&ros_msg::encode::odometry(
                    1_000_000_000,
                    "base_link",
                    9.0,
                    0.5,
                ))
                .unwrap(),
            ],
            gps: vec![
                ros_msg::decode_navsatfix(&ros_msg::encode::navsatfix(
                    1_000_000_000,
                    46.78,
                    -71.27,
                    80.0,
                ))
                .unwrap(),
                ros_msg::decode_navsatfix(&ros_msg::encode::navsatfix(
                    2_000_000_000,
                    46.78 + 1.0 / 3600.0,
                    -71.27,
                    80.0,
                ))
                .unwrap(),
            ],
            ..Decoded::default()
        };
        let ds = to_dataset(
            Path::new("x.bag"),
            d,
            &o,
            [None, Some("/odom".into()), Some("/fix".into())],
        )
        .unwrap();
        let (_, rates) = ds.wheel_rates.unwrap();
        assert_eq!(rates.len(), 2, "the repeated stamp is dropped");
        assert_eq!(rates[0].t, Timestamp(1_000_000_000));
        let (v, w) = (
            0.5 * f64::from(rates[0].left + rates[0].right) * o.wheel_radius,
            f64::from(rates[0].right - rates[0].left) * o.wheel_radius / o.track,
        );
        assert!((v - 1.0).abs() < 1e-6 && (w - 0.5).abs() < 1e-6, "{v} {w}");
        let gt = ds.groundtruth.unwrap();
        assert!((gt[1].p[1] - 30.88).abs() < 0.05, "{:?}", gt[1].p);
        let labels = ds.labels.unwrap();
        assert_eq!(labels.get("reference"), Some("gps"));
        assert!(
            labels
                .notes
                .iter()
                .any(|n| n.contains("1 messages repeating")),
            "{labels:?}"
        );
    }
}
