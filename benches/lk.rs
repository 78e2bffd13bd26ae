//! Pyramidal Lucas-Kanade on a 320x240 crop of `camera.png` warped by a small
//! known homography: 100 Shi-Tomasi corners, 21x21 window, 3 levels (the
//! setting OpenCV's `calcOpticalFlowPyrLK` is usually quoted at, ~1 ms).
//! Loading, warping, pyramids and corners are built outside the timer; the
//! pyramid build and the corner detection have their own benches, and
//! `lk_with_pyramids` times what `cv2.calcOpticalFlowPyrLK` does when handed
//! two images: both pyramids plus the tracking. Each bench reports the median
//! time of a single call (see `per_call_median`), the statistic the OpenCV
//! peer reports too.
//!
//! With `LK_PEER_DIR` set, the bench first writes its exact input there for
//! the OpenCV peer (`benches/peer/opencv_lk.py`, driven by
//! `benches/peer/run_lk_peer.sh`): `first.pgm`, `second.pgm`, `points.txt`
//! (corner `x y` and the ground-truth position `x y` under the homography,
//! f64), `config.txt` (window, levels, iterations, epsilon) and `ours.txt`
//! (our tracked position and status per corner).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use test_support::images::{Gray, Homography, load};
use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};
use vslam_core::geometry::Vec2;
use vslam_core::lk::{Illumination, LkConfig, TrackResult, Tracker};
use vslam_core::pyramid::{Pyramid, PyramidStorage, storage_bytes};

/// `g` as the library's image view.
fn view(g: &Gray) -> vslam_core::image::ImageView<'_> {
    vslam_core::image::ImageView::packed(&g.data, g.width, g.height).unwrap()
}

const W: usize = 320;
const H: usize = 240;
type Storage = PyramidStorage<{ storage_bytes(W, H, 3) }>;

fn bench(c: &mut Criterion) {
    let first = load("camera.png").crop_centre(W, H);
    let h = Homography::similarity_about(160.0, 120.0, 1.5, 1.01, 2.7, -1.9, 2e-5, -1.5e-5);
    let second = first.warp(&h);
    let (va, vb) = (view(&first), view(&second));

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
    if let Some(dir) = std::env::var_os("LK_PEER_DIR") {
        let tracker = Tracker::new(LkConfig::default()).unwrap();
        tracker.track(&pa, &pb, &points, &mut results).unwrap();
        peer::write(
            std::path::Path::new(&dir),
            &first,
            &second,
            &points,
            &h,
            &results,
        )
        .unwrap();
    }

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
            "lk/100_corners_21x21_3_levels_coarse_epsilon_0.04",
            LkConfig {
                coarse_epsilon: Some(0.04),
                ..LkConfig::default()
            },
        ),
        (
            "lk/100_corners_21x21_3_levels_gain_bias",
            LkConfig {
                illumination: Illumination::GAIN_BIAS,
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
            bench.iter_custom(|iters| {
                per_call_median(iters, || {
                    tracker
                        .track(
                            black_box(&pa),
                            black_box(&pb),
                            black_box(&points),
                            &mut results,
                        )
                        .unwrap()
                })
            })
        });
    }

    // What OpenCV's calcOpticalFlowPyrLK does with two images: both pyramids
    // and the tracking (the front end builds only the new frame's pyramid).
    let tracker = Tracker::new(LkConfig::default()).unwrap();
    let (mut qa, mut qb) = (Box::new(Storage::new()), Box::new(Storage::new()));
    c.bench_function("lk/100_corners_21x21_3_levels_with_pyramids", |bench| {
        bench.iter_custom(|iters| {
            per_call_median(iters, || {
                let pa = Pyramid::build(black_box(&va), 3, &mut qa).unwrap();
                let pb = Pyramid::build(black_box(&vb), 3, &mut qb).unwrap();
                tracker
                    .track(&pa, &pb, black_box(&points), &mut results)
                    .unwrap()
            })
        })
    });

    let mut storage = Box::new(Storage::new());
    c.bench_function("pyramid/build_320x240_3_levels", |bench| {
        bench.iter_custom(|iters| {
            per_call_median(iters, || {
                Pyramid::build(black_box(&va), 3, &mut storage)
                    .map(|p| p.levels())
                    .unwrap()
            })
        })
    });

    let mut out = [Corner::default(); 100];
    c.bench_function("corners/shi_tomasi_320x240_100", |bench| {
        bench.iter_custom(|iters| {
            per_call_median(iters, || {
                detect_corners(black_box(&va), &corner_config, &mut scratch, &mut out).unwrap()
            })
        })
    });
}

/// Times each of `iters` calls of `f` alone and reports `iters` times the
/// median: criterion then shows the median time of one call. On this shared
/// machine (load ~10 on 2 cores) a sample of many back-to-back calls also
/// counts the time the process waits for a core, which inflates criterion's
/// usual mean by several times; a single call of ~1 ms mostly runs
/// uninterrupted, so its median is the figure to compare, and the OpenCV peer
/// reports the same statistic.
fn per_call_median<T>(iters: u64, mut f: impl FnMut() -> T) -> std::time::Duration {
    let mut times: Vec<std::time::Duration> = (0..iters)
        .map(|_| {
            let start = std::time::Instant::now();
            black_box(f());
            start.elapsed()
        })
        .collect();
    times.sort_unstable();
    let median = times.get(times.len() / 2).copied().unwrap_or_default();
    median * u32::try_from(iters).unwrap_or(u32::MAX)
}

/// The input files of the OpenCV peer.
mod peer {
    use std::io::Write;
    use std::path::Path;

    use test_support::images::{Gray, Homography};
    use vslam_core::geometry::Vec2;
    use vslam_core::lk::{LkConfig, TrackResult};

    fn pgm(path: &Path, img: &Gray) -> std::io::Result<()> {
        let mut f = std::fs::File::create(path)?;
        write!(f, "P5\n{} {}\n255\n", img.width, img.height)?;
        f.write_all(&img.data)
    }

    pub fn write(
        dir: &Path,
        first: &Gray,
        second: &Gray,
        points: &[Vec2],
        h: &Homography,
        ours: &[TrackResult],
    ) -> std::io::Result<()> {
        std::fs::create_dir_all(dir)?;
        pgm(&dir.join("first.pgm"), first)?;
        pgm(&dir.join("second.pgm"), second)?;
        let mut f = std::fs::File::create(dir.join("points.txt"))?;
        for p in points {
            let (gx, gy) = h.apply(f64::from(p.x), f64::from(p.y));
            writeln!(f, "{} {} {gx:.9} {gy:.9}", p.x, p.y)?;
        }
        let c = LkConfig::default();
        let mut f = std::fs::File::create(dir.join("config.txt"))?;
        writeln!(
            f,
            "window {}\nlevels {}\nmax_iterations {}\nepsilon {}",
            c.window, c.levels, c.max_iterations, c.epsilon
        )?;
        let mut f = std::fs::File::create(dir.join("ours.txt"))?;
        for r in ours {
            writeln!(
                f,
                "{} {} {}",
                r.position.x,
                r.position.y,
                u8::from(r.is_tracked())
            )?;
        }
        Ok(())
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
