//! The README's "Real data" commands on the committed excerpts
//! (`data/real/optiodom`: the first 20 s of an OptiOdom square run, MIT;
//! `data/real/borealtc/SNOW` and `ICE`: the first 10 s of a BorealTC snow
//! sequence and the first 20 s of an ice one, CC0), pinned to the values
//! they measured: `calibrate`, `replay --wheels`, `terrain-stats`, report.json
//! `aids` and the skid steer's learned track factor.

mod common;
use common::host_sim;

use std::path::{Path, PathBuf};
use std::process::Output;

fn tmp(name: &str) -> common::Scratch {
    common::scratch("host-sim-real", name)
}

fn real(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/real")
        .join(p)
}

fn ok(o: Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// Dead reckoning by the midpoint rule from the run file (right ticks
/// first) with the given radii and track: the end pose.
fn dead_reckoning(run: &str, r_left: f64, r_right: f64, track: f64) -> (f64, f64) {
    let per_rev = 43.7 * 64.0;
    let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
    for line in run.lines() {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        let dr = f[4] * std::f64::consts::TAU / per_rev * r_right;
        let dl = f[5] * std::f64::consts::TAU / per_rev * r_left;
        let (ds, dth) = (0.5 * (dr + dl), (dr - dl) / track);
        x += ds * (th + 0.5 * dth).cos();
        y += ds * (th + 0.5 * dth).sin();
        th += dth;
    }
    (x, y)
}

#[test]
fn calibrate_on_the_optiodom_excerpt_and_replay_with_it() {
    let d = tmp("calib");
    let run = real("optiodom/231220200029_run-01.csv");
    ok(host_sim()
        .args(["import", "optiodom"])
        .arg(&run)
        .arg("--out")
        .arg(d.join("ds"))
        .output()
        .unwrap());
    let text = ok(host_sim()
        .arg("calibrate")
        .arg(d.join("ds"))
        .arg("--out")
        .arg(d.join("wheels.yaml"))
        .output()
        .unwrap());
    assert!(text.contains("calibration over 20 windows"), "{text}");
    assert!(text.contains("radius left       0.042000"), "{text}");
    // Measured: 0.041967, 0.041955, 0.201700 m.
    let y = std::fs::read_to_string(d.join("wheels.yaml")).unwrap();
    let key = |k: &str| -> f64 {
        y.lines()
            .find_map(|l| l.strip_prefix(&format!("{k}: ")))
            .unwrap()
            .parse()
            .unwrap()
    };
    let (rl, rr, b) = (
        key("wheel_radius_left"),
        key("wheel_radius_right"),
        key("wheel_base"),
    );
    assert!((rl - 0.041967).abs() < 5e-6, "{y}");
    assert!((rr - 0.041955).abs() < 5e-6, "{y}");
    assert!((b - 0.201700).abs() < 5e-5, "{y}");

    // replay --wheels drives with them: the wheel-only end pose is the
    // midpoint rule's with the calibrated geometry, not the nominal one.
    ok(host_sim()
        .arg("replay")
        .arg(d.join("ds"))
        .arg("--wheels")
        .arg(d.join("wheels.yaml"))
        .arg("--out")
        .arg(d.join("out"))
        .output()
        .unwrap());
    let run_text = std::fs::read_to_string(&run).unwrap();
    let (x, yy) = dead_reckoning(&run_text, rl, rr, b);
    let (xn, yn) = dead_reckoning(&run_text, 0.042, 0.042, 0.2);
    let tum = std::fs::read_to_string(d.join("out/wheel_only.tum")).unwrap();
    let last: Vec<f64> = tum
        .lines()
        .last()
        .unwrap()
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    let err = (last[1] - x).hypot(last[2] - yy);
    let err_nominal = (last[1] - xn).hypot(last[2] - yn);
    assert!(
        err < 1e-3 && err_nominal > 5.0 * err,
        "{last:?}: {err} from calibrated, {err_nominal} from nominal"
    );
    // Against OptiTrack (measured: ATE 0.0123 m, final 0.0135 m; with the
    // nominal geometry 0.0112 m and 0.0122 m: a calibration on 20 s of one
    // side and one corner is no better on those same 20 s).
    let e = &json(&d.join("out/report.json"))["errors"]["wheel_only"];
    let (ate, fin) = (
        e["ate_rmse_m"].as_f64().unwrap(),
        e["final_error_m"].as_f64().unwrap(),
    );
    assert!((ate - 0.0123).abs() < 0.0005, "ATE {ate}");
    assert!((fin - 0.0135).abs() < 0.0005, "final {fin}");
}

#[test]
fn calibrate_refuses_a_dataset_without_ground_truth() {
    let d = tmp("nogt");
    ok(host_sim()
        .args(["import", "borealtc"])
        .arg(real("borealtc/SNOW/imu_10.csv"))
        .arg(real("borealtc/SNOW/pro_10.csv"))
        .arg("--out")
        .arg(d.join("ds"))
        .output()
        .unwrap());
    let o = host_sim()
        .arg("calibrate")
        .arg(d.join("ds"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no ground truth"), "{err}");
}

#[test]
fn terrain_stats_and_aids_on_the_borealtc_excerpt() {
    let d = tmp("terrain");
    ok(host_sim()
        .args(["import", "borealtc"])
        .arg(real("borealtc/SNOW/imu_10.csv"))
        .arg(real("borealtc/SNOW/pro_10.csv"))
        .arg("--out")
        .arg(d.join("SNOW_10"))
        .output()
        .unwrap());
    let text = ok(host_sim()
        .arg("terrain-stats")
        .arg(d.join("SNOW_10"))
        .arg("--json")
        .arg(d.join("t.json"))
        .output()
        .unwrap());
    assert!(text.contains("| SNOW | SNOW_10 | 10.0 |"), "{text}");
    let l = &json(&d.join("t.json"))[0];
    assert_eq!(l["terrain"], "SNOW");
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    // Measured: yaw-rate residual RMS 0.2479 rad/s, gain 0.03 (the wheels
    // command turns, the body barely turns).
    let y = &l["yaw_residual"];
    assert!((num(&y["rms"]) - 0.2479).abs() < 0.002, "{y}");
    assert!(num(&y["gain"]).abs() < 0.1, "{y}");
    // The wheels' forward rows: measured mean NIS 2.38 (774 with the
    // accelerometer's sensor noise alone in the propagation and no reset of
    // a filter overrunning the wheels: its velocity ran away on the shaking
    // IMU; 0.77 when a failed differential row also dropped the forward
    // row, whose variance then grew), 67.2 % of the samples gated (the
    // differential rows: the wheels turn, the body hardly does; their
    // forward rows are fused); the forward noise learner settles at its
    // upper bound (4x the filter's 0.014 m/s: the wheels slip on snow).
    let w = &l["aids"]["wheel"];
    let fwd = &w["components"][0];
    assert_eq!(fwd["name"], "forward");
    assert!((num(&fwd["nis_mean"]) - 2.38).abs() < 0.15, "{fwd}");
    assert!((num(&w["gated_fraction"]) - 0.672).abs() < 0.03, "{w}");
    let n = &l["forward_noise"];
    assert!((num(&n["multiplier"]) - 4.0).abs() < 1e-9, "{n}");
    assert!((num(&n["filter_std"]) - 0.014).abs() < 0.001, "{n}");
    // What the filter learned: radii near the nominal 0.13 m; the skid
    // steer's track factor (measured 2.103, std 0.382, 56 updates: the
    // wheels turn, the body hardly does) above the nominal 1.80.
    for r in l["learned"]["wheel_radii"].as_array().unwrap() {
        assert!((num(r) - 0.13).abs() < 0.002, "{r}");
    }
    let chi = &l["learned"]["track_factor"];
    assert!((num(&chi["chi"]) - 2.103).abs() < 0.01, "{chi}");
    assert!((num(&chi["chi_std"]) - 0.382).abs() < 0.01, "{chi}");

    // report.json of a plain replay carries the same aid statistics.
    ok(host_sim()
        .arg("replay")
        .arg(d.join("SNOW_10"))
        .arg("--out")
        .arg(d.join("out"))
        .output()
        .unwrap());
    let aids = &json(&d.join("out/report.json"))["aids"];
    assert_eq!(aids["wheel"], *w);
    assert_eq!(aids["zupt"]["nis_dof"], 9);
    let records = aids["wheel"]["records"].as_u64().unwrap();
    let fused = aids["wheel"]["fused"].as_u64().unwrap();
    let gated = aids["wheel"]["gated"].as_u64().unwrap();
    let rejected = aids["wheel"]["rejected"].as_u64().unwrap();
    assert_eq!(records, fused + gated + rejected, "{aids}");
    assert!(
        records >= 60,
        "65 wheel rows, the first few before the filter runs"
    );
}

/// The ice excerpt (the Husky turning in place): described as a skid steer,
/// the filter learns the track factor (measured 1.394, std 0.096, from 125
/// wheel samples) and the gyroscope's z bias stays a gyro's (measured 1.7
/// mrad/s); described as a differential drive with the same nominal
/// effective track, the bias takes up the skid (measured 38.0 mrad/s).
#[test]
fn the_skid_steer_learns_its_track_on_the_ice_excerpt() {
    let d = tmp("ice");
    ok(host_sim()
        .args(["import", "borealtc"])
        .arg(real("borealtc/ICE/imu_06.csv"))
        .arg(real("borealtc/ICE/pro_06.csv"))
        .arg("--out")
        .arg(d.join("skid/ICE_06"))
        .output()
        .unwrap());
    let yaml = d.join("skid/ICE_06/mav0/wheel0/sensor.yaml");
    let text = std::fs::read_to_string(&yaml).unwrap();
    assert!(text.contains("steering: skid"), "{text}");
    // The same log described as a differential drive.
    let plain = d.join("differential/ICE_06");
    std::fs::create_dir_all(plain.join("mav0/wheel0")).unwrap();
    for f in [
        "labels.yaml",
        "mav0/imu0/data.csv",
        "mav0/imu0/sensor.yaml",
        "mav0/wheel0/data.csv",
    ] {
        let to = plain.join(f);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(d.join("skid/ICE_06").join(f), to).unwrap();
    }
    std::fs::write(
        plain.join("mav0/wheel0/sensor.yaml"),
        text.replace("steering: skid\n", ""),
    )
    .unwrap();
    let stats = |ds: &Path, name: &str| {
        ok(host_sim()
            .arg("terrain-stats")
            .arg(ds)
            .arg("--json")
            .arg(d.join(name))
            .output()
            .unwrap());
        json(&d.join(name))[0].clone()
    };
    let num = |v: &serde_json::Value| v.as_f64().unwrap();
    let skid = stats(&d.join("skid/ICE_06"), "skid.json");
    let chi = &skid["learned"]["track_factor"];
    assert!((num(&chi["chi"]) - 1.394).abs() < 0.01, "{chi}");
    assert!((num(&chi["chi_std"]) - 0.096).abs() < 0.005, "{chi}");
    assert_eq!(chi["updates"], 125, "{chi}");
    let bias_z = |l: &serde_json::Value| num(&l["learned"]["gyro_bias"][2]);
    assert!((bias_z(&skid) - 0.0017).abs() < 0.001, "{skid}");
    assert_eq!(skid["aids"]["wheel"]["gated"], 0, "{skid}");

    let diff = stats(&plain, "differential.json");
    assert!(diff["learned"]["track_factor"].is_null(), "{diff}");
    assert!((bias_z(&diff) - 0.0380).abs() < 0.001, "{diff}");
}

/// The IMU plausibility check (`ego_ekf::plausibility`, on in every replay)
/// refuses no reading of the BorealTC excerpts: their largest rate change
/// between two 100 Hz readings (0.30 rad/s on snow, 0.06 on ice) is well
/// within the 1.0 rad/s it allows, their largest yaw-rate change (about
/// the IMU's z axis, the vertical of a level robot: 0.12 rad/s on snow,
/// 0.04 on ice) within the 0.3 rad/s it allows about the vertical, and no
/// reading repeats.
#[test]
fn the_imu_plausibility_check_refuses_no_real_reading() {
    for (terrain, run) in [("SNOW", "10"), ("ICE", "06")] {
        let imu = real(&format!("borealtc/{terrain}/imu_{run}.csv"));
        let rows: Vec<Vec<f64>> = std::fs::read_to_string(&imu)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        let largest = rows
            .windows(2)
            .map(|w| {
                (1..4)
                    .map(|i| (w[1][i] - w[0][i]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0f64, f64::max);
        assert!(largest < 0.5, "{terrain}: {largest}");
        let largest_yaw = rows
            .windows(2)
            .map(|w| (w[1][3] - w[0][3]).abs())
            .fold(0.0f64, f64::max);
        assert!(largest_yaw < 0.15, "{terrain}: {largest_yaw}");
        let d = tmp(&format!("plausible-{terrain}"));
        ok(host_sim()
            .args(["import", "borealtc"])
            .arg(&imu)
            .arg(real(&format!("borealtc/{terrain}/pro_{run}.csv")))
            .arg("--out")
            .arg(d.join("ds"))
            .output()
            .unwrap());
        ok(host_sim()
            .arg("replay")
            .arg(d.join("ds"))
            .arg("--out")
            .arg(d.join("out"))
            .output()
            .unwrap());
        let imu_counts = &json(&d.join("out/report.json"))["counts"]["imu"];
        let rejected = &imu_counts["rejected"];
        for reason in ["out_of_range", "low_quality"] {
            assert!(
                rejected[reason].as_u64().unwrap_or(0) == 0,
                "{terrain}: {imu_counts}"
            );
        }
        assert!(imu_counts["fused"].as_u64().unwrap() as usize + 60 > rows.len());
    }
}
