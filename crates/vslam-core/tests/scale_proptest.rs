//! Properties: whenever a scale is produced it is positive and finite; no
//! input panics (random transactions and samples including NaN, Inf, zero,
//! huge and out-of-order values).

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use vslam_core::Timestamp;
use vslam_core::adverse::{AdverseKind, AdverseMemory, AdverseParams, SensorKind};
use vslam_core::geometry::{Extrinsics, Rot3, Vec2, Vec3};
use vslam_core::scale::raw_flow::{FeatureMotion, RawFlowOptics};
use vslam_core::scale::robust::RobustEstimate;
use vslam_core::scale::select::{SelectParams, SelectionInput, SelectionMethod, select};
use vslam_core::scale::slip::{SlipEvidence, SlipParams, assess};
use vslam_core::scale::{CameraMotion, PipelineConfig, ScalePipeline, Transaction};
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, OdometryDelta};

fn wild() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(0.0f32),
        Just(-0.0f32),
        Just(f32::MAX),
        Just(f32::MIN_POSITIVE),
        Just(1e-30f32),
        Just(-1.0f32),
        any::<f32>(),
        0.0f32..5.0,
        0.0f32..5.0,
        0.0f32..0.1,
    ]
}

fn transaction() -> impl Strategy<Value = Transaction> {
    (wild(), wild(), wild(), wild()).prop_map(|(metres, variance, confidence, coverage)| {
        Transaction {
            metres,
            variance,
            confidence,
            coverage,
        }
    })
}

const METHODS: [SelectionMethod; 7] = [
    SelectionMethod::SlipThreshold,
    SelectionMethod::Outlier,
    SelectionMethod::SourceConfidence,
    SelectionMethod::ScaleConfidence,
    SelectionMethod::Fusion,
    SelectionMethod::WheelOnly,
    SelectionMethod::FlowOnly,
];

proptest! {
    #![proptest_config(ProptestConfig { rng_seed: RngSeed::Fixed(0x5CA1E), cases: 2048, ..ProptestConfig::default() })]

    #[test]
    fn selected_scale_is_positive_and_finite(
        baseline in wild(),
        cam in wild(),
        wheel in transaction(),
        flow in transaction(),
        slip_ev in (wild(), wild(), wild(), wild(), wild(), wild()),
        outlier in any::<bool>(),
        robust in proptest::option::of((wild(), wild(), any::<u16>())),
    ) {
        let slip = assess(&SlipEvidence {
            dt: slip_ev.0,
            wheel_path: slip_ev.1,
            wheel_yaw: slip_ev.2,
            wheel_accel: Some(slip_ev.3),
            wheel_discontinuities: 0,
            flow_path: slip_ev.4,
            flow_confidence: slip_ev.5,
            imu_yaw: Some(slip_ev.2 * 0.5),
            imu_accel: Some(slip_ev.3),
            camera_baseline: baseline,
            scale: Some(slip_ev.4),
        }, &SlipParams::default());
        prop_assert!(slip.amount >= 0.0);
        let input = SelectionInput {
            baseline,
            camera_confidence: cam,
            wheel,
            flow,
            slip,
            wheel_outlier: outlier,
            robust: robust.map(|(scale, sigma, count)| RobustEstimate { scale, sigma, count }),
        };
        for m in METHODS {
            if let Ok(e) = select(m, &input, &SelectParams::default()) {
                prop_assert!(e.scale.is_finite() && e.scale > 0.0, "{m:?} {e:?}");
                prop_assert!(e.variance.is_finite() && e.variance > 0.0, "{m:?} {e:?}");
            }
        }
    }
}

#[derive(Clone, Debug)]
enum Input {
    Imu(u64, [f32; 3], [f32; 3]),
    Wheel(u64, u64, [f32; 3], f32),
    Flow(u64, i16, i16, u8, u16),
    Raw(u64, u64, Vec<(f32, f32)>),
    Camera(u64, u64, [f32; 3], [f32; 3], u16, f32, f32),
}

fn time() -> impl Strategy<Value = u64> {
    prop_oneof![
        Just(0u64),
        Just(u64::MAX),
        0u64..5_000_000_000,
        0u64..5_000_000_000
    ]
}

