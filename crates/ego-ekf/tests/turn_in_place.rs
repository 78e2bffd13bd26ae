//! Wheels turning in place while the body does not turn (a skid steer on
//! snow, BorealTC's SNOW_21): the differential row fails the gate at every
//! sample, and the forward row, which says the robot stands, must still be
//! fused. Dropping it with the differential row let the filter's velocity
//! run away on the IMU alone (SNOW_21: 54 m of path while turning in place).
//!
//! The robot stands still on a shaking floor (accelerometer noise 0.3 m/s^2
//! per 250 Hz sample) with an accelerometer bias the filter does not know;
//! its wheels turn at +-0.3 m/s (rim speed) for 30 s.

mod support;

use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig};
use support::{IMU_DT_NS, Rng};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

const G: f32 = 9.806_65;
const RADIUS: f32 = 0.035;

struct Run {
    wheel_samples: u32,
    gated: u32,
    forward_fused: u32,
    max_speed: f32,
    drift: f32,
}

fn run(seconds: u64, accel_bias: f32, seed: u64) -> Run {
    let mut c = FilterConfig::default();
    c.init.accel_bias_std = 1e-3;
    let mut f = EgoEkf::new(c).unwrap();
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
    let mut rng = Rng::new(seed);
    let mut out = Run {
        wheel_samples: 0,
        gated: 0,
        forward_fused: 0,
        max_speed: 0.0,
        drift: 0.0,
    };
    let n = seconds * 1_000_000_000 / IMU_DT_NS;
    for k in 1..=n {
        let t = Timestamp(k * IMU_DT_NS);
        let shake = |rng: &mut Rng| (0.3 * rng.normal()) as f32;
        let accel = [
            accel_bias + shake(&mut rng),
            shake(&mut rng),
            G + shake(&mut rng),
        ];
        let gyro = [
            (2e-3 * rng.normal()) as f32,
            (2e-3 * rng.normal()) as f32,
            (2e-3 * rng.normal()) as f32,
        ];
        f.propagate(&ImuSample::new(t, gyro, accel).unwrap())
            .unwrap();
        if k.is_multiple_of(5) {
            let rate = |v: f32, rng: &mut Rng| (v + (0.003 * rng.normal()) as f32) / RADIUS;
            let rates = WheelRates::new(t, rate(-0.3, &mut rng), rate(0.3, &mut rng)).unwrap();
            if let Ok(inn) = f.fuse_wheel(&rates) {
                out.wheel_samples += 1;
                out.gated += u32::from(inn.gated);
                out.forward_fused += u32::from(inn.forward_fused);
            }
        }
        out.max_speed = out.max_speed.max(f.robot_velocity().xy().norm());
    }
    out.drift = f.position().xy().norm();
    out
}

#[test]
fn turning_in_place_without_turning_keeps_the_forward_row() {
    for seed in 1..=3 {
        let r = run(30, 0.05, seed);
        // The body does not turn as the wheels say: the differential row
        // fails at (almost) every sample.
        assert!(
            r.gated * 10 >= r.wheel_samples * 9,
            "seed {seed}: {} of {} gated",
            r.gated,
            r.wheel_samples
        );
        // The forward row says the robot stands; it is consistent and fused.
        assert!(
            r.forward_fused * 10 >= r.wheel_samples * 9,
            "seed {seed}: forward fused {} of {}",
            r.forward_fused,
            r.wheel_samples
        );
        // With it the velocity stays held (IMU alone: 0.05 m/s^2 of bias is
        // 1.5 m/s and 22 m after 30 s).
        assert!(r.max_speed < 0.05, "seed {seed}: speed {}", r.max_speed);
        assert!(r.drift < 0.1, "seed {seed}: drift {} m", r.drift);
    }
}
