//! Wheel radii converge to true radii 2 % away from the nominal.
//!
//! Observability: the differential wheel row against the gyro's yaw rate
//! fixes the radii relative to the track width (and their difference in
//! straight driving); the absolute scale comes from an absolute velocity
//! reference. With the optical-flow sensor that reference is direct. Without
//! it the IMU alone supplies it, weakly, through accelerations and the
//! centripetal acceleration `v * yaw_rate` while turning.

mod support;

use ego_ekf::state::Vec3;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, FlowConfig, GripParams};
use support::{Sim, SimNoise, SimRobot, flow_optics};

fn run(with_flow: bool, seconds: u64) -> (EgoEkf, [f64; 2]) {
    let c = FilterConfig {
        grip: GripParams::new(0.95, 0.005, 0.001, 10.83, 2.0).unwrap(),
        flow: Some(FlowConfig::new(flow_optics())),
        ..FilterConfig::default()
    };
    let r = &c.robot;
    let truth = [r.radius as f64 * 1.02, r.radius as f64 * 0.98];
    let robot = SimRobot {
        p_bl: r.p_bl,
        p_br: r.p_br,
        q_rb: r.q_rb,
        radius_left: truth[0],
        radius_right: truth[1],
    };
    let noise = SimNoise {
        accel_density: c.imu.noise.accel_density as f64,
        gyro_density: c.imu.noise.gyro_density as f64,
        accel_bias: Vec3::new(0.02, -0.03, 0.01),
        gyro_bias: Vec3::new(0.002, -0.001, 0.003),
        accel_random_walk: 0.0,
        gyro_random_walk: 0.0,
        wheel_std: 0.005,
        flow_std: 0.005,
    };
    let mut sim = Sim::new(42, noise, robot);
    sim.with_flow = with_flow;
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
    for _ in 0..seconds * 250 {
        let tick = sim.tick();
        f.propagate(&tick.imu).unwrap();
        if let Some(w) = tick.wheel {
            f.fuse_wheel(&w).unwrap();
        }
        if let Some(s) = tick.flow {
            let _ = f.fuse_flow(&s);
        }
    }
    (f, truth)
}

fn check(f: &EgoEkf, truth: [f64; 2], max_rel_err: f64, max_rel_std: f64) {
    let est = f.wheel_radii();
    let std = f.wheel_radius_std();
    let nominal = f.config().robot.radius as f64;
    for i in 0..2 {
        let err = est[i] as f64 - truth[i];
        println!(
            "wheel {i}: true {:.5} (nominal {nominal:.5}) estimate {:.5} std {:.6} error {:.3} %",
            truth[i],
            est[i],
            std[i],
            100.0 * err / truth[i]
        );
        assert!(err.abs() < max_rel_err * truth[i], "wheel {i}: error {err}");
        assert!(
            err.abs() < 3.0 * std[i] as f64,
            "wheel {i}: error {err} vs std {}",
            std[i]
        );
        assert!((std[i] as f64) < max_rel_std * truth[i]);
    }
}

#[test]
fn radii_converge_with_the_flow_sensor() {
    let (f, truth) = run(true, 120);
    assert!(f.flow_counts().fused() > 2_900, "{:?}", f.flow_counts());
    check(&f, truth, 0.002, 0.002);
}

#[test]
fn radii_converge_from_imu_and_gyro_alone_more_slowly() {
    let (f, truth) = run(false, 120);
    assert_eq!(f.flow_counts().seen(), 0);
    check(&f, truth, 0.005, 0.005);
}
