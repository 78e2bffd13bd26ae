//! The camera in the filter (`ego_ekf::camera`): frame pairs against the
//! pose clone hold the heading of a gyro-biased filter, an outlier pair is
//! gated and counted, the covariance stays positive definite, a still
//! robot's frames are skipped, and a frame between IMU samples is measured
//! at its own time. (The Jacobians: `tests/jacobians.rs`.)

mod support;

use ego_ekf::covariance::is_positive_definite;
use ego_ekf::state::{Quat, Vec3};
use ego_ekf::{CameraConfig, EgoEkf, ExplicitStart, FilterConfig};
use support::{Sim, SimNoise, SimRobot, Truth};
use vslam_core::Reject;
use vslam_core::Timestamp;
use vslam_core::geometry::Rot3;
use vslam_core::scale::CameraMotion;
use vslam_core::sensors::ImuSample;

const G: f32 = ego_ekf::state::STANDARD_GRAVITY;
const DT_NS: u64 = 4_000_000;
/// Ceiling distance: the unit of the camera's `t/d`, m.
const D: f32 = 2.4;

/// A camera turned and offset from the IMU (so the mounting matters).
fn camera() -> CameraConfig {
    CameraConfig {
        q_ic: Quat::from_euler_angles(0.1, -0.05, 1.2),
        t_ic: Vec3::new(0.05, -0.02, 0.08),
        ..CameraConfig::default()
    }
}

fn config(with_camera: bool) -> FilterConfig {
    FilterConfig {
        camera: with_camera.then(camera),
        ..FilterConfig::default()
    }
}

/// The camera's motion from `a` to `b` (true IMU poses) through the
/// mounting: `T_C0C1 = T_IC^-1 T_I0I1 T_IC`, the rotation disturbed by
/// `noise` (rotation vector, camera frame), the translation divided by `D`.
fn camera_motion(a: &Truth, b: &Truth, c: &CameraConfig, noise: Vec3) -> CameraMotion {
    let q_rel = a.q_wb.inverse() * b.q_wb;
    let t_rel = a.q_wb.inverse() * (b.p_wb - a.p_wb);
    // T_IC^-1 T_rel T_IC: rotation R_IC^T R R_IC, translation
    // R_IC^T (R t_IC + t - t_IC).
    let q_c = c.q_ic.inverse() * q_rel * c.q_ic;
    let t_c = c.q_ic.inverse() * (q_rel * c.t_ic + t_rel - c.t_ic);
    let q_c = q_c * Quat::from_scaled_axis(noise);
    CameraMotion::new(a.t, b.t, Rot3::from(q_c), t_c / D, 200, 0.9, 0.3).unwrap()
}

struct Drive {
    /// RMS yaw error over the drive, rad.
    yaw_rms: f32,
    filter: EgoEkf,
    /// Whether the covariance was positive definite after every frame.
    always_pd: bool,
}

/// Two minutes of driving (one stop at the start, so no zero-velocity
/// update learns the bias) with a gyro bias the filter does not know
/// (0.3 deg/s on z); with `camera`, frame pairs at 10 Hz with metric
/// scale (`translation`) or without. `outlier_at`: the frame whose rotation
/// is off by 10 degrees.
fn drive(camera_on: bool, translation: bool, outlier_at: Option<u32>) -> Drive {
    let c = config(camera_on);
    let cam = camera();
    let r = &c.robot;
    let robot = SimRobot {
        p_bl: r.p_bl,
        p_br: r.p_br,
        q_rb: r.q_rb,
        radius_left: r.radius as f64,
        radius_right: r.radius as f64,
    };
    let noise = SimNoise {
        accel_density: c.imu.noise.accel_density as f64,
        gyro_density: c.imu.noise.gyro_density as f64,
        accel_bias: Vec3::new(0.02, -0.03, 0.05),
        gyro_bias: Vec3::new(0.001, -0.001, 0.005),
        accel_random_walk: c.imu.noise.accel_random_walk as f64,
        gyro_random_walk: c.imu.noise.gyro_random_walk as f64,
        wheel_std: 0.005,
        flow_std: 0.005,
    };
    let mut sim = Sim::new(11, noise, robot);
    // One stop at the start, then no zero-velocity update to learn the bias.
    sim.drive_time = 1000.0;
    let mut previous = sim.truth();
    let mut f = EgoEkf::new(c).unwrap();
    f.start(&ExplicitStart {
        t: previous.t,
        p_wb: previous.p_wb,
        v_wb: previous.v_wb,
        q_wb: previous.q_wb,
        accel_bias: Vec3::zeros(),
        gyro_bias: Vec3::zeros(),
    })
    .unwrap();
    let (mut sum, mut n, mut frames) = (0.0f32, 0u32, 0u32);
    let mut always_pd = true;
    for k in 1..=(120 * 250u64) {
        let tick = sim.tick();
        f.propagate(&tick.imu).unwrap();
        if let Some(w) = tick.wheel {
            let _ = f.fuse_wheel(&w);
        }
        if camera_on && k % 25 == 0 {
            let truth = tick.truth;
            let noise = sim.rng.vec3(1.0e-4);
            let mut m = camera_motion(&previous, &truth, &cam, noise);
            if outlier_at == Some(frames) {
                let off = Quat::from_scaled_axis(Vec3::new(0.0, 0.0, 0.17));
                m = camera_motion(&previous, &truth, &cam, off.scaled_axis());
            }
            let scale = translation.then_some((D, 1.0e-4));
            let _ = f.fuse_camera(&m, scale);
            always_pd &= is_positive_definite(f.covariance());
            frames += 1;
            previous = truth;
        }
        let e = (f.attitude().inverse() * tick.truth.q_wb).scaled_axis();
        sum += e.z * e.z;
        n += 1;
    }
    Drive {
        yaw_rms: (sum / n as f32).sqrt(),
        filter: f,
        always_pd,
    }
}

