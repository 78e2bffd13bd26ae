//! A skid steer whose effective track is 1.5 times the description's
//! (`ego_ekf::wheel::skid`): the robot slaloms (left and right turns at up
//! to 0.6 rad/s, 0.4 m/s) while its wheels' speed difference is that of a
//! track 1.5 times wider than the contact points. With the learner the
//! factor converges to 1.5, the wheel rows are consistent (mean NIS near 1,
//! few samples gated), the gyroscope's z bias stays at the true zero and the
//! contact points where they are; without it (the test of the test) the
//! filter gates more while it adapts and stretches its contact points (a
//! 3 mm prior) by 10 cm to take up the skid.

mod support;

use ego_ekf::wheel::skid::SkidConfig;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig};
use nalgebra::Vector3;
use support::{IMU_DT_NS, Rng};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

const G: f64 = 9.806_65;
/// The default robot prior's geometry: 35 mm wheels, 0.23 m between the
/// contact points, the IMU 6 cm above the robot origin.
const RADIUS: f64 = 0.035;
const TRACK: f64 = 0.23;
const IMU_HEIGHT: f64 = 0.06;
/// Effective over kinematic track on this floor.
const CHI: f64 = 1.5;
const SPEED: f64 = 0.4;
const DT: f64 = IMU_DT_NS as f64 * 1e-9;

fn yaw_rate(t: f64) -> f64 {
    0.6 * (std::f64::consts::TAU * t / 8.0).cos()
}

/// What one run saw over its second half.
#[derive(Debug, Default)]
struct Seen {
    forward_nis: f64,
    differential_nis: f64,
    gated: usize,
    samples: usize,
    chi: Option<f32>,
    chi_std: Option<f32>,
    gyro_bias_z: f32,
    /// Gated samples in the first half.
    gated_early: usize,
    /// The filter's kinematic track (its contact points' distance), m.
    contact_track: f32,
}

fn drive(skid: bool, seconds: f64) -> Seen {
    let mut c = FilterConfig::default();
    c.wheel.skid = skid.then(|| SkidConfig::new(TRACK as f32, 1.0));
    c.init.tilt_std = 5e-4;
    let mut f = EgoEkf::new(c).unwrap();
    f.start(&ExplicitStart {
        p_wb: Vector3::new(0.0, 0.0, IMU_HEIGHT as f32),
        v_wb: Vector3::new(SPEED as f32, 0.0, 0.0),
        ..ExplicitStart::at_rest(Timestamp(0))
    })
    .unwrap();
    // The wheels' noise is the filter's model of it (the default grip's).
    let wn = f64::from(c.grip.forward_std());
    let mut rng = Rng::new(3);
    let mut seen = Seen::default();
    let n = (seconds / DT).round() as u64;
    for k in 1..=n {
        let t = k as f64 * DT;
        let w = yaw_rate(t);
        let gn = 1e-3;
        // Constant forward speed in the body: the acceleration is the
        // centripetal `v w` to the left.
        let imu = ImuSample::new(
            Timestamp(k * IMU_DT_NS),
            [
                (gn * rng.normal()) as f32,
                (gn * rng.normal()) as f32,
                (w + gn * rng.normal()) as f32,
            ],
            [
                (10.0 * gn * rng.normal()) as f32,
                (SPEED * w + 10.0 * gn * rng.normal()) as f32,
                (G + 10.0 * gn * rng.normal()) as f32,
            ],
        )
        .unwrap();
        let _ = f.propagate(&imu);
        if k.is_multiple_of(5) {
            let half = 0.5 * w * TRACK * CHI;
            let vl = SPEED - half + wn * rng.normal();
            let vr = SPEED + half + wn * rng.normal();
            let rates = WheelRates::new(
                Timestamp(k * IMU_DT_NS),
                (vl / RADIUS) as f32,
                (vr / RADIUS) as f32,
            )
            .unwrap();
            let out = f.fuse_wheel(&rates);
            if t <= 0.5 * seconds {
                seen.gated_early += usize::from(out.is_ok_and(|i| i.gated));
            }
            if t > 0.5 * seconds
                && let (Ok(inn), Some(s)) = (out, f.wheel_status())
            {
                seen.samples += 1;
                seen.gated += usize::from(inn.gated);
                seen.forward_nis += f64::from(s.innovation[0].powi(2) / s.innovation_var[0]);
                seen.differential_nis += f64::from(s.innovation[1].powi(2) / s.innovation_var[1]);
            }
        }
    }
    let m = seen.samples.max(1) as f64;
    seen.forward_nis /= m;
    seen.differential_nis /= m;
    seen.chi = f.track_estimate().map(|e| e.chi);
    seen.chi_std = f.track_estimate().map(|e| e.chi_std);
    seen.gyro_bias_z = f.gyro_bias().z;
    let x = f.state();
    seen.contact_track = (x.p_br - x.p_bl).norm();
    seen
}

#[test]
fn the_effective_track_is_learned_and_the_wheels_are_consistent() {
    let seen = drive(true, 60.0);
    eprintln!("with the learner: {seen:?}");
    let (chi, chi_std) = (seen.chi.unwrap(), seen.chi_std.unwrap());
    assert!((chi - 1.5).abs() < 0.05, "{seen:?}");
    assert!(
        chi_std < 0.1 && (chi - 1.5).abs() < 2.0 * chi_std,
        "{seen:?}"
    );
    assert!(seen.samples > 1000, "{seen:?}");
    assert!((seen.gated as f64) < 0.03 * seen.samples as f64, "{seen:?}");
    for nis in [seen.forward_nis, seen.differential_nis] {
        assert!((0.5..1.5).contains(&nis), "{seen:?}");
    }
    // The gyro's bias is its own (zero), not the skid's; the contact
    // points stay at the physical track.
    assert!(seen.gyro_bias_z.abs() < 2e-3, "{seen:?}");
    assert!((seen.contact_track - 0.23).abs() < 0.01, "{seen:?}");

    // The test of the test: a differential drive's wheel model on the same
    // robot gates more while it adapts and takes the skid into its contact
    // points, 30 prior standard deviations away.
    let plain = drive(false, 60.0);
    eprintln!("without: {plain:?}");
    assert!(plain.chi.is_none());
    assert!(plain.contact_track > 0.32, "{plain:?}");
    assert!(
        plain.gated_early > 2 * seen.gated_early,
        "{plain:?} {seen:?}"
    );
}
