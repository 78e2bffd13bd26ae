//! Property tests (seeded): no input panics, and what comes out is valid.

use ego_ekf::GripParams;
use ego_ekf::events::{JoltConfig, JoltContext, JoltMonitor};
use ego_ekf::surface::{
    ClassConfig, ClassRole, GroundCamera, LearningConfig, NoiseLearner, SegmentationConfig,
    SurfaceConfig, SurfaceKind, SurfaceMix, SurfaceModel, TrackerConfig, WheelType,
};
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, RngSeed};
use vslam_core::Timestamp;
use vslam_core::image::LabelView;

fn config() -> Config {
    Config {
        cases: 256,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x7472_6163_7469_6f6e),
        failure_persistence: Some(Box::new(FileFailurePersistence::Off)),
        ..Config::default()
    }
}

/// A grip parameter set is valid if its own checked constructor accepts it.
fn valid(p: &GripParams) -> bool {
    GripParams::new(
        p.grip(),
        p.forward_std(),
        p.lateral_std(),
        p.forward_gate(),
        p.jolt_threshold(),
    )
    .is_ok()
}

fn role() -> impl Strategy<Value = ClassRole> {
    prop_oneof![
        Just(ClassRole::Unknown),
        Just(ClassRole::NotGround),
        (0usize..SurfaceKind::COUNT)
            .prop_map(|i| ClassRole::Ground(SurfaceKind::from_index(i).unwrap())),
    ]
}

fn wheel() -> impl Strategy<Value = WheelType> {
    (0usize..WheelType::COUNT).prop_map(|i| WheelType::from_index(i).unwrap())
}

/// Any f32, with the awkward ones often.
fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(0.0f32),
        Just(f32::MAX),
        Just(f32::MIN_POSITIVE),
        -100.0f32..100.0,
        any::<f32>(),
    ]
}

/// A label map: width, height, stride padding, the bytes, roles of ids 0..24.
fn label_case() -> impl Strategy<Value = (usize, usize, usize, Vec<u8>, Vec<ClassRole>)> {
    (1usize..48, 1usize..48, 0usize..4).prop_flat_map(|(w, h, pad)| {
        let stride = w + pad;
        let len = stride * (h - 1) + w;
        (
            Just(w),
            Just(h),
            Just(stride),
            prop::collection::vec(prop_oneof![0u8..24, any::<u8>()], len..=len),
            prop::collection::vec(role(), 24),
        )
    })
}