#[test]
fn camera_rotation_holds_the_heading_of_a_gyro_biased_filter() {
    let without = drive(false, false, None);
    let rotation = drive(true, false, None);
    let pose = drive(true, true, None);
    println!(
        "yaw RMSE: no camera {:.3} deg, rotation {:.3} deg, rotation and translation {:.3} deg",
        without.yaw_rms.to_degrees(),
        rotation.yaw_rms.to_degrees(),
        pose.yaw_rms.to_degrees()
    );
    let counts = rotation.filter.camera_counts();
    let skips = rotation.filter.camera_skips();
    println!("camera counts {counts}, skips {skips:?}");
    assert!(rotation.yaw_rms < 0.25 * without.yaw_rms);
    assert!(pose.yaw_rms < 0.25 * without.yaw_rms);
    assert!(counts.fused() > 0 && counts.gated() == 0);
    // Frames while still (at the start) are skipped, not measured; the
    // first frame of a drive takes the clone.
    assert!(skips.still > 0 && skips.no_clone > 0);
    assert_eq!(
        counts.seen(),
        counts.fused() + counts.rejected_total(),
        "every frame counted once"
    );
    assert!(rotation.always_pd && pose.always_pd);
    assert!(is_positive_definite(pose.filter.covariance()));
    let status = pose.filter.camera_status().unwrap();
    assert!(status.t > Timestamp(0));
}

#[test]
fn an_outlier_pair_is_gated_and_counted() {
    let clean = drive(true, true, None);
    let bad = drive(true, true, Some(300));
    let (c, b) = (clean.filter.camera_counts(), bad.filter.camera_counts());
    println!("clean {c}; with an outlier {b}");
    assert_eq!(b.gated(), c.gated() + 1);
    assert_eq!(b.rejected(Reject::Gated), c.rejected(Reject::Gated) + 1);
    // A gated pair leaves the heading where the clean run has it.
    assert!(bad.yaw_rms < 1.5 * clean.yaw_rms);
    assert!(bad.always_pd);
}

/// A filter started level at rest, without the floor constraint (whose
/// schedule counts IMU samples, so it would tell the two filters below apart).
fn turning_filter() -> EgoEkf {
    let c = FilterConfig {
        floor: None,
        camera: Some(CameraConfig::default()),
        ..FilterConfig::default()
    };
    let mut f = EgoEkf::new(c).unwrap();
    f.start(&ExplicitStart {
        v_wb: Vec3::new(0.3, 0.0, 0.0),
        ..ExplicitStart::at_rest(Timestamp(0))
    })
    .unwrap();
    f
}

/// Turning at 0.5 rad/s while speeding up: far from still.
fn moving_sample(t: u64) -> ImuSample {
    ImuSample::new(Timestamp(t), [0.0, 0.0, 0.5], [0.2, 0.0, G]).unwrap()
}

