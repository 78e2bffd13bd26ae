//! Seeded properties: no input makes the pyramid, the corner detector or the
//! tracker panic, and whatever is reported tracked is finite.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};
use vslam_core::geometry::Vec2;
use vslam_core::image::ImageView;
use vslam_core::lk::{Illumination, LkConfig, TrackResult, Tracker};
use vslam_core::pyramid::{Pyramid, PyramidStorage};

fn config() -> Config {
    Config {
        cases: 96,
        rng_seed: RngSeed::Fixed(0x1c_2025),
        failure_persistence: None,
        ..Config::default()
    }
}

/// An image of 1..=48 pixels a side with random content (textured or flat).
fn image() -> impl Strategy<Value = (usize, usize, Vec<u8>)> {
    (1usize..=48, 1usize..=48, any::<bool>(), any::<u64>()).prop_map(|(w, h, flat, seed)| {
        let mut s = seed | 1;
        let data = (0..w * h)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                if flat { 77 } else { (s >> 24) as u8 }
            })
            .collect();
        (w, h, data)
    })
}

fn coordinate() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => -5.0f32..60.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(1e30f32),
        1 => Just(-3e9f32),
        1 => any::<f32>(),
    ]
}

fn point() -> impl Strategy<Value = Vec2> {
    (coordinate(), coordinate()).prop_map(|(x, y)| Vec2::new(x, y))
}

fn lk_config() -> impl Strategy<Value = LkConfig> {
    (
        1usize..=15,
        1usize..=4,
        1u32..=12,
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
    )
        .prop_map(
            |(half, levels, max_iterations, fb, affine_refinement, gain_bias)| LkConfig {
                window: 2 * half + 1,
                levels,
                max_iterations,
                fb_threshold: fb.then_some(0.7),
                affine_refinement,
                illumination: if gain_bias {
                    Illumination::GAIN_BIAS
                } else {
                    Illumination::Constant
                },
                ..LkConfig::default()
            },
        )
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn tracking_never_panics_and_tracked_points_are_finite(
        (w, h, a) in image(),
        b_seed in any::<u8>(),
        config in lk_config(),
        points in proptest::collection::vec(point(), 0..8),
        guess in point(),
    ) {
        // The second frame: the first with a few bytes changed.
        let mut b = a.clone();
        for (i, v) in b.iter_mut().enumerate() {
            if (i as u8).wrapping_mul(31) == b_seed {
                *v = v.wrapping_add(b_seed);
            }
        }
        let va = ImageView::packed(&a, w, h).unwrap();
        let vb = ImageView::packed(&b, w, h).unwrap();
        let levels = config.levels.min(Pyramid::max_levels(w, h));
        let (mut sa, mut sb) = (PyramidStorage::<2048>::new(), PyramidStorage::<2048>::new());
        let pa = Pyramid::build(&va, levels, &mut sa).unwrap();
        let pb = Pyramid::build(&vb, levels, &mut sb).unwrap();
        let tracker = Tracker::new(config).unwrap();
        let mut out = vec![TrackResult::EMPTY; points.len()];
        let counts = tracker.track(&pa, &pb, &points, &mut out).unwrap();
        prop_assert_eq!(counts.tracked + counts.lost_total(), points.len());
        for r in &out {
            if r.is_tracked() {
                prop_assert!(r.position.x.is_finite() && r.position.y.is_finite(), "{:?}", r);
                prop_assert!(r.residual.is_finite() && r.residual <= config.max_residual, "{:?}", r);
                prop_assert!(r.position.x >= 0.0 && r.position.x <= (w - 1) as f32, "{:?}", r);
                prop_assert!(r.position.y >= 0.0 && r.position.y <= (h - 1) as f32, "{:?}", r);
            }
        }
        if let Some(p) = points.first() {
            let r = tracker.track_point(&pa, &pb, *p, Some(guess)).unwrap();
            if r.is_tracked() {
                prop_assert!(r.position.x.is_finite() && r.position.y.is_finite());
            }
        }
    }

    #[test]
    fn pyramids_and_corners_never_panic(
        (w, h, data) in image(),
        levels in 0usize..=9,
        block in prop_oneof![Just(3usize), Just(5), Just(7), Just(4)],
        quality in prop_oneof![Just(0.01f32), Just(0.5), Just(1.0), Just(0.0), Just(f32::NAN)],
        min_distance in prop_oneof![Just(0.0f32), Just(3.0), Just(10.0), Just(-1.0)],
        border in 0usize..30,
        capacity in 0usize..20,
    ) {
        let img = ImageView::packed(&data, w, h).unwrap();
        let mut st = PyramidStorage::<1500>::new();
        match Pyramid::build(&img, levels, &mut st) {
            Ok(p) => {
                prop_assert_eq!(p.levels(), levels);
                prop_assert!(levels <= Pyramid::max_levels(w, h));
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
        let cfg = CornerConfig { quality_level: quality, min_distance, block_size: block, border, min_response: 1.0 };
        let mut scratch = vec![0f32; scratch_len(w, h, block)];
        let mut out = vec![Corner::default(); capacity];
        if let Ok(n) = detect_corners(&img, &cfg, &mut scratch, &mut out) {
            prop_assert!(n <= capacity);
            let found = &out[..n];
            for c in found {
                prop_assert!(c.x >= border && c.x + border < w && c.y >= border && c.y + border < h);
                prop_assert!(c.response.is_finite() && c.response >= cfg.min_response);
            }
            for (i, a) in found.iter().enumerate() {
                if let Some(b) = found.get(i + 1) {
                    prop_assert!(a.response >= b.response);
                }
                for b in &found[i + 1..] {
                    let d = (a.position() - b.position()).norm();
                    prop_assert!(d >= min_distance, "{:?} {:?}", a, b);
                }
            }
        } else {
            prop_assert!(cfg.validate().is_err());
        }
    }
}
