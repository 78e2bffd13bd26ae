//! The `lk` bench's workload in a plain loop, for instruction counts:
//! `valgrind --tool=callgrind --toggle-collect='*Tracker*track*' target/release/examples/lk_profile`
//! (tracking) or `--toggle-collect='*Pyramid*build*'` (pyramids). Prints the
//! median endpoint error against the ground-truth homography and the median
//! wall time of one tracking call (a rough figure; the criterion bench is the
//! measurement).
//! Usage: `lk_profile [ROUNDS [REPEATS [COARSE_EPSILON [gain-bias]]]]`
//! (default 20 rounds of 1 tracking call, `LkConfig::default()`; a third
//! argument sets `LkConfig::coarse_epsilon` (`-` for none), a fourth
//! `gain-bias` the `Illumination::GAIN_BIAS` model).

use std::hint::black_box;

use test_support::images::{Gray, Homography, load, median};
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

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let repeat: usize = std::env::args()
        .nth(2)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1);
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
    let points: Vec<Vec2> = corners[..n].iter().map(Corner::position).collect();
    let (mut sa, mut sb) = (Box::new(Storage::new()), Box::new(Storage::new()));
    let mut results = vec![TrackResult::EMPTY; n];
    let coarse_epsilon = std::env::args().nth(3).and_then(|a| a.parse().ok());
    let illumination = match std::env::args().nth(4).as_deref() {
        Some("gain-bias") => Illumination::GAIN_BIAS,
        _ => Illumination::Constant,
    };
    let tracker = Tracker::new(LkConfig {
        coarse_epsilon,
        illumination,
        ..LkConfig::default()
    })
    .unwrap();
    let mut iterations = 0;
    let mut times = Vec::with_capacity(rounds * repeat);
    for _ in 0..rounds {
        let pa = Pyramid::build(black_box(&va), 3, &mut sa).unwrap();
        let pb = Pyramid::build(black_box(&vb), 3, &mut sb).unwrap();
        for _ in 0..repeat {
            let start = std::time::Instant::now();
            black_box(tracker.track(&pa, &pb, &points, &mut results).unwrap());
            times.push(start.elapsed().as_secs_f64() * 1e6);
        }
        iterations = results.iter().map(|r| r.iterations).sum::<u32>();
    }
    let median_us = median(&mut times);
    let mut errors: Vec<f64> = points
        .iter()
        .zip(&results)
        .filter(|(_, r)| r.is_tracked())
        .map(|(p, r)| {
            let (x, y) = h.apply(f64::from(p.x), f64::from(p.y));
            (f64::from(r.position.x) - x).hypot(f64::from(r.position.y) - y)
        })
        .collect();
    let tracked = errors.len();
    println!(
        "{rounds} rounds, tracking median {median_us:.1} us, {tracked}/{n} tracked, median endpoint error {:.4} px, mean {:.4} px, level-0 iterations {iterations}",
        median(&mut errors),
        errors.iter().sum::<f64>() / tracked.max(1) as f64
    );
}
