//! The importers' CSV parsers (`host_sim::import`): OptiOdom run files and
//! metadata files, BorealTC IMU and wheel-speed files. The first byte picks
//! the parser, the rest is the file's text. A parse either gives what the
//! format promises (finite values, strictly increasing time stamps,
//! positive geometry) or an exit-2 error naming the file.
#![no_main]

use host_sim::import::{borealtc, optiodom};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fn increasing(ts: impl Iterator<Item = u64>) -> bool {
    let v: Vec<u64> = ts.collect();
    v.windows(2).all(|w| w[0] < w[1])
}

fn refused(e: host_sim::CliError, file: &str) {
    assert_eq!(e.exit_code(), 2);
    assert!(e.to_string().starts_with(file), "error does not name the file: {e}");
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else {
        return;
    };
    let text = String::from_utf8_lossy(rest);
    match which % 4 {
        0 => match optiodom::parse_run(Path::new("run.csv"), &text) {
            Ok(rows) => {
                assert!(rows.len() >= 2 && increasing(rows.iter().map(|r| r.t.0)));
                assert!(rows.iter().all(|r| r.pose.iter().all(|v| v.is_finite())));
                let meta = optiodom::OptiOdomMeta {
                    ngear: 43.7,
                    enc_res: 64.0,
                    track: 0.2,
                    diameter_right: 0.084,
                    diameter_left: 0.084,
                };
                match optiodom::to_dataset(Path::new("run.csv"), &meta, &rows) {
                    Ok(ds) => assert!(ds.wheel.is_some_and(|(_, w)| w.len() == rows.len())),
                    Err(e) => refused(e, "run.csv:"),
                }
            }
            Err(e) => refused(e, "run.csv"),
        },
        1 => match optiodom::parse_metadata(Path::new("meta.csv"), &text) {
            Ok(m) => {
                let all = [m.ngear, m.enc_res, m.track, m.diameter_left, m.diameter_right];
                assert!(all.iter().all(|v| v.is_finite() && *v > 0.0));
            }
            Err(e) => refused(e, "meta.csv"),
        },
        2 => match borealtc::parse_imu(Path::new("imu.csv"), &text) {
            Ok(v) => {
                assert!(v.len() >= 2 && increasing(v.iter().map(|s| s.t.0)));
                assert!(v.iter().all(|s| s.gyro.iter().chain(&s.accel).all(|x| !x.is_nan())));
            }
            Err(e) => refused(e, "imu.csv"),
        },
        _ => match borealtc::parse_pro(Path::new("pro.csv"), &text) {
            Ok(rows) => {
                assert!(rows.len() >= 2 && increasing(rows.iter().map(|r| r.t.0)));
                assert!(rows.iter().all(|r| r.values.len() == 2));
                let ds = borealtc::to_dataset(
                    Path::new("imu.csv"),
                    Vec::new(),
                    Path::new("pro.csv"),
                    &rows,
                    "T",
                    borealtc::HuskyGeometry::default(),
                );
                // No IMU samples: refused for the IMU file, never a panic.
                if let Err(e) = ds {
                    refused(e, "imu.csv");
                }
            }
            Err(e) => refused(e, "pro.csv"),
        },
    }
});
