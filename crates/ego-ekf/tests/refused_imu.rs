//! Readings refused for their values leave a hole in the IMU stream: the
//! reading that ends it is integrated over its own part of the interval,
//! the last accepted rates held over the refused part.

use ego_ekf::config::ImuConfig;
use ego_ekf::state::STANDARD_GRAVITY;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, ImuPlausibility};
use vslam_core::sensors::ImuSample;
use vslam_core::{Reject, Timestamp};

const DT: u64 = 4_000_000;
/// The robot turns in place at this rate, rad/s.
const RATE: f32 = 0.3;

fn filter() -> EgoEkf {
    let config = FilterConfig {
        imu: ImuConfig {
            // Noise-free readings repeat: never judged frozen.
            plausibility: Some(ImuPlausibility::DEFAULT),
            ..ImuConfig::default()
        },
        ..FilterConfig::default()
    };
    let mut f = EgoEkf::new(config).unwrap();
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
    f
}

fn turning(k: u64, gz: f32) -> ImuSample {
    ImuSample::new(
        Timestamp(k * DT),
        [0.0, 0.0, gz],
        [0.0, 0.0, STANDARD_GRAVITY],
    )
    .unwrap()
}

fn yaw(f: &EgoEkf) -> f32 {
    f.attitude().euler_angles().2
}

/// Turns for one second; from sample 100 `bad` readings and then one of
/// `RATE + last`; `bad_reading(k)` gives a refused reading. Returns the
/// filter after sample 250.
fn drive(bad: u64, last: f32, bad_reading: impl Fn(u64) -> ImuSample) -> EgoEkf {
    let mut f = filter();
    for k in 1..=250 {
        let s = match k {
            100.. if k < 100 + bad => bad_reading(k),
            _ if k == 100 + bad => turning(k, RATE + last),
            _ => turning(k, RATE),
        };
        let _ = f.propagate(&s);
    }
    f
}

fn truth() -> f32 {
    RATE * 250.0 * DT as f32 * 1e-9
}

#[test]
fn a_spike_after_refused_readings_turns_the_heading_over_its_own_step_only() {
    // Four hundredfold spikes are refused as yaw jumps; the fifth, 0.15
    // rad/s off and within the allowance grown over 20 ms, is accepted (and
    // so is the rate it returns to, within 0.18 rad/s of it).
    let spike = |k| turning(k, RATE * 100.0);
    let f = drive(4, 0.15, spike);
    assert_eq!(f.imu_counts().rejected(Reject::OutOfRange), 4);
    assert_eq!(f.imu_counts().fused(), 250 - 4);
    let err = (yaw(&f) - truth()).abs();
    // Held over the refused 16 ms, the spike turns the heading by 0.15
    // rad/s for 4 ms (0.6 mrad); integrated over the whole 20 ms it would
    // be 3.
    assert!(err < 0.8e-3 && err > 0.4e-3, "yaw error {err} rad");
}

#[test]
fn saturated_readings_are_held_over_as_well() {
    let config = ImuConfig::default();
    let saturated = |k| turning(k, config.gyro_max);
    // The reading after four of them 0.15 rad/s off: one step of it (0.6
    // mrad), not the 20 ms since the last accepted one (3 mrad; five would
    // make a gap, bridged instead).
    let f = drive(4, 0.15, saturated);
    assert_eq!(f.imu_counts().rejected(Reject::Saturated), 4);
    let err = (yaw(&f) - truth()).abs();
    assert!(err < 0.8e-3 && err > 0.4e-3, "yaw error {err} rad");
}

#[test]
fn readings_refused_before_the_filter_are_held_over_as_well() {
    // Non-finite readings never become an `ImuSample`: the caller that
    // refused them says when they were taken.
    let mut f = filter();
    for k in 1..=250u64 {
        if (100..104).contains(&k) {
            f.refused_imu_at(Timestamp(k * DT));
            continue;
        }
        let gz = if k == 104 { RATE + 0.15 } else { RATE };
        f.propagate(&turning(k, gz)).unwrap();
    }
    let err = (yaw(&f) - truth()).abs();
    assert!(err < 0.8e-3 && err > 0.4e-3, "yaw error {err} rad");
    // A time far ahead (a time stamp in error) does not keep the next
    // refused reading from being held over.
    f.refused_imu_at(Timestamp(10_000 * DT));
    f.refused_imu_at(Timestamp(251 * DT));
    let before = yaw(&f);
    f.propagate(&turning(252, RATE + 0.15)).unwrap();
    let turned = yaw(&f) - before;
    assert!(
        (turned - RATE * 0.008 - 0.15 * 0.004).abs() < 2e-5,
        "{turned}"
    );
}

#[test]
fn a_turn_that_speeds_up_behind_refused_readings_keeps_its_old_rate_until_them() {
    // The true rate steps up by 0.4 rad/s while three readings are
    // refused: the held rate misses the step over those 12 ms (4.8 mrad at
    // most), the reading that ends them is not integrated backwards.
    let spike = |k| turning(k, 30.0);
    let mut f = filter();
    let mut truth = 0.0f32;
    for k in 1..=250u64 {
        let rate = if k >= 100 { RATE + 0.4 } else { RATE };
        truth += rate * DT as f32 * 1e-9;
        let s = if (100..103).contains(&k) {
            spike(k)
        } else {
            turning(k, rate)
        };
        let _ = f.propagate(&s);
    }
    assert_eq!(f.imu_counts().rejected(Reject::OutOfRange), 3);
    let err = truth - yaw(&f);
    assert!((err - 0.4 * 0.012).abs() < 2e-4, "yaw error {err} rad");
}
