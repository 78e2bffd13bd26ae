//! Pyramidal Lucas-Kanade on a 320x240 crop of `camera.png` warped by a small
//! known homography: 100 Shi-Tomasi corners, 21x21 window, 3 levels (the
//! setting OpenCV's `calcOpticalFlowPyrLK` is usually quoted at, ~1 ms).
//! Loading, warping, pyramids and corners are built outside the timer; the
//! pyramid build and the corner detection have their own benches.

#[path = "../crates/vslam-core/tests/lk_support/mod.rs"]
mod lk_support;

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use lk_support::{Homography, load};
use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};
use vslam_core::geometry::Vec2;
use vslam_core::lk::{LkConfig, TrackResult, Tracker};
use vslam_core::pyramid::{Pyramid, PyramidStorage, storage_bytes};

const W: usize = 320;
const H: usize = 240;
type Storage = PyramidStorage<{ storage_bytes(W, H, 3) }>;

fn bench(c: &mut Criterion) {
    let first = load("camera.png").crop_centre(W, H);
    let h = Homography::similarity_about(160.0, 120.0, 1.5, 1.01, 2.7, -1.9, 2e-5, -1.5e-5);
    let second = first.warp(&h);
    let (va, vb) = (first.view(), second.view());

    let corner_config = CornerConfig {
        min_distance: 8.0,
        border: 16,
        ..CornerConfig::default()
    };
    let mut scratch = vec![0f32; scratch_len(W, H, corner_config.block_size)];
    let mut corners = [Corner::default(); 100];
    let n = detect_corners(&va, &corner_config, &mut scratch, &mut corners).unwrap();
    assert_eq!(n, 100);
    let points: Vec<Vec2> = corners.iter().map(Corner::position).collect();

    let mut sa = Box::new(Storage::new());
    let mut sb = Box::new(Storage::new());
    let pa = Pyramid::build(&va, 3, &mut sa).unwrap();
    let pb = Pyramid::build(&vb, 3, &mut sb).unwrap();
    let mut results = vec![TrackResult::EMPTY; points.len()];

    let variants = [
        ("lk/100_corners_21x21_3_levels", LkConfig::default()),
        (
            "lk/100_corners_21x21_3_levels_forward_backward",
            LkConfig {
                fb_threshold: Some(0.5),
                ..LkConfig::default()
            },
        ),
        (
            "lk/100_corners_21x21_3_levels_affine",
            LkConfig {
                affine_refinement: true,
                ..LkConfig::default()
            },
        ),
    ];
    for (name, config) in variants {
        let tracker = Tracker::new(config).unwrap();
        let counts = tracker.track(&pa, &pb, &points, &mut results).unwrap();
        assert!(counts.tracked >= 95, "{name}: {counts:?}");
        c.bench_function(name, |bench| {
            bench.iter(|| {
                tracker
                    .track(
                        black_box(&pa),
                        black_box(&pb),
                        black_box(&points),
                        &mut results,
                    )
                    .unwrap()
            })
        });
    }

    let mut storage = Box::new(Storage::new());
    c.bench_function("pyramid/build_320x240_3_levels", |bench| {
        bench.iter(|| {
            Pyramid::build(black_box(&va), 3, &mut storage)
                .map(|p| p.levels())
                .unwrap()
        })
    });

    let mut out = [Corner::default(); 100];
    c.bench_function("corners/shi_tomasi_320x240_100", |bench| {
        bench.iter(|| {
            detect_corners(black_box(&va), &corner_config, &mut scratch, &mut out).unwrap()
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
