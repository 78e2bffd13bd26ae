//! Absolute yaw is unobservable to the IMU, the wheels and the zero-velocity
//! update, so no update may shrink its variance: a robot standing still
//! must not learn its heading. Ignored: it fails today (a known bug; see
//! `tests/fused_consistency.rs`'s module doc). With a yaw prior of 0.2 rad
//! the filter's world-yaw standard deviation after 0.96 s standing still is
//! 0.075-0.146 rad on seeds 1000-1005 (cargo test -p ego-ekf --release
//! --test yaw_unobservable -- --ignored --nocapture); with the IMU mounted
//! level (rotation prior 1e-6 rad) or the tilt known to 1e-5 rad it is
//! 0.076-0.185 rad after 1 s (measured with this test so changed). The
//! wheel updates do it: without them (zero-velocity updates only) the yaw
//! stays at 0.200 rad; without the zero-velocity updates it still falls
//! (0.081-0.150 rad). The first wheel update at rest removes a quarter of
//! the yaw variance. The propagation's velocity-yaw covariance equals its
//! first-order prediction `-R [a]x e_z dt sigma^2` step by step; the
//! wheel rows' attitude column `R_rb [v_b]x` is evaluated at the estimated
//! velocity, which is not zero while the true one is (the start's
//! velocity error, the integrated accelerometer noise), so the rows see
//! the yaw where the truth's would not: the linearisation-point
//! inconsistency that first-estimate or observability-constrained
//! Jacobians remove (Huang et al. 2010; Hesch et al. 2014).

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