fn seg_config() -> impl Strategy<Value = SegmentationConfig> {
    (
        any_f32(),
        any_f32(),
        any_f32(),
        any_f32(),
        any_f32(),
        any_f32(),
    )
        .prop_map(|(a, b, c, d, e, f)| {
            SegmentationConfig::new(a, b, c, d, e, f).unwrap_or_default()
        })
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn any_label_map_gives_valid_fractions_or_a_status(
        (w, h, stride, data, roles) in label_case(),
        seg in seg_config(),
        wheel in wheel(),
        speed in any_f32(),
        t_ns in 0u64..u64::MAX / 2,
    ) {
        let mut classes = ClassConfig::new();
        for (id, r) in roles.iter().enumerate() {
            classes.set(id as u8, *r);
        }
        let labels = LabelView::new(&data, w, h, stride).unwrap();
        let mut cfg = SurfaceConfig::new(wheel, classes);
        cfg.segmentation = seg;
        let mut model = SurfaceModel::new(cfg);
        let t = Timestamp(t_ns);
        if let Ok(v) = model.on_segmentation(t, &labels, speed) {
            for m in [Some(v.mix), v.near, v.ahead, Some(v.present_mix())].into_iter().flatten() {
                let sum: f32 = m.fractions().iter().sum();
                prop_assert!((sum - 1.0).abs() < 1e-4);
                prop_assert!(m.fractions().iter().all(|f| f.is_finite() && *f >= 0.0));
            }
            prop_assert!(v.coverage > 0.0 && v.coverage <= 1.0);
            if let Some(u) = v.upcoming {
                prop_assert!(u.row_fraction > 0.0 && u.row_fraction <= 1.0);
                prop_assert!(u.fraction > 0.0 && u.fraction <= 1.0 + 1e-6);
            }
        }
        for dt in [0u64, 1, 1_000_000_000, 100_000_000_000] {
            let tq = Timestamp(t_ns.saturating_add(dt));
            prop_assert!(valid(&model.grip_params(tq)));
            let ctx = model.jolt_context(tq, speed);
            prop_assert!(ctx.jolt_threshold.is_finite() && ctx.jolt_threshold > 0.0);
            prop_assert!(ctx.strip_threshold >= ctx.jolt_threshold);
        }
    }

    #[test]
    fn grip_params_are_always_valid(
        weights in prop::array::uniform5(any_f32()),
        multipliers in prop::array::uniform5(any_f32()),
        wheel in wheel(),
        w in any_f32(),
    ) {
        let table = ego_ekf::surface::GripTable::default();
        let mix = SurfaceMix::from_weights(&weights).unwrap_or(SurfaceMix::pure(SurfaceKind::Wood));
        let p = table.blended(&mix, wheel, &multipliers);
        prop_assert!(valid(&p));
        let q = ego_ekf::surface::lerp_params(&p, &SurfaceConfig::conservative_params(), w);
        prop_assert!(valid(&q));
        let b = mix.blend(&SurfaceMix::pure(SurfaceKind::Carpet), w);
        prop_assert!((b.fractions().iter().sum::<f32>() - 1.0).abs() < 1e-4);
    }

    #[test]
    fn random_jolt_streams_never_panic_and_are_all_accounted(
        samples in prop::collection::vec((0u64..20_000_000, any_f32(), any::<bool>()), 1..400),
        threshold in any_f32(),
        strip in any_f32(),
        speed in any_f32(),
        crossing in prop::option::of(0u64..2_000_000_000),
    ) {
        let mut m = JoltMonitor::<4>::new(JoltConfig::default());
        let ctx = JoltContext {
            jolt_threshold: threshold,
            floor_jolt_threshold: threshold,
            strip_threshold: strip,
            surface: None,
            last_crossing: crossing.map(Timestamp),
            next_crossing: None,
            forward_speed: speed,
        };
        let mut t = 1_000_000u64;
        let mut pushed = 0u32;
        let mut events = 0u32;
        for (step, v, back) in samples {
            // Sometimes step backwards or repeat the time stamp.
            t = if back { t.saturating_sub(step) } else { t.saturating_add(step) };
            pushed += 1;
            if let Ok(Some(e)) = m.push(Timestamp(t), v, &ctx) {
                events += 1;
                prop_assert!(e.magnitude.is_finite() && e.magnitude >= 0.0);
                prop_assert!(e.onset <= e.t);
            }
        }
        prop_assert_eq!(m.detector().samples().seen(), pushed);
        prop_assert_eq!(m.counters().total(), events);
        prop_assert!(m.events().count() <= 4);
        prop_assert_eq!(m.events().count() as u32 + m.dropped(), events);
    }

    #[test]
    fn learner_stays_bounded_on_any_stream(
        stream in prop::collection::vec((any_f32(), any_f32(), any::<bool>()), 1..600),
        weights in prop::array::uniform5(0.0f32..1.0),
        bytes in prop::collection::vec(any::<u8>(), 0..100),
    ) {
        let cfg = LearningConfig::new(0.99, 0.05, 5.0, 0.5, 3.0, 25.0, 0.2).unwrap();
        let mut l = NoiseLearner::new(cfg, WheelType::SoftTreaded);
        let mix = SurfaceMix::from_weights(&weights).unwrap_or(SurfaceMix::pure(SurfaceKind::Tile));
        for (nu, var, gated) in stream {
            let _ = l.observe(&mix, nu, var, gated);
            for m in l.multipliers() {
                prop_assert!((0.5..=3.0).contains(&m));
            }
        }
        let before = l;
        if l.restore(&bytes).is_err() {
            prop_assert_eq!(l, before);
        }
        let mut fresh = NoiseLearner::new(cfg, WheelType::SoftTreaded);
        prop_assert!(fresh.restore(&l.to_bytes()).is_ok());
        for m in fresh.multipliers() {
            prop_assert!((0.5..=3.0).contains(&m));
        }
    }

    #[test]
    fn camera_geometry_never_panics(
        p in prop::array::uniform6(any_f32()),
        row in any_f32(),
    ) {
        if let Ok(cam) = GroundCamera::new(p[0], p[1], p[2], p[3], p[4], p[5])
            && let Some(d) = cam.ground_distance(row)
        {
            prop_assert!(d.is_finite());
        }
    }

    #[test]
    fn tracker_times_in_any_order(
        times in prop::collection::vec(any::<u64>(), 1..20),
        speeds in prop::collection::vec(any_f32(), 20),
    ) {
        let classes = ClassConfig::from_lists(&[(1, SurfaceKind::Wood), (2, SurfaceKind::Carpet)], &[]);
        let mut cfg = SurfaceConfig::new(WheelType::Omni, classes);
        cfg.tracker = TrackerConfig::new(u64::MAX, 0, u64::MAX, 1e-6, u64::MAX).unwrap();
        let mut model = SurfaceModel::new(cfg);
        let data: Vec<u8> = (0..24 * 12).map(|i| if i < 24 * 8 { 2 } else { 1 }).collect();
        let labels = LabelView::new(&data, 24, 12, 24).unwrap();
        for (t, v) in times.iter().zip(speeds.iter()) {
            let _ = model.on_segmentation(Timestamp(*t), &labels, *v);
            prop_assert!(valid(&model.grip_params(Timestamp(*t))));
            prop_assert!(valid(&model.grip_params(Timestamp(t.wrapping_mul(3)))));
        }
    }
}
