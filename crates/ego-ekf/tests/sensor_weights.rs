//! The adverse-event memory's weights applied where each sensor is used
//! (`EgoEkf::set_sensor_weights`): the IMU's in the propagation's process
//! noise, the wheels' and the flow sensor's in their measurement noise.
//! Two filters fed the same samples, one with a weight below one, must
//! differ the way the weight says; at full weight nothing changes.

mod support;

use ego_ekf::state::{Covariance, P, TH, V};
use ego_ekf::{EgoEkf, FilterConfig, FlowConfig, SensorWeights};
use support::flow_optics;
use support::monte_carlo::draw;
use vslam_core::Reject;

fn config() -> FilterConfig {
    FilterConfig {
        flow: Some(FlowConfig::new(flow_optics())),
        ..FilterConfig::default()
    }
}

fn trace(p: &Covariance, start: usize) -> f32 {
    (start..start + 3).map(|i| p[(i, i)]).sum()
}

/// Runs `seconds` of the seeded drive through two filters, the second with
/// `weights`.
fn pair(c: FilterConfig, weights: SensorWeights, seconds: u64) -> (EgoEkf, EgoEkf, Vec<[f32; 2]>) {
    let (mut sim, start) = draw(7, &c);
    sim.with_flow = true;
    let mut a = EgoEkf::new(c).unwrap();
    let mut b = EgoEkf::new(c).unwrap();
    a.start(&start).unwrap();
    b.start(&start).unwrap();
    b.set_sensor_weights(weights).unwrap();
    // Per aid sample: (what a saw, what b saw) of its noise.
    let mut seen = Vec::new();
    for _ in 0..seconds * 250 {
        let tick = sim.tick();
        a.propagate(&tick.imu).unwrap();
        b.propagate(&tick.imu).unwrap();
        if let Some(w) = tick.wheel
            && let (Ok(x), Ok(y)) = (a.fuse_wheel(&w), b.fuse_wheel(&w))
        {
            seen.push([x.forward_var, y.forward_var]);
        }
        if let Some(s) = tick.flow
            && let (Ok(x), Ok(y)) = (a.fuse_flow(&s), b.fuse_flow(&s))
        {
            seen.push([x.std, y.std]);
        }
    }
    (a, b, seen)
}

#[test]
fn weights_outside_the_unit_interval_are_refused() {
    let mut f = EgoEkf::new(config()).unwrap();
    for bad in [0.0, -0.5, 1.5, f32::NAN, f32::INFINITY] {
        for w in [
            SensorWeights {
                imu: bad,
                ..SensorWeights::FULL
            },
            SensorWeights {
                wheel: bad,
                ..SensorWeights::FULL
            },
            SensorWeights {
                flow: bad,
                ..SensorWeights::FULL
            },
        ] {
            assert_eq!(f.set_sensor_weights(w), Err(Reject::OutOfRange), "{w:?}");
            assert_eq!(f.sensor_weights(), SensorWeights::FULL);
        }
    }
    let w = SensorWeights {
        imu: 0.5,
        wheel: 1.0,
        flow: 0.01,
    };
    assert_eq!(f.set_sensor_weights(w), Ok(()));
    assert_eq!(f.sensor_weights(), w);
}

#[test]
fn full_weights_change_no_bit() {
    let (a, b, seen) = pair(config(), SensorWeights::FULL, 20);
    assert!(seen.len() > 1_000, "{} aid samples", seen.len());
    assert_eq!(a.state(), b.state());
    assert_eq!(a.covariance(), b.covariance());
}

#[test]
fn the_imu_weight_divides_its_noise_variance_in_propagation() {
    // One IMU step from the same state and covariance: the velocity and
    // attitude variances grow by the accelerometer's and the gyro's noise
    // densities (squared, times dt, per axis), divided by the weight; the
    // bias random walks and the rest of the propagation are the same.
    let c = config();
    let (mut sim, start) = draw(7, &c);
    let mut a = EgoEkf::new(c).unwrap();
    let mut b = EgoEkf::new(c).unwrap();
    a.start(&start).unwrap();
    b.start(&start).unwrap();
    b.set_sensor_weights(SensorWeights {
        imu: 0.25,
        ..SensorWeights::FULL
    })
    .unwrap();
    let imu = sim.tick().imu;
    let step = a.propagate(&imu).unwrap();
    b.propagate(&imu).unwrap();
    let dt = step.dt;
    let n = c.imu.noise;
    for (block, density) in [(V, n.accel_density), (TH, n.gyro_density)] {
        let extra = trace(b.covariance(), block) - trace(a.covariance(), block);
        let expected = 3.0 * 3.0 * density * density * dt;
        eprintln!("block {block}: extra variance {extra:e}, expected {expected:e}");
        assert!(
            (extra / expected - 1.0).abs() < 1e-2,
            "{extra} vs {expected}"
        );
    }
    // The nominal state does not depend on the noise.
    assert_eq!(a.state(), b.state());
}

#[test]
fn the_wheel_and_flow_weights_inflate_their_measurement_noise() {
    let (a, b, seen) = pair(
        config(),
        SensorWeights {
            imu: 1.0,
            wheel: 0.1,
            flow: 0.25,
        },
        20,
    );
    let wheel = seen.iter().filter(|[x, y]| y > x).count();
    eprintln!("{} aid samples, {wheel} with more noise in b", seen.len());
    // The flow's standard deviation doubles exactly (weight 0.25).
    let flow: Vec<f32> = seen
        .iter()
        .map(|[x, y]| y / x)
        .filter(|r| (r - 2.0).abs() < 1e-3)
        .collect();
    assert!(
        flow.len() > 450,
        "{} flow reports at twice the std",
        flow.len()
    );
    // Every wheel innovation's variance is larger (its noise is 10x).
    assert!(wheel >= seen.len() - 5, "{wheel} of {}", seen.len());
    // Trusting the aids less leaves the position less certain.
    assert!(trace(b.covariance(), P) > trace(a.covariance(), P));
}