fn input() -> impl Strategy<Value = Input> {
    let v3 = || [wild(), wild(), wild()];
    prop_oneof![
        (time(), v3(), v3()).prop_map(|(t, g, a)| Input::Imu(t, g, a)),
        (time(), time(), v3(), wild()).prop_map(|(a, b, d, y)| Input::Wheel(a, b, d, y)),
        (
            time(),
            any::<i16>(),
            any::<i16>(),
            any::<u8>(),
            any::<u16>()
        )
            .prop_map(|(t, x, y, q, s)| Input::Flow(t, x, y, q, s)),
        (
            time(),
            time(),
            proptest::collection::vec((wild(), wild()), 0..80)
        )
            .prop_map(|(a, b, f)| Input::Raw(a, b, f)),
        (time(), time(), v3(), v3(), any::<u16>(), wild(), wild())
            .prop_map(|(a, b, r, t, n, q, e)| Input::Camera(a, b, r, t, n, q, e)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { rng_seed: RngSeed::Fixed(0xF00D), cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn the_pipeline_never_panics_and_only_produces_good_scales(inputs in proptest::collection::vec(input(), 1..120)) {
        let optics = FlowOptics::new(500.0, 0.02, Extrinsics::new(Rot3::identity(), Vec3::new(0.1, 0.0, 0.0)).unwrap()).unwrap();
        let raw = RawFlowOptics::new(0.01, 0.02, Extrinsics::identity(), 3).unwrap();
        let config = PipelineConfig { flow_optics: Some(optics), ..PipelineConfig::default() };
        let mut p: ScalePipeline<4> = ScalePipeline::new(config).unwrap();
        for (k, i) in inputs.iter().enumerate() {
            if k % 17 == 0 {
                p.set_method(METHODS[k / 17 % METHODS.len()]);
            }
            match i {
                Input::Imu(t, g, a) => {
                    if let Ok(s) = ImuSample::new(Timestamp(*t), *g, *a) {
                        let _ = p.push_imu(&s);
                    }
                }
                Input::Wheel(a, b, d, y) => {
                    let translation = Vec3::from(*d);
                    let _ = p.push_wheel(&OdometryDelta {
                        t0: Timestamp(*a),
                        t1: Timestamp(*b),
                        translation,
                        dyaw: *y,
                        path_length: translation.norm(),
                    });
                }
                Input::Flow(t, dx, dy, squal, shutter) => {
                    let _ = p.push_flow(&FlowSample {
                        t: Timestamp(*t),
                        dx: *dx,
                        dy: *dy,
                        squal: *squal,
                        shutter: *shutter,
                        ..FlowSample::default()
                    });
                }
                Input::Raw(a, b, f) => {
                    let f: Vec<FeatureMotion> = f.iter().map(|(dx, dy)| FeatureMotion { dx: *dx, dy: *dy }).collect();
                    let _ = p.push_raw_flow(Timestamp(*a), Timestamp(*b), &f, &raw);
                }
                Input::Camera(a, b, r, t, n, q, e) => {
                    let rot = Rot3::from_euler_angles(r[0], r[1], r[2]);
                    let m = CameraMotion::new(Timestamp(*a), Timestamp(*b), rot, Vec3::from(*t), *n, *q, *e);
                    if let Ok(d) = m.map_err(|_| ()).and_then(|m| p.push_camera(&m).map_err(|_| ())) {
                        if let Ok(s) = d.scale {
                            prop_assert!(s.scale.is_finite() && s.scale > 0.0, "{d:?}");
                            prop_assert!(s.variance.is_finite() && s.variance > 0.0);
                        }
                        if let Some(s) = d.applied_scale {
                            prop_assert!(s.is_finite() && s > 0.0);
                        }
                    }
                }
            }
            let pose = p.body_pose();
            prop_assert!(pose.translation.vector.iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn adverse_records_never_panic_and_corruption_is_detected(
        bytes in proptest::collection::vec(any::<u8>(), 0..400),
        flip in any::<usize>(),
        xs in proptest::collection::vec((wild(), wild(), any::<u64>()), 0..20),
    ) {
        type M = AdverseMemory<4, 4>;
        let _ = M::restore(&bytes);
        let mut m = M::new(AdverseParams::default()).unwrap();
        for (x, y, t) in &xs {
            let _ = m.record(SensorKind::Flow, AdverseKind::Blank, &Vec2::new(*x, *y), Timestamp(*t));
            let w = m.weight(SensorKind::Flow, &Vec2::new(*x, *y), Timestamp(*t));
            prop_assert!((0.0..=1.0).contains(&w));
        }
        let mut buf = vec![0u8; M::RECORD_LEN];
        prop_assert_eq!(m.export(&mut buf), Ok(M::RECORD_LEN));
        let back = M::restore(&buf);
        prop_assert_eq!(back.as_ref(), Ok(&m));
        let i = flip % buf.len();
        buf[i] ^= 0x40;
        prop_assert!(M::restore(&buf).is_err());
    }
}
