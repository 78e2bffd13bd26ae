//! ROS 1 bag import (`host_sim::import::rosbag`): the first byte picks a
//! message decoder (`sensor_msgs/Imu`, `nav_msgs/Odometry`,
//! `sensor_msgs/NavSatFix`, `tf2_msgs/TFMessage`, hand-written, bounds
//! checked) or the whole importer on the rest as a `.bag` file (the bag
//! header check, then the `rosbag` crate, bz2/lz4 chunks included). Either
//! a value or an error; a whole-file error is exit 2 naming the file.
#![no_main]

use host_sim::import::{ros_msg, rosbag};
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;
use traction_fuzz::scratch_dir;

fn bag_path() -> &'static PathBuf {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| scratch_dir("rosbag").join("fuzz.bag"))
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    match which % 5 {
        0 => {
            if let Ok(m) = ros_msg::decode_imu(rest) {
                assert!(m.header.frame_id.len() < rest.len());
            }
        }
        1 => {
            let _ = ros_msg::decode_odometry(rest);
        }
        2 => {
            let _ = ros_msg::decode_navsatfix(rest);
        }
        3 => {
            if let Ok(v) = ros_msg::decode_tf(rest) {
                assert!(v.len() * 76 <= rest.len());
            }
        }
        _ => {
            std::fs::write(bag_path(), rest).unwrap();
            match rosbag::read(bag_path(), &rosbag::BagOptions::default()) {
                Ok(ds) => assert!(ds.labels.is_some()),
                Err(e) => {
                    assert_eq!(e.exit_code(), 2);
                    let msg = e.to_string();
                    assert!(msg.contains("fuzz.bag") || msg.contains("topic"), "{msg}");
                }
            }
        }
    }
});
