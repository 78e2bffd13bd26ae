//! The IMUs robots carry: a simulated log (the `short` scenario, 10 s, seed
//! 1, without the camera) replayed with its 250 Hz IMU resampled to 100 Hz
//! and 30 Hz (the mean of each interval, stamped at its end, as an IMU's
//! own filter would), and with the IMU mounted turned 90 degrees about
//! x (`T_BS` says so, the samples are in the turned frame).

mod common;

use host_sim::asl::{Dataset, write_dataset};
use host_sim::replay::{ReplayOutput, imu_rate_hz, run_replay};
use host_sim::sim::scenario::{Scenario, generate};
use std::path::Path;
use traction::vslam_core::Timestamp;
use traction::vslam_core::sensors::RawImuSample;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("traction-imuv", name)
}

fn simulated(root: &Path) -> Dataset {
    let mut sc = Scenario::by_name("short").unwrap();
    sc.script.duration = 10.0;
    let (mut ds, _) = generate(&sc, 1, &root.join("gen")).unwrap();
    ds.cam = None;
    ds.seg = None;
    ds
}

fn replay(root: &Path, name: &str, ds: &Dataset) -> ReplayOutput {
    let d = root.join(name);
    write_dataset(&d, ds).unwrap();
    run_replay(&d, &d.join("out"), false).unwrap()
}

fn ekf_ate(r: &ReplayOutput) -> f64 {
    r.errors
        .iter()
        .find(|(n, _)| *n == "ekf")
        .unwrap()
        .1
        .ate_rmse
}

/// The samples averaged over intervals of `1 / hz` s, each stamped at the
/// interval's end.
fn resample(v: &[RawImuSample], hz: f64) -> Vec<RawImuSample> {
    let mut out: Vec<RawImuSample> = Vec::new();
    let mut bin: Vec<&RawImuSample> = Vec::new();
    let index = |s: &RawImuSample| (s.t.0 as f64 * 1e-9 * hz).floor() as u64;
    for s in v {
        if let Some(k) = bin.last().map(|b| index(b)).filter(|&k| k != index(s)) {
            let mut m = mean(&bin);
            m.t = Timestamp(((k + 1) as f64 * 1e9 / hz).round() as u64);
            out.push(m);
            bin.clear();
        }
        bin.push(s);
    }
    out
}

fn mean(bin: &[&RawImuSample]) -> RawImuSample {
    let n = bin.len() as f32;
    let mut m = RawImuSample {
        t: bin.last().unwrap().t,
        gyro: [0.0; 3],
        accel: [0.0; 3],
    };
    for s in bin {
        for i in 0..3 {
            m.gyro[i] += s.gyro[i] / n;
            m.accel[i] += s.accel[i] / n;
        }
    }
    m
}

#[test]
fn imu_at_30_and_100_hz_runs_the_ekf() {
    let root = tmp("rate");
    let ds = simulated(&root);
    let base = replay(&root, "250", &ds);
    println!("250 Hz: EKF ATE {:.4} m", ekf_ate(&base));
    for hz in [100.0, 30.0] {
        let mut d = ds.clone();
        let (meta, v) = d.imu.as_mut().unwrap();
        *v = resample(v, hz);
        meta.rate_hz = hz;
        let measured = imu_rate_hz(&d).unwrap();
        assert!((measured as f64 - hz).abs() < 0.05 * hz, "{measured} Hz");
        let r = replay(&root, &format!("{hz}"), &d);
        let imu = &r.report["counts"]["imu"];
        let poses = r.ekf.len();
        let samples = d.imu.as_ref().unwrap().1.len();
        println!(
            "{hz} Hz: {samples} samples, {poses} EKF poses, ATE {:.4} m, imu counts {imu}",
            ekf_ate(&r)
        );
        assert!(
            imu["rejected"]["gap"].is_null(),
            "{hz} Hz: steps rejected as gaps: {imu}"
        );
        assert!(poses > samples * 8 / 10, "{hz} Hz: {poses} poses");
        assert!(
            ekf_ate(&r) < 3.0 * ekf_ate(&base) + 0.05,
            "{hz} Hz: ATE {} m against {} m at 250 Hz",
            ekf_ate(&r),
            ekf_ate(&base)
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn imu_mounted_turned_90_degrees_about_x_is_honoured() {
    let root = tmp("turned");
    let ds = simulated(&root);
    let base = replay(&root, "upright", &ds);
    let mut d = ds.clone();
    let (meta, v) = d.imu.as_mut().unwrap();
    // R_BS' = R_BS Rx(90 deg); a vector in the turned frame S' is
    // Rx^T v_S: (x, y, z) -> (x, z, -y).
    let r = meta.t_bs;
    let m = |i: usize, j: usize| r[4 * i + j];
    for i in 0..3 {
        // Columns of R_BS Rx: (c0, c2, -c1).
        meta.t_bs[4 * i + 1] = m(i, 2);
        meta.t_bs[4 * i + 2] = -m(i, 1);
    }
    for s in v.iter_mut() {
        let turn = |a: [f32; 3]| [a[0], a[2], -a[1]];
        s.gyro = turn(s.gyro);
        s.accel = turn(s.accel);
    }
    let turned = replay(&root, "turned", &d);
    let first = turned.ekf.first().expect("the EKF started");
    let [x, y, z, w] = first.q_xyzw;
    // Roll and pitch of the first pose of B.
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    println!(
        "first attitude: roll {:.3} deg, pitch {:.3} deg; ATE upright {:.4} m, turned {:.4} m",
        roll.to_degrees(),
        pitch.to_degrees(),
        ekf_ate(&base),
        ekf_ate(&turned)
    );
    assert!(roll.abs().to_degrees() < 1.0 && pitch.abs().to_degrees() < 1.0);
    assert!(
        (ekf_ate(&turned) - ekf_ate(&base)).abs() < 0.01,
        "ATE turned {} m, upright {} m",
        ekf_ate(&turned),
        ekf_ate(&base)
    );
    let _ = std::fs::remove_dir_all(&root);
}
