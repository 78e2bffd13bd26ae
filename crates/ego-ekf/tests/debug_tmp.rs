#![allow(missing_docs, clippy::field_reassign_with_default)]
mod support;
use ego_ekf::state::{Quat, Vec3};
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, GripParams};
use support::*;

#[test]
fn debug_mc() {
    let mut c = FilterConfig::default();
    c.grip = GripParams::new(0.95, 0.005, 0.003, 10.83, 2.0).unwrap();
    let env = |k: &str| std::env::var(k).is_ok();
    if env("TR") {
        c.robot.radius_std = 1e-6;
    }
    if env("TC") {
        c.robot.contact_std = 1e-6;
    }
    if env("TROT") {
        c.robot.rotation_std = 1e-6;
    }
    let n = 10;
    let mut tot = [0.0f64; 4];
    let mut cnt = 0;
    for run in 0..n {
        let mut rng = Rng::new(run ^ 0xABCD);
        let r = &c.robot;
        let robot = if env("GEO") {
            SimRobot {
                p_bl: r.p_bl + rng.vec3(r.contact_std as f64),
                p_br: r.p_br + rng.vec3(r.contact_std as f64),
                q_rb: r.q_rb * Quat::from_scaled_axis(rng.vec3(r.rotation_std as f64)),
                radius_left: r.radius as f64 + rng.normal() * r.radius_std as f64,
                radius_right: r.radius as f64 + rng.normal() * r.radius_std as f64,
            }
        } else {
            SimRobot {
                p_bl: r.p_bl,
                p_br: r.p_br,
                q_rb: r.q_rb,
                radius_left: r.radius as f64,
                radius_right: r.radius as f64,
            }
        };
        let noise = SimNoise {
            accel_density: if env("NOA") { 1e-9 } else { 2e-3 },
            gyro_density: if env("NOG") { 1e-9 } else { 2e-4 },
            accel_bias: if env("BIAS") {
                rng.vec3(0.05)
            } else {
                Vec3::zeros()
            },
            gyro_bias: if env("BIAS") {
                rng.vec3(0.005)
            } else {
                Vec3::zeros()
            },
            accel_random_walk: 0.0,
            gyro_random_walk: 0.0,
            wheel_std: if env("NOW") { 0.0 } else { 0.005 },
            flow_std: 0.0,
        };
        let mut sim = Sim::new(run + 100, noise, robot);
        let t = sim.truth();
        let mut f = EgoEkf::new(c).unwrap();
        f.start(&ExplicitStart {
            t: t.t,
            p_wb: t.p_wb,
            v_wb: t.v_wb,
            q_wb: t.q_wb,
            accel_bias: Vec3::zeros(),
            gyro_bias: Vec3::zeros(),
        })
        .unwrap();
        for k in 1..=7500u64 {
            let tick = sim.tick();
            f.propagate(&tick.imu).unwrap();
            if let Some(w) = tick.wheel {
                f.fuse_wheel(&w).unwrap();
            }
            if k % 50 == 0 {
                let s = f.state();
                tot[0] += nees3(&(tick.truth.p_wb - s.p_wb), f.covariance(), 0);
                tot[1] += nees3(&(tick.truth.v_wb - s.v_wb), f.covariance(), 3);
                tot[2] += nees3(
                    &attitude_error(&s.q_wb, &tick.truth.q_wb),
                    f.covariance(),
                    6,
                );
                let er = [
                    sim.robot.radius_left as f32 - s.radius_left,
                    sim.robot.radius_right as f32 - s.radius_right,
                ];
                let rs = f.wheel_radius_std();
                tot[3] += ((er[0] / rs[0]).powi(2) + (er[1] / rs[1]).powi(2)) as f64;
                cnt += 1;
                if run == 0 && env("PR") && k % 500 == 0 {
                    println!(
                        "t {:.0} radii {:.5?} std {:.5?} ev {:.4?} vstd {:.4?} still {} cl {:.4?} cr {:.4?}",
                        k as f64 * 0.004,
                        f.wheel_radii(),
                        f.wheel_radius_std(),
                        (tick.truth.v_wb - s.v_wb).as_slice(),
                        f.velocity_std().as_slice(),
                        f.is_still(),
                        s.p_bl.as_slice(),
                        s.p_br.as_slice()
                    );
                }
            }
        }
    }
    println!(
        "mean NEES p {:.2} v {:.2} th {:.2} radius(2) {:.2}",
        tot[0] / cnt as f64,
        tot[1] / cnt as f64,
        tot[2] / cnt as f64,
        tot[3] / cnt as f64
    );
}