#[test]
fn a_frame_between_imu_samples_is_cloned_at_its_own_time() {
    let mut a = turning_filter();
    let mut b = turning_filter();
    for k in 1..=100u64 {
        a.propagate(&moving_sample(k * DT_NS)).unwrap();
        b.propagate(&moving_sample(k * DT_NS)).unwrap();
    }
    // A frame half-way to the next sample: `a` holds the last sample's rates
    // to it; `b` gets a sample there (the same rates).
    let t_frame = 100 * DT_NS + DT_NS / 2;
    let first = CameraMotion::new(
        Timestamp(t_frame - 100_000_000),
        Timestamp(t_frame),
        Rot3::identity(),
        nalgebra::Vector3::zeros(),
        200,
        0.9,
        0.3,
    )
    .unwrap();
    // The first frame of a drive only takes the clone.
    assert_eq!(a.fuse_camera(&first, None), Err(Reject::NotReady));
    assert_eq!(a.camera_skips().no_clone, 1);
    assert_eq!(a.time(), Some(Timestamp(t_frame)));
    assert_eq!(a.imu_counts().fused(), 100, "the frame is no IMU sample");
    b.propagate(&moving_sample(t_frame)).unwrap();
    let (xa, xb) = (*a.state(), *b.state());
    let dp = (xa.clone_p_wb - xb.p_wb).norm();
    let dq = (xa.clone_q_wb.inverse() * xb.q_wb).angle();
    println!("clone against the pose at the frame: {dp:e} m, {dq:e} rad");
    assert!(dp < 1e-6 && dq < 1e-6);
    // The pose at the sample before the frame is 2 ms of motion away
    // (about 0.6 mm): the test tells the two apart.
    let mut c = turning_filter();
    for k in 1..=100u64 {
        c.propagate(&moving_sample(k * DT_NS)).unwrap();
    }
    assert!((xa.clone_p_wb - c.position()).norm() > 1e-4);
    // Both continue from the frame's time with the next sample.
    a.propagate(&moving_sample(101 * DT_NS)).unwrap();
    b.propagate(&moving_sample(101 * DT_NS)).unwrap();
    let gap = (a.position() - b.position()).norm();
    assert!(gap < 1e-6, "{gap}");
}

#[test]
fn frames_without_a_configured_camera_or_too_old_are_refused() {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
    let m = CameraMotion::new(
        Timestamp(0),
        Timestamp(DT_NS),
        Rot3::identity(),
        nalgebra::Vector3::zeros(),
        200,
        0.9,
        0.3,
    )
    .unwrap();
    assert_eq!(f.fuse_camera(&m, None), Err(Reject::NotReady));
    let mut g = turning_filter();
    for k in 1..=100u64 {
        g.propagate(&moving_sample(k * DT_NS)).unwrap();
    }
    // 300 ms behind the filter: out of order.
    assert_eq!(g.fuse_camera(&m, None), Err(Reject::OutOfOrder));
    assert_eq!(g.camera_counts().rejected(Reject::OutOfOrder), 1);
}

/// Two frame pairs of a turning filter: the first takes the clone, the
/// second (a pair 100 ms later that saw 5 % more rotation than the filter
/// predicts) is fused with the camera's memory weight `weight`.
fn weighted_pair(weight: f32) -> EgoEkf {
    let mut f = turning_filter();
    let frame = |t0: u64, t1: u64, yaw: f32| {
        CameraMotion::new(
            Timestamp(t0),
            Timestamp(t1),
            Rot3::from_axis_angle(&nalgebra::Vector3::z_axis(), yaw),
            nalgebra::Vector3::zeros(),
            200,
            0.9,
            0.3,
        )
        .unwrap()
    };
    for k in 1..=100u64 {
        f.propagate(&moving_sample(k * DT_NS)).unwrap();
    }
    let t1 = 100 * DT_NS;
    assert_eq!(
        f.fuse_camera_weighted(&frame(t1 - 100_000_000, t1, 0.0), None, weight),
        Err(Reject::NotReady)
    );
    let motion = f
        .relative_motion(Timestamp(t1))
        .expect("a clone at the frame");
    assert_eq!(motion.t0, Timestamp(t1));
    for k in 101..=125u64 {
        f.propagate(&moving_sample(k * DT_NS)).unwrap();
    }
    let t2 = 125 * DT_NS;
    let predicted = f.relative_motion(Timestamp(t2)).unwrap().imu.rotation.z;
    assert!((predicted - 0.05).abs() < 2e-3, "{predicted}");
    f.fuse_camera_weighted(&frame(t1, t2, 0.05 * 1.05), None, weight)
        .unwrap();
    f
}

#[test]
fn the_camera_memory_weight_inflates_its_noise() {
    let full = weighted_pair(1.0);
    let quarter = weighted_pair(0.25);
    let a = full.camera_status().unwrap();
    let b = quarter.camera_status().unwrap();
    for i in 0..3 {
        let ratio = b.observation_var[i] / a.observation_var[i];
        assert!((ratio - 4.0).abs() < 1e-4, "row {i}: {ratio}");
    }
    // The weighted camera moves the heading less.
    let pull = |f: &EgoEkf| f.attitude().euler_angles().2;
    assert!(
        pull(&quarter) < pull(&full),
        "{} vs {}",
        pull(&quarter),
        pull(&full)
    );
    // Weights outside (0, 1] are taken as 1.
    for w in [f32::NAN, 0.0, 2.0] {
        let odd = weighted_pair(w);
        let var = odd.camera_status().unwrap().observation_var;
        assert_eq!(var[..3], a.observation_var[..3], "weight {w}");
    }
}
