//! The estimator's IMU path feeds the adverse-event memory: a saturated
//! reading is an IMU event, a suspected obstacle from the jolt monitor a
//! wheel collision event, and one episode (the samples of one knock) is
//! recorded once.

use traction::ego_ekf::events::JoltKind;
use traction::estimator::{Estimator, Processed};
use traction::vslam_core::Timestamp;
use traction::vslam_core::adverse::{AdverseKind, SensorKind};
use traction::vslam_core::sensors::RawImuSample;

mod common;
use common::estimator;

const MS: u64 = 1_000_000;
/// 250 Hz.
const STEP: u64 = 4 * MS;

/// Feeds IMU samples from `from_ms` for `ms` with vertical specific force
/// `az` (m/s^2); gives the obstacle jolts the estimator reported.
fn feed(est: &mut Estimator<'_>, from_ms: u64, ms: u64, az: f32) -> usize {
    let mut obstacles = 0;
    for k in 0..ms * MS / STEP {
        est.offer_imu(RawImuSample {
            t: Timestamp(from_ms * MS + k * STEP),
            gyro: [0.0; 3],
            accel: [0.0, 0.0, az],
        });
        while let Some(p) = est.poll() {
            if let Processed::Imu { jolt: Some(j), .. } = p {
                obstacles += usize::from(j.kind == JoltKind::SuspectedObstacle);
            }
        }
    }
    obstacles
}

fn tally(est: &Estimator<'_>, sensor: SensorKind, kind: AdverseKind) -> u32 {
    est.scale().memory().tally(sensor, kind)
}

#[test]
fn saturated_readings_and_collisions_are_remembered_once_per_episode() {
    let mut est = estimator();
    assert_eq!(feed(&mut est, 0, 1_000, 9.81), 0);
    assert!(
        est.estimate().is_some(),
        "the filter started on still samples"
    );
    assert_eq!(tally(&est, SensorKind::Imu, AdverseKind::Saturated), 0);

    // A knock: 40 ms of readings beyond the 160 m/s^2 full scale (each
    // checked once the ordering window has passed it).
    feed(&mut est, 1_000, 40, 400.0);
    feed(&mut est, 1_040, 100, 9.81);
    assert_eq!(tally(&est, SensorKind::Imu, AdverseKind::Saturated), 1);
    // Another knock 0.5 s on is the same episode; 2 s on a new one.
    feed(&mut est, 1_140, 400, 9.81);
    feed(&mut est, 1_540, 20, 400.0);
    feed(&mut est, 1_560, 100, 9.81);
    assert_eq!(tally(&est, SensorKind::Imu, AdverseKind::Saturated), 1);
    feed(&mut est, 1_660, 1_900, 9.81);
    feed(&mut est, 3_560, 20, 400.0);
    feed(&mut est, 3_580, 100, 9.81);
    assert_eq!(tally(&est, SensorKind::Imu, AdverseKind::Saturated), 2);
    assert_eq!(tally(&est, SensorKind::Wheel, AdverseKind::Collision), 0);

    // A bump within full scale, far beyond what the floor explains: the
    // jolt monitor suspects an obstacle, a collision of the wheels.
    feed(&mut est, 3_680, 1_900, 9.81);
    let mut obstacles = feed(&mut est, 5_580, 12, 9.81 + 40.0);
    obstacles += feed(&mut est, 5_592, 1_000, 9.81);
    assert_eq!(obstacles, 1);
    assert_eq!(tally(&est, SensorKind::Wheel, AdverseKind::Collision), 1);
    assert_eq!(tally(&est, SensorKind::Imu, AdverseKind::Saturated), 2);
    // A second bump at the same (standing) place: two collisions there
    // lower the wheels' weight.
    let here = est.scale().body_pose().translation.vector;
    let here = traction::vslam_core::geometry::Vec2::new(here.x, here.y);
    let now = Timestamp(9_000 * MS);
    assert_eq!(
        est.scale().memory().weight(SensorKind::Wheel, &here, now),
        1.0
    );
    obstacles = feed(&mut est, 6_592, 12, 9.81 + 40.0);
    obstacles += feed(&mut est, 6_604, 1_000, 9.81);
    assert_eq!(obstacles, 1);
    assert_eq!(tally(&est, SensorKind::Wheel, AdverseKind::Collision), 2);
    assert!(est.scale().memory().weight(SensorKind::Wheel, &here, now) < 1.0);
}
