//! The floor constraint (`ego_ekf::floor`): the height stays on a flat
//! floor, a bump is gated and forgotten, a new level is taken over, and each
//! of these fails when the constraint is cut.

mod support;

use ego_ekf::config::ConfigError;
use ego_ekf::state::Vec3;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, FloorConfig};
use support::{Sim, SimNoise, SimRobot};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

const G: f32 = ego_ekf::state::STANDARD_GRAVITY;
const DT_NS: u64 = 4_000_000;

fn with_floor(on: bool) -> FilterConfig {
    FilterConfig {
        floor: on.then(FloorConfig::default),
        ..FilterConfig::default()
    }
}

/// Largest |height error| of the IMU after the first two seconds of a
/// two-minute drive whose accelerometer has a vertical bias the filter does
/// not know at the start.
fn worst_height_error(floor: bool) -> f32 {
    let c = with_floor(floor);
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
        accel_bias: Vec3::new(0.02, -0.03, 0.08),
        gyro_bias: Vec3::new(0.002, -0.001, 0.003),
        accel_random_walk: c.imu.noise.accel_random_walk as f64,
        gyro_random_walk: c.imu.noise.gyro_random_walk as f64,
        wheel_std: 0.005,
        flow_std: 0.005,
    };
    let mut sim = Sim::new(7, noise, robot);
    let truth = sim.truth();
    let mut f = EgoEkf::new(c).unwrap();
    f.start(&ExplicitStart {
        t: truth.t,
        p_wb: truth.p_wb,
        v_wb: truth.v_wb,
        q_wb: truth.q_wb,
        accel_bias: Vec3::zeros(),
        gyro_bias: Vec3::zeros(),
    })
    .unwrap();
    let mut worst = 0.0f32;
    for k in 1..=(120 * 250) {
        let tick = sim.tick();
        f.propagate(&tick.imu).unwrap();
        if let Some(w) = tick.wheel {
            let _ = f.fuse_wheel(&w);
        }
        if k > 500 {
            worst = worst.max((f.position().z - tick.truth.p_wb.z).abs());
        }
    }
    worst
}

#[test]
fn height_stays_within_a_centimetre_on_a_flat_floor() {
    let on = worst_height_error(true);
    let off = worst_height_error(false);
    println!("worst height error: floor {on:.4} m, no floor {off:.4} m");
    assert!(on < 0.01, "with the floor: {on} m");
    // The check can fail: without the constraint the same drive drifts.
    assert!(off > 3.0 * on && off > 0.01, "without the floor: {off} m");
}

/// A filter started level and still at the origin.
fn still_filter(c: FilterConfig) -> EgoEkf {
    let mut f = EgoEkf::new(c).unwrap();
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
    f
}

/// Feeds `seconds` of IMU samples from `*k` on, with vertical acceleration
/// `a(t)` (t from the start of this call, s); with `wheels`, wheel samples
/// report stopped wheels at 50 Hz.
fn feed(f: &mut EgoEkf, k: &mut u64, seconds: f32, wheels: bool, a: impl Fn(f32) -> f32) {
    let n = (seconds * 250.0) as u64;
    for i in 0..n {
        *k += 1;
        let t = Timestamp(*k * DT_NS);
        let s = i as f32 * DT_NS as f32 * 1e-9;
        let imu = ImuSample::new(t, [0.0; 3], [0.0, 0.0, G + a(s)]).unwrap();
        f.propagate(&imu).unwrap();
        if wheels && k.is_multiple_of(5) {
            let _ = f.fuse_wheel(&WheelRates::new(t, 0.0, 0.0).unwrap());
        }
    }
}

/// Up by `height` in `duration` s: constant acceleration, then the same
/// deceleration.
fn lift(height: f32, duration: f32) -> impl Fn(f32) -> f32 {
    let a = 4.0 * height / (duration * duration);
    move |s| {
        if s < 0.5 * duration {
            a
        } else if s < duration {
            -a
        } else {
            0.0
        }
    }
}

