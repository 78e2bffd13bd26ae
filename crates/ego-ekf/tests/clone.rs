//! The pose clone read by the zero-velocity update: it holds the pose of the
//! last moving step when the robot stops (copied at the first still step,
//! not at every moving step), and the updates that follow hold the pose to
//! it.

mod random_update;

use ego_ekf::config::{ImuConfig, RobotPrior};
use ego_ekf::covariance::{decouple_clone, is_positive_definite};
use ego_ekf::propagate::{
    Transition, process_noise, propagate_covariance, propagate_covariance_clone_decoupled,
};
use ego_ekf::state::{CP, DIM, Quat, STANDARD_GRAVITY, Vec3};
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig};
use random_update::{Rng, random_covariance};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

const DT: u64 = 4_000_000;
const SPEED: f32 = 0.2;

/// Steps of the braking phase (1 m/s^2 for 0.2 s).
const BRAKING: u64 = 50;
const DECELERATION: f32 = 1.0;

/// Drives at `SPEED` for `moving` IMU steps, brakes to a stop in `BRAKING`
/// steps and stands (wheel samples every fifth step, consistent with the
/// IMU). Calls `on_step(filter, position before the step, still)` after
/// every IMU step.
fn drive_then_stop(moving: u64, total: u64, on_step: impl FnMut(&EgoEkf, Vec3, bool)) {
    drive_then_stop_with(FilterConfig::default(), moving, total, on_step);
}

/// [`drive_then_stop`] with the filter's `config`.
fn drive_then_stop_with(
    config: FilterConfig,
    moving: u64,
    total: u64,
    mut on_step: impl FnMut(&EgoEkf, Vec3, bool),
) {
    let mut f = EgoEkf::new(config).unwrap();
    f.start(&ExplicitStart {
        p_wb: Vec3::new(1.0, -0.5, 0.05),
        v_wb: Vec3::new(SPEED, 0.0, 0.0),
        ..ExplicitStart::at_rest(Timestamp(0))
    })
    .unwrap();
    let dt = DT as f32 * 1e-9;
    let mut speed = SPEED;
    for k in 1..=total {
        let t = k * DT;
        let braking = k > moving && k <= moving + BRAKING;
        let ax = if braking { -DECELERATION } else { 0.0 };
        let s = ImuSample::new(Timestamp(t), [0.0; 3], [ax, 0.0, STANDARD_GRAVITY]).unwrap();
        let before = f.position();
        let step = f.propagate(&s).unwrap();
        on_step(&f, before, step.still);
        if braking {
            speed = (speed - DECELERATION * dt).max(0.0);
        }
        if k > moving + BRAKING {
            speed = 0.0;
        }
        if k % 5 == 0 {
            let w = speed / config.robot.radius;
            let _ = f.fuse_wheel(&WheelRates::new(Timestamp(t), w, w).unwrap());
        }
    }
}

#[test]
fn the_first_still_step_clones_the_pose_of_the_last_moving_step() {
    let mut first_still = None;
    let mut still_steps = 0;
    let mut moved_clone = false;
    drive_then_stop(250, 600, |f, before, still| {
        // While moving, the clone is left behind (a past pose).
        moved_clone |= !still && (f.state().clone_p_wb - f.position()).norm() > 0.1;
        if still && first_still.is_none() {
            // Exactly the position the previous (moving) step ended with,
            // after the wheel update that followed it; not this step's.
            assert_eq!(f.state().clone_p_wb, before);
            first_still = Some(before);
        }
        still_steps += u32::from(still);
    });
    assert!(first_still.is_some(), "the robot never became still");
    assert!(moved_clone);
    assert!(still_steps > 200, "{still_steps}");
}

#[test]
fn zero_velocity_updates_hold_the_pose_at_the_clone() {
    let mut stop = None;
    let mut last = Vec3::zeros();
    drive_then_stop(250, 1000, |f, before, still| {
        if still && stop.is_none() {
            stop = Some(before);
        }
        last = f.position();
        if still {
            // Pose and clone agree while still.
            assert!((f.position() - f.state().clone_p_wb).norm() < 2e-3);
        }
    });
    let stop = stop.expect("the robot became still");
    // Held within millimetres over 1.4 s of standing (the velocity decays
    // under the updates instead of carrying the pose away at 0.2 m/s).
    assert!((last - stop).norm() < 0.01, "{}", (last - stop).norm());
}

/// A pose known only to a metre (after a long IMU gap, or a start without a
/// fix) held still for 20 s: the zero-velocity updates tie the pose to the
/// clone ever more tightly, yet the whole covariance, the clone's rows
/// included, stays positive definite in `f32` (the difference of pose and
/// clone keeps the clone's copy variance).
#[test]
fn a_long_stand_keeps_the_whole_covariance_positive_definite() {
    let mut config = FilterConfig::default();
    config.init.position_std = 1.0;
    config.init.yaw_std = 0.3;
    let (mut still_steps, mut failed) = (0u32, 0u32);
    drive_then_stop_with(config, 250, 250 + 5_000, |f, _, still| {
        if still {
            still_steps += 1;
            failed += u32::from(!is_positive_definite(f.covariance()));
        }
    });
    assert!(still_steps > 4_000, "{still_steps}");
    assert_eq!(failed, 0, "of {still_steps} still steps");
}

#[test]
fn a_decoupled_clone_stays_decoupled_and_propagation_may_skip_it() {
    let r = Quat::from_euler_angles(0.05, -0.03, 1.2)
        .to_rotation_matrix()
        .into_inner();
    let f = Transition::new(
        &r,
        &Vec3::new(0.3, -0.4, 9.9),
        &Vec3::new(0.1, -0.05, 1.3),
        0.004,
    );
    let q = process_noise(&ImuConfig::default(), &RobotPrior::default(), 0.004);
    let clone = CP..CP + 6;
    for seed in 0..10 {
        let original = random_covariance(&mut Rng(seed));
        let mut p = original;
        decouple_clone(&mut p);
        assert!(is_positive_definite(&p));
        for i in 0..DIM {
            for j in 0..DIM {
                let coupled = clone.contains(&i) != clone.contains(&j);
                let want = if coupled { 0.0 } else { original[(i, j)] };
                assert_eq!(p[(i, j)], want, "({i}, {j})");
            }
        }
        let (mut full, mut skipped) = (p, p);
        for _ in 0..5 {
            propagate_covariance(&mut full, &f, &q);
            propagate_covariance_clone_decoupled(&mut skipped, &f, &q);
        }
        // Bit for bit, and the clone's cross terms still zero.
        assert_eq!(full, skipped);
        for i in clone.clone() {
            for j in (0..DIM).filter(|j| !clone.contains(j)) {
                assert_eq!((full[(i, j)], full[(j, i)]), (0.0, 0.0));
            }
        }
    }
}
