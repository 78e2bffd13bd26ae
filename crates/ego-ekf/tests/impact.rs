//! A robot that hits something stops within milliseconds while its wheels
//! keep turning (`ego_ekf::impact`): on a carpet whose wheels' noise the
//! adverse-event memory inflated (their weight where the robot is), the
//! samples after the stop must still be gated on the wheels' own noise,
//! not fused.

use ego_ekf::config::RecoveryConfig;
use ego_ekf::grip::GripParams;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, SensorWeights};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

const G: f32 = 9.806_65;
const STEP_NS: u64 = 4_000_000;
const SPEED: f32 = 0.3;
/// The wheels' weight: their noise's standard deviation 4x.
const WEIGHT: f32 = 1.0 / 16.0;

/// Drives at 0.3 m/s for 2 s, hits a wall (one IMU step carries the
/// -0.3 m/s), then stands with its wheels still turning for 2 s; returns,
/// per wheel sample of the first second from the stop, whether its
/// forward row was fused.
fn drive_into_a_wall(recovery: RecoveryConfig, wheel_weight: f32) -> (EgoEkf, Vec<bool>) {
    let config = FilterConfig {
        recovery,
        ..FilterConfig::default()
    };
    let mut f = EgoEkf::new(config).unwrap();
    let start = ExplicitStart {
        v_wb: [SPEED, 0.0, 0.0].into(),
        ..ExplicitStart::at_rest(Timestamp(0))
    };
    f.start(&start).unwrap();
    // A carpet: grip 0.7, forward noise 0.03 m/s, a 99.9 % gate.
    f.set_grip(GripParams::new(0.7, 0.03, 0.01, 10.83, 4.0).unwrap());
    f.set_sensor_weights(SensorWeights {
        wheel: wheel_weight,
        ..SensorWeights::FULL
    })
    .unwrap();
    let rate = SPEED / config.robot.radius;
    let hit = 500; // IMU steps: 2 s
    let mut after = Vec::new();
    for k in 1..=1000u64 {
        let t = Timestamp(k * STEP_NS);
        let ax = if k == hit {
            -SPEED / (STEP_NS as f32 * 1e-9)
        } else {
            0.0
        };
        f.propagate(&ImuSample::new(t, [0.0; 3], [ax, 0.0, G]).unwrap())
            .unwrap();
        if k % 5 == 0 {
            let w = WheelRates::new(t, rate, rate).unwrap();
            let inn = f.fuse_wheel(&w).unwrap();
            if k >= hit && k <= hit + 250 {
                after.push(inn.forward_fused);
            }
        }
    }
    (f, after)
}

#[test]
fn after_an_impact_the_turning_wheels_are_gated_on_their_own_noise() {
    let (f, after) = drive_into_a_wall(RecoveryConfig::DEFAULT, WEIGHT);
    let fused = after.iter().filter(|x| **x).count();
    eprintln!("impact on: {fused} of {} samples fused", after.len());
    assert_eq!(f.impacts().impacts(), 1);
    assert_eq!(fused, 0, "{after:?}");
    assert!(f.impacts().strict_gated() as usize >= after.len());
}

#[test]
fn without_the_impact_rule_the_inflated_gate_lets_the_wheels_in() {
    // The same drive with impacts never detected: the first samples pass the
    // gate widened by the weight (the failure the rule exists for) and drag
    // the standing filter forward.
    let never = RecoveryConfig {
        impact_accel: f32::INFINITY,
        ..RecoveryConfig::DEFAULT
    };
    let (f, after) = drive_into_a_wall(never, WEIGHT);
    let fused = after.iter().filter(|x| **x).count();
    eprintln!("impact off: {fused} of {} samples fused", after.len());
    assert_eq!(f.impacts().impacts(), 0);
    assert!(fused >= after.len() / 2, "{after:?}");
    // ... and the filter drives on with them.
    assert!(f.velocity().norm() > 0.1, "{:?}", f.velocity());
}

#[test]
fn at_full_weight_the_rule_changes_nothing() {
    let never = RecoveryConfig {
        impact_accel: f32::INFINITY,
        ..RecoveryConfig::DEFAULT
    };
    let (a, x) = drive_into_a_wall(RecoveryConfig::DEFAULT, 1.0);
    let (b, y) = drive_into_a_wall(never, 1.0);
    assert_eq!(x, y);
    assert_eq!(a.state(), b.state());
    assert!(x.iter().all(|fused| !fused), "{x:?}");
}

#[test]
fn a_level_that_calls_every_step_an_impact_is_refused() {
    for bad in [0.0, -1.0, f32::NAN] {
        let config = FilterConfig {
            recovery: RecoveryConfig {
                impact_accel: bad,
                ..RecoveryConfig::DEFAULT
            },
            ..FilterConfig::default()
        };
        assert!(EgoEkf::new(config).is_err(), "{bad}");
    }
}