#[test]
fn a_bump_is_gated_and_the_height_returns() {
    let mut f = still_filter(with_floor(true));
    let mut k = 0;
    feed(&mut f, &mut k, 2.0, true, |_| 0.0);
    // Over a 2 cm cable and down again within 0.4 s.
    let up = lift(0.02, 0.2);
    feed(&mut f, &mut k, 0.2, true, &up);
    feed(&mut f, &mut k, 0.2, true, |s| -up(s));
    feed(&mut f, &mut k, 3.0, true, |_| 0.0);
    let counts = f.floor_counts();
    println!(
        "floor counts {counts:?}, level {:?}, z {}",
        (f.floor().reanchored(), f.floor().floor()),
        f.position().z
    );
    assert!(
        counts.gated() >= 1,
        "the bump's vertical velocity was not gated"
    );
    assert_eq!(f.floor().reanchored(), 0, "a bump re-anchored the floor");
    assert!(f.position().z.abs() < 0.01, "height {}", f.position().z);
    assert_eq!(counts.seen(), counts.fused() + counts.gated());
}

#[test]
fn a_new_level_is_taken_over() {
    for floor in [false, true] {
        let mut f = still_filter(with_floor(floor));
        let mut k = 0;
        feed(&mut f, &mut k, 2.0, true, |_| 0.0);
        let ground = f.floor().floor();
        // Lifted 0.3 m in a second, then held there for 12 s: the wheels off the
        // floor say nothing (their non-holonomic rows would pull the
        // vertical velocity to zero).
        feed(&mut f, &mut k, 1.0, false, lift(0.3, 1.0));
        feed(&mut f, &mut k, 12.0, false, |_| 0.0);
        let (reanchored, level) = (f.floor().reanchored(), f.floor().floor());
        let z = f.position().z;
        println!("floor {floor}: re-anchored {reanchored}, floor {level}, z {z}");
        if floor {
            assert_eq!(reanchored, 1);
            assert!((z - 0.3).abs() < 0.05, "height {z}");
            let rise = level - ground;
            assert!((rise - 0.3).abs() < 0.02, "floor rose by {rise}");
        } else {
            // Without the constraint nothing pulls the height either.
            assert_eq!(reanchored, 0);
            assert_eq!(f.floor_counts().seen(), 0);
            assert!((z - 0.3).abs() < 0.05, "height {z}");
        }
    }
}

#[test]
fn a_bad_floor_config_is_refused() {
    let bad: [fn(&mut FloorConfig); 4] = [
        |c| c.every = 0,
        |c| c.reanchor_after = 0,
        |c| c.height_std = 0.0,
        |c| c.climb_gate = f32::NAN,
    ];
    let want = [
        ConfigError::BadLimit,
        ConfigError::BadLimit,
        ConfigError::BadNoise,
        ConfigError::BadNoise,
    ];
    for (edit, want) in bad.iter().zip(want) {
        let mut floor = FloorConfig::default();
        edit(&mut floor);
        let c = FilterConfig {
            floor: Some(floor),
            ..FilterConfig::default()
        };
        assert_eq!(EgoEkf::new(c).err(), Some(want));
    }
}

#[test]
fn the_floor_waits_while_the_wheels_disagree() {
    let mut f = still_filter(with_floor(true));
    let mut k = 0;
    feed(&mut f, &mut k, 2.0, true, |_| 0.0);
    let before = *f.floor_counts();
    assert_eq!(f.floor().suspended(), 0);
    // Free wheels at 10 rad/s (0.35 m/s) while the IMU says the robot is
    // still: the wheels' forward row is gated sample after sample.
    for _ in 0..250 {
        k += 1;
        let t = Timestamp(k * DT_NS);
        let imu = ImuSample::new(t, [0.0; 3], [0.0, 0.0, G]).unwrap();
        f.propagate(&imu).unwrap();
        if k.is_multiple_of(5) {
            let _ = f.fuse_wheel(&WheelRates::new(t, 10.0, 10.0).unwrap());
        }
    }
    let suspended = f.floor().suspended();
    let made = f.floor_counts().seen() - before.seen();
    println!("suspended {suspended}, made {made}");
    assert!(suspended >= 8, "only {suspended} updates suspended");
    assert!(
        made <= 2,
        "{made} floor updates made while the wheels were gated"
    );
}
