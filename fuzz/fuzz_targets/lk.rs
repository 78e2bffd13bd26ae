//! Pyramidal Lucas-Kanade (and the pyramid and Shi-Tomasi corners it sits
//! on) on small random image pairs: sizes, settings, points and guesses all
//! come from the fuzzer. Every point ends in exactly one count; a tracked
//! point is finite and inside the image. The shift byte's two top bits both
//! set pick the gain-bias illumination model (and then relight the second
//! image to half the contrast, 64 levels brighter, the change that model is
//! for); the point count byte's top bit picks its residual limit.
#![no_main]

use libfuzzer_sys::fuzz_target;
use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};
use vslam_core::geometry::Vec2;
use vslam_core::image::ImageView;
use vslam_core::lk::{Illumination, LkConfig, TrackResult, Tracker};
use vslam_core::pyramid::{Pyramid, storage_bytes};

const MAX_SIDE: usize = 48;

fuzz_target!(|data: &[u8]| {
    let Some((head, rest)) = data.split_first_chunk::<8>() else {
        return;
    };
    let [sw, sh, win, lev, iters, flags, npts, shift] = *head;
    let w = 4 + usize::from(sw) % (MAX_SIDE - 3);
    let h = 4 + usize::from(sh) % (MAX_SIDE - 3);
    let n = w * h;
    // Image 1 from the bytes (cycled); image 2 is image 1 shifted by a
    // fuzzed offset with fuzzed noise, or fully fuzzed.
    let Some((pixels, rest)) = rest.split_at_checked(rest.len().min(n)) else {
        return;
    };
    if pixels.is_empty() {
        return;
    }
    let img1: Vec<u8> = pixels.iter().copied().cycle().take(n).collect();
    let (dx, dy) = (usize::from(shift & 7), usize::from(shift >> 3 & 7));
    let gain_bias = shift & 0xc0 == 0xc0;
    let img2: Vec<u8> = (0..n)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut src = img1[((y + dy) % h) * w + (x + dx) % w];
            if gain_bias {
                src = src / 2 + 64;
            }
            if flags & 0x40 != 0 {
                src.wrapping_add(rest.get(i).copied().unwrap_or(0) & 7)
            } else {
                src
            }
        })
        .collect();
    let (Ok(v1), Ok(v2)) = (
        ImageView::packed(&img1, w, h),
        ImageView::packed(&img2, w, h),
    ) else {
        return;
    };
    let max_levels = Pyramid::max_levels(w, h);
    let levels = 1 + usize::from(lev) % max_levels.max(1);
    let mut s1 = vec![0u8; storage_bytes(w, h, levels)];
    let mut s2 = vec![0u8; storage_bytes(w, h, levels)];
    let (Ok(p1), Ok(p2)) = (
        Pyramid::build_in(&v1, levels, &mut s1),
        Pyramid::build_in(&v2, levels, &mut s2),
    ) else {
        return;
    };
    assert_eq!(p1.levels(), levels);

    let corner_config = CornerConfig {
        block_size: [3, 5, 7][usize::from(flags & 3) % 3],
        border: usize::from(flags >> 2 & 7),
        min_distance: f32::from(flags >> 5),
        ..CornerConfig::default()
    };
    let mut scratch = vec![0f32; scratch_len(w, h, corner_config.block_size)];
    let mut corners = [Corner::default(); 16];
    let found = detect_corners(&v1, &corner_config, &mut scratch, &mut corners).unwrap_or(0);
    assert!(found <= corners.len());
    for c in &corners[..found] {
        assert!(c.x < w && c.y < h && c.response.is_finite());
    }

    let config = LkConfig {
        window: 3 + 2 * (usize::from(win) % 15),
        levels: 1 + usize::from(lev >> 4) % 4,
        max_iterations: 1 + u32::from(iters) % 30,
        affine_refinement: flags & 0x80 != 0,
        fb_threshold: (iters & 0x80 != 0).then_some(1.0),
        illumination: if gain_bias {
            Illumination::GainBias {
                max_residual: if npts & 0x80 != 0 { 2.0 } else { 0.5 },
            }
        } else {
            Illumination::Constant
        },
        ..LkConfig::default()
    };
    let Ok(tracker) = Tracker::new(config) else {
        return;
    };
    // Points: the corners, then fuzzed ones (raw f32 bits: NaN and
    // infinities included), with guesses.
    let tail = rest.get(n.min(rest.len())..).unwrap_or(&[]);
    let mut points: Vec<Vec2> = corners[..found].iter().map(Corner::position).collect();
    let fuzzed: Vec<f32> = tail
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    points.extend(
        fuzzed
            .chunks_exact(2)
            .take(usize::from(npts) % 16)
            .map(|c| Vec2::new(c[0], c[1])),
    );
    let guesses: Vec<Vec2> = points
        .iter()
        .map(|p| p + Vec2::new(-(dx as f32), -(dy as f32)))
        .collect();
    let mut results = vec![TrackResult::EMPTY; points.len()];
    for with_guesses in [false, true] {
        let counts = if with_guesses {
            tracker.track_with_guesses(&p1, &p2, &points, &guesses, &mut results)
        } else {
            tracker.track(&p1, &p2, &points, &mut results)
        };
        let Ok(counts) = counts else {
            panic!("sizes are right: {counts:?}");
        };
        assert_eq!(counts.tracked + counts.lost_total(), points.len());
        for r in &results {
            if r.is_tracked() {
                let p = r.position;
                assert!(p.x.is_finite() && p.y.is_finite(), "{r:?}");
                assert!(
                    p.x >= -1.0 && p.y >= -1.0 && p.x <= w as f32 && p.y <= h as f32,
                    "{r:?} in {w}x{h}"
                );
                assert!(r.residual.is_finite());
            }
        }
    }
});
