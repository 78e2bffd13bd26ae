//! `host-sim import rosbag` on the committed bag (`data/real/rl/test2.bag`,
//! robot_localization's test bag, BSD-3-Clause; bz2 chunks), then `replay`.
//! Figures checked against the data's README: message counts, the stamp
//! grids, the mean vertical specific force, the odometry's path length.

mod common;
use common::host_sim;

use std::path::{Path, PathBuf};

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-import-rb", name)
}

fn bag() -> PathBuf {
    common::repo_data("real/rl/test2.bag")
}

fn rows(path: &Path) -> Vec<Vec<f64>> {
    common::csv_rows(path)
}

fn import(bag: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    host_sim()
        .args(["import", "rosbag"])
        .arg(bag)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn the_bag_imports_and_replays() {
    let d = tmp("ok");
    let imp = import(&bag(), &d.join("ds"), &[]);
    common::assert_ok(&imp);
    let imu = rows(&d.join("ds/mav0/imu0/data.csv"));
    let wheel = rows(&d.join("ds/mav0/wheel0/data.csv"));
    assert_eq!((imu.len(), wheel.len()), (3061, 3060));
    // Header stamps: IMU on a 20 ms grid from 47.58 s, odometry 4 ms after.
    assert_eq!(imu[0][0], 47_580_000_000.0);
    assert_eq!(wheel[0][0], 47_584_000_000.0);
    assert!(imu.windows(2).all(|w| w[1][0] - w[0][0] == 20_000_000.0));
    let mean_az = imu.iter().map(|r| r[6]).sum::<f64>() / imu.len() as f64;
    assert!((mean_az - 9.75).abs() < 0.01, "mean az {mean_az}");
    // The odometry's path length, 84 m, from the wheel rates' mean rim speed.
    let r = 0.098;
    let path: f64 = wheel
        .windows(2)
        .map(|w| 0.5 * r * (w[1][1] + w[1][2]).abs() * (w[1][0] - w[0][0]) * 1e-9)
        .sum();
    assert!((path - 84.0).abs() < 1.0, "path {path} m");
    let yaml = std::fs::read_to_string(d.join("ds/mav0/wheel0/sensor.yaml")).unwrap();
    assert!(yaml.contains("wheel_radius_left: 0.098") && yaml.contains("wheel_base: 0.37559"));
    let labels = std::fs::read_to_string(d.join("ds/labels.yaml")).unwrap();
    assert!(
        labels.contains("T_BS identity") && labels.contains("reference: \"none\""),
        "{labels}"
    );

    common::replay(&d.join("ds"), &d.join("out"), &[]);
    let report = common::report(&d.join("out"));
    assert_eq!(report["counts"]["imu"]["seen"], 3061);
    assert_eq!(report["counts"]["wheel"]["seen"], 3060);
}

#[test]
fn bad_bags_and_topics_exit_2() {
    let d = tmp("bad");
    let bytes = std::fs::read(bag()).unwrap();
    let cut = d.join("cut.bag");
    std::fs::write(&cut, &bytes[..100_000]).unwrap();
    let out = import(&cut, &d.join("a"), &[]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cut.bag") && err.contains("index_pos"),
        "{err}"
    );

    let text = d.join("text.bag");
    std::fs::write(&text, "time,a\n0,1\n").unwrap();
    let out = import(&text, &d.join("b"), &[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("format 2.0"));

    let out = import(&bag(), &d.join("c"), &["--imu-topic", "/nope"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no topic `/nope`"));
    let out = import(
        &bag(),
        &d.join("c"),
        &["--imu-topic", "/jackal_velocity_controller/odom"],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not sensor_msgs/Imu"));
    assert!(!d.join("c").exists());
}

/// A minimal uncompressed bag (format 2.0): one chunk with the connection
/// and message records, the connections again in the index section.
/// `topics` are `(topic, type)`, `messages` are `(connection, stamp, bytes)`.
fn write_bag(path: &Path, topics: &[(&str, &str)], messages: &[(u32, u64, Vec<u8>)]) {
    fn field(name: &str, val: &[u8]) -> Vec<u8> {
        let f = [name.as_bytes(), b"=", val].concat();
        [(f.len() as u32).to_le_bytes().to_vec(), f].concat()
    }
    fn record(fields: &[Vec<u8>], data: &[u8]) -> Vec<u8> {
        let h = fields.concat();
        [
            (h.len() as u32).to_le_bytes().to_vec(),
            h,
            (data.len() as u32).to_le_bytes().to_vec(),
            data.to_vec(),
        ]
        .concat()
    }
    let conns: Vec<u8> = topics
        .iter()
        .enumerate()
        .flat_map(|(i, (topic, tp))| {
            let data = [
                field("topic", topic.as_bytes()),
                field("type", tp.as_bytes()),
                field("md5sum", &[b'0'; 32]),
                field("message_definition", b""),
            ]
            .concat();
            record(
                &[
                    field("op", &[7]),
                    field("conn", &(i as u32).to_le_bytes()),
                    field("topic", topic.as_bytes()),
                ],
                &data,
            )
        })
        .collect();
    let mut body = conns.clone();
    for (c, t, bytes) in messages {
        let time = [
            ((t / 1_000_000_000) as u32).to_le_bytes(),
            ((t % 1_000_000_000) as u32).to_le_bytes(),
        ]
        .concat();
        body.extend(record(
            &[
                field("op", &[2]),
                field("conn", &c.to_le_bytes()),
                field("time", &time),
            ],
            bytes,
        ));
    }
    let chunk = record(
        &[
            field("op", &[5]),
            field("compression", b"none"),
            field("size", &(body.len() as u32).to_le_bytes()),
        ],
        &body,
    );
    let header = |index_pos: u64| {
        record(
            &[
                field("op", &[3]),
                field("index_pos", &index_pos.to_le_bytes()),
                field("conn_count", &(topics.len() as u32).to_le_bytes()),
                field("chunk_count", &1u32.to_le_bytes()),
            ],
            b"    ",
        )
    };
    let magic = b"#ROSBAG V2.0\n";
    let index_pos = (magic.len() + header(0).len() + chunk.len()) as u64;
    std::fs::write(
        path,
        [magic.to_vec(), header(index_pos), chunk, conns].concat(),
    )
    .unwrap();
}

#[test]
fn gps_fixes_become_an_enu_reference_and_tf_static_mounts_the_imu() {
    use host_sim::import::ros_msg::encode;
    let d = tmp("gps");
    let half = std::f64::consts::FRAC_1_SQRT_2;
    let mut messages = vec![(
        3,
        1_000_000_000,
        encode::tf(
            "base_link",
            "imu_link",
            [0.1, 0.0, 0.2],
            [0.0, 0.0, half, half],
        ),
    )];
    for k in 0..20u64 {
        let t = 1_000_000_000 + k * 10_000_000;
        messages.push((
            0,
            t,
            encode::imu(t, "imu_link", [0.0; 3], [0.0, 0.0, 9.81], 1e-6),
        ));
        messages.push((
            1,
            t + 2_000_000,
            encode::odometry(t + 2_000_000, "base_link", 0.5, 0.0),
        ));
        // North at 0.5 m/s: 1e-3 deg of latitude is about 111 m.
        let lat = 46.78 + 0.5 * (k as f64 * 0.01) / 111_000.0;
        messages.push((2, t, encode::navsatfix(t, lat, -71.27, 80.0)));
    }
    let bag = d.join("synthetic.bag");
    write_bag(
        &bag,
        &[
            ("/imu", "sensor_msgs/Imu"),
            ("/odom", "nav_msgs/Odometry"),
            ("/fix", "sensor_msgs/NavSatFix"),
            ("/tf_static", "tf2_msgs/TFMessage"),
        ],
        &messages,
    );
    let out = import(&bag, &d.join("ds"), &[]);
    common::assert_ok(&out);
    let yaml = std::fs::read_to_string(d.join("ds/mav0/imu0/sensor.yaml")).unwrap();
    // A quarter turn about z and the lever arm: row 1 is [0, -1, 0, 0.1].
    assert!(
        yaml.contains("0.000000000, -1.000000000, 0.000000000, 0.100000001,"),
        "{yaml}"
    );
    let gt = rows(&d.join("ds/mav0/state_groundtruth_estimate0/data.csv"));
    assert_eq!(gt.len(), 20);
    let north = gt[19][2];
    assert!(
        (north - 0.095).abs() < 0.002 && gt[19][1].abs() < 1e-6,
        "{:?}",
        gt[19]
    );
    let labels = std::fs::read_to_string(d.join("ds/labels.yaml")).unwrap();
    assert!(
        labels.contains("reference: \"gps\"")
            && labels.contains("/tf_static base_link -> imu_link"),
        "{labels}"
    );
}
