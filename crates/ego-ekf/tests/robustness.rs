//! Property: under random sequences of IMU, wheel and flow samples (bad time
//! stamps, NaN, huge values, saturated and invalid flow included), nothing
//! panics, every sample is counted once, and the covariance stays symmetric
//! positive definite and the state finite.

use ego_ekf::covariance::is_positive_definite;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig, FlowConfig};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use vslam_core::Timestamp;
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, WheelRates};

#[derive(Clone, Debug)]
enum Event {
    Imu {
        step: i64,
        gyro: [f32; 3],
        accel: [f32; 3],
    },
    Wheel {
        step: i64,
        left: f32,
        right: f32,
    },
    Flow {
        step: i64,
        dx: i16,
        dy: i16,
        squal: u8,
        shutter: u16,
    },
}

fn float(range: f32) -> impl Strategy<Value = f32> {
    prop_oneof![
        8 => -range..range,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(1e30f32),
    ]
}

fn step() -> impl Strategy<Value = i64> {
    prop_oneof![
        8 => 1_000_000i64..20_000_000,
        1 => Just(0i64),
        1 => -10_000_000i64..0,
        1 => 20_000_000i64..2_000_000_000,
    ]
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        6 => (step(), [float(5.0), float(5.0), float(5.0)], [float(20.0), float(20.0), float(30.0)])
            .prop_map(|(step, gyro, accel)| Event::Imu { step, gyro, accel }),
        2 => (step(), float(30.0), float(30.0))
            .prop_map(|(step, left, right)| Event::Wheel { step, left, right }),
        2 => (step(), any::<i16>(), any::<i16>(), any::<u8>(), any::<u16>())
            .prop_map(|(step, dx, dy, squal, shutter)| Event::Flow { step, dx, dy, squal, shutter }),
    ]
}

fn advance(t: &mut i64, step: i64) -> Timestamp {
    *t = (*t + step).max(0);
    Timestamp(*t as u64)
}

#[test]
fn covariance_stays_positive_definite_under_random_samples() {
    let optics = FlowOptics::new(500.0, 0.03, Extrinsics::identity()).unwrap();
    let config = FilterConfig {
        flow: Some(FlowConfig::new(optics)),
        ..FilterConfig::default()
    };
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: 96,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]),
    );
    runner
        .run(&proptest::collection::vec(event(), 1..300), |events| {
            let mut f = EgoEkf::new(config).unwrap();
            let mut t = 1_000_000_000i64;
            f.start(&ExplicitStart::at_rest(Timestamp(t as u64)))
                .unwrap();
            let (mut imu, mut wheel, mut flow) = (0u32, 0u32, 0u32);
            for e in &events {
                match *e {
                    Event::Imu { step, gyro, accel } => {
                        let ts = advance(&mut t, step);
                        // Non-finite readings never become samples.
                        if let Ok(s) = ImuSample::new(ts, gyro, accel) {
                            imu += 1;
                            let _ = f.propagate(&s);
                        }
                    }
                    Event::Wheel { step, left, right } => {
                        let ts = advance(&mut t, step);
                        // Non-finite rates cannot be built; the others are offered.
                        if let Ok(w) = WheelRates::new(ts, left, right) {
                            wheel += 1;
                            let _ = f.fuse_wheel(&w);
                        }
                    }
                    Event::Flow {
                        step,
                        dx,
                        dy,
                        squal,
                        shutter,
                    } => {
                        let ts = advance(&mut t, step);
                        flow += 1;
                        let s = FlowSample {
                            t: ts,
                            dx,
                            dy,
                            squal,
                            shutter,
                            motion: true,
                            ..FlowSample::default()
                        };
                        let _ = f.fuse_flow(&s);
                    }
                }
                prop_assert!(f.state().is_finite());
            }
            prop_assert_eq!(f.imu_counts().seen(), imu);
            prop_assert_eq!(f.wheel_counts().seen(), wheel);
            prop_assert_eq!(f.flow_counts().seen(), flow);
            let p = f.covariance();
            prop_assert!((p - p.transpose()).abs().max() == 0.0);
            prop_assert!(is_positive_definite(p), "{:?}", p.diagonal());
            Ok(())
        })
        .unwrap();
}
