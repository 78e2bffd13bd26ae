//! Absolute yaw is unobservable to the IMU, the wheels and the zero-velocity
//! update, so no update may shrink its variance: a robot standing still
//! must not learn its heading. Ignored: it fails today (a known bug; see
//! `tests/fused_consistency.rs`'s module doc). With a yaw prior of 0.2 rad
//! the filter's world-yaw standard deviation after 0.96 s standing still is
//! 0.075-0.146 rad on seeds 1000-1005 (cargo test -p ego-ekf --release
//! --test yaw_unobservable -- --ignored --nocapture); with the IMU mounted
//! level (rotation prior 1e-6 rad) or the tilt known to 1e-5 rad it is
//! 0.076-0.185 rad after 1 s (measured with this test so changed). The first wheel
//! update at rest already removes a quarter of the yaw variance: before
//! it, the velocity-yaw covariance is not the one the unobservable
//! direction implies (`sigma^2 [e_z]x (v - v_0)`).

mod support;

use ego_ekf::state::Vec3;
use ego_ekf::{EgoEkf, FilterConfig, GripParams, InitConfig};
use support::monte_carlo::{draw, yaw_error};

#[test]
#[ignore = "known bug: the filter learns absolute yaw standing still"]
fn standing_still_does_not_reveal_the_heading() {
    let c = FilterConfig {
        grip: GripParams::new(0.95, 0.005, 0.001, 10.83, 2.0).unwrap(),
        floor: None,
        init: InitConfig {
            yaw_std: 0.2,
            ..InitConfig::default()
        },
        ..FilterConfig::default()
    };
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
    println!("world-yaw std after 0.96 s standing still (prior 0.2 rad): {stds:.3?}");
    assert!(stds.iter().all(|s| *s > 0.199), "{stds:.3?}");
}
