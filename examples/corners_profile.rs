//! The corner detector alone in a plain loop, for instruction counts: the
//! three committed photographs, centre crops of 320x240 and 160x120, default
//! settings (200 corners, as the front end asks). Prints what it found (a
//! checksum to compare two builds) and the median wall time per call.
//!
//! Instructions per round: run `valgrind --tool=callgrind` on
//! `target/release/examples/corners_profile 0` and `... corners_profile 10`
//! and divide the difference by 10 (loading and cropping cancel out).
//! Usage: `corners_profile [ROUNDS]` (default 20).

use std::hint::black_box;

use test_support::images::{Gray, load, median};
use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};

/// `g` as the library's image view.
fn view(g: &Gray) -> vslam_core::image::ImageView<'_> {
    vslam_core::image::ImageView::packed(&g.data, g.width, g.height).unwrap()
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let mut images = Vec::new();
    for name in ["camera.png", "brick.png", "gravel.png"] {
        let photo = load(name);
        images.push((name, photo.crop_centre(320, 240)));
        images.push((name, photo.crop_centre(160, 120)));
    }
    let config = CornerConfig::default();
    let mut scratch = vec![0f32; scratch_len(320, 240, config.block_size)];
    let mut out = [Corner::default(); 200];
    let mut times = Vec::with_capacity(rounds * images.len());
    for _ in 0..rounds {
        for (_, image) in &images {
            let start = std::time::Instant::now();
            black_box(
                detect_corners(black_box(&view(image)), &config, &mut scratch, &mut out).unwrap(),
            );
            times.push(start.elapsed().as_secs_f64() * 1e6);
        }
    }
    for (name, image) in &images {
        let n = detect_corners(&view(image), &config, &mut scratch, &mut out).unwrap();
        let sum: f64 = out[..n]
            .iter()
            .map(|c| (c.x * 7 + c.y * 13) as f64 + f64::from(c.response))
            .sum();
        println!(
            "{name} {}x{}: {n} corners, checksum {sum:.3}, first {:?}",
            image.width,
            image.height,
            out.first()
        );
    }
    println!(
        "{rounds} rounds, median {:.1} us per call",
        median(&mut times)
    );
}
