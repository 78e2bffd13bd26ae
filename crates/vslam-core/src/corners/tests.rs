//! The streaming detector against a plain whole-image implementation of the
//! same definition, and its edge cases.

extern crate std;

use std::vec;
use std::vec::Vec;

use proptest::prelude::*;

use super::*;

/// The definition written out directly: Sobel at every pixel, the block
/// sum of each pixel (exact column sums added left to right), a whole response image, the global
/// threshold, the 3x3 maximum test, then the greedy list in raster order.
fn reference(img: &ImageView<'_>, cfg: &CornerConfig, capacity: usize) -> Vec<Corner> {
    let (w, h) = (img.width(), img.height());
    let response = reference_response(img, cfg.block_size);
    let strongest = response.iter().copied().fold(0.0f32, f32::max);
    if !(strongest >= cfg.min_response && strongest > 0.0) {
        return Vec::new();
    }
    let threshold = (cfg.quality_level * strongest).max(cfg.min_response);
    let border = cfg.border.max(1);
    let md2 = cfg.min_distance * cfg.min_distance;
    let d2 = |a: &Corner, b: &Corner| {
        let (dx, dy) = (a.x as f32 - b.x as f32, a.y as f32 - b.y as f32);
        dx * dx + dy * dy
    };
    let mut list: Vec<Corner> = Vec::new();
    for y in border..h.saturating_sub(border) {
        for x in border..w.saturating_sub(border) {
            let v = response[y * w + x];
            let neighbours_not_above = (y - 1..=y + 1)
                .flat_map(|ny| (x - 1..=x + 1).map(move |nx| (nx, ny)))
                .all(|(nx, ny)| response[ny * w + nx] <= v);
            if v < threshold || !neighbours_not_above {
                continue;
            }
            let c = Corner { x, y, response: v };
            if list.iter().any(|k| k.response >= v && d2(k, &c) < md2) {
                continue;
            }
            list.retain(|k| !(k.response < v && d2(k, &c) < md2));
            let at = list.partition_point(|k| k.response >= v);
            list.insert(at, c);
            list.truncate(capacity);
        }
    }
    list
}

/// The Shi-Tomasi response image, zero where the block has no gradients.
fn reference_response(img: &ImageView<'_>, block_size: usize) -> Vec<f32> {
    let (w, h) = (img.width(), img.height());
    let px = |x: usize, y: usize| i64::from(img.get(x, y).unwrap());
    // Sobel gradient products; none on the outermost rows and columns.
    let products = |x: usize, y: usize| -> [i64; 3] {
        if x == 0 || y == 0 || x + 1 >= w || y + 1 >= h {
            return [0; 3];
        }
        let gx = px(x + 1, y - 1) - px(x - 1, y - 1)
            + 2 * (px(x + 1, y) - px(x - 1, y))
            + px(x + 1, y + 1)
            - px(x - 1, y + 1);
        let gy = px(x - 1, y + 1) + 2 * px(x, y + 1) + px(x + 1, y + 1)
            - px(x - 1, y - 1)
            - 2 * px(x, y - 1)
            - px(x + 1, y - 1);
        [gx * gx, gx * gy, gy * gy]
    };
    let r = block_size / 2;
    let norm = 1.0 / (64.0 * (block_size * block_size) as f32);
    let mut response = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            // The whole block must have gradients.
            if x < r + 1 || y < r + 1 || x + r + 2 > w || y + r + 2 > h {
                continue;
            }
            // Columns summed exactly, then the columns added left to right.
            let mut g = [0f32; 3];
            for bx in x - r..=x + r {
                let mut column = [0i64; 3];
                for by in y - r..=y + r {
                    let p = products(bx, by);
                    for k in 0..3 {
                        column[k] += p[k];
                    }
                }
                for k in 0..3 {
                    g[k] += column[k] as f32;
                }
            }
            let [xx, xy, yy] = g.map(|v| v * norm);
            let half_diff = 0.5 * (xx - yy);
            let lambda = 0.5 * (xx + yy) - libm::sqrtf(half_diff * half_diff + xy * xy);
            response[y * w + x] = lambda.max(0.0);
        }
    }
    response
}

fn detect_vec(img: &ImageView<'_>, cfg: &CornerConfig, capacity: usize) -> Vec<Corner> {
    let mut scratch = vec![0f32; scratch_len(img.width(), img.height(), cfg.block_size)];
    let mut out = vec![Corner::default(); capacity];
    let n = detect_corners(img, cfg, &mut scratch, &mut out).unwrap();
    out.truncate(n);
    out
}

fn detect(img: &ImageView<'_>, cfg: &CornerConfig, out: &mut [Corner]) -> usize {
    let mut scratch = [0f32; 4096];
    detect_corners(img, cfg, &mut scratch, out).unwrap()
}

/// Seeded blobs and steps on noise: corners of every strength.
fn random_image(w: usize, h: usize, seed: u64) -> Vec<u8> {
    let mut s = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    let mut next = move || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 33) as u32
    };
    let mut img: Vec<u8> = (0..w * h).map(|_| 100 + (next() % 24) as u8).collect();
    for _ in 0..(w * h / 200).max(2) {
        let (x0, y0) = (next() as usize % w, next() as usize % h);
        let (bw, bh) = (1 + next() as usize % 12, 1 + next() as usize % 12);
        let level = (next() % 256) as u8;
        for y in y0..(y0 + bh).min(h) {
            for x in x0..(x0 + bw).min(w) {
                img[y * w + x] = level;
            }
        }
    }
    img
}

/// An 8-bit grayscale PNG of the repository's `data/images`.
fn photograph(name: &str) -> (Vec<u8>, usize, usize) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/images");
    let file = std::fs::File::open(dir.join(name)).unwrap();
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0u8; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Grayscale, "{name}");
    buf.truncate(info.buffer_size());
    (buf, info.width as usize, info.height as usize)
}

fn crop(img: &[u8], stride: usize, x0: usize, y0: usize, w: usize, h: usize) -> Vec<u8> {
    (y0..y0 + h)
        .flat_map(|y| img[y * stride + x0..y * stride + x0 + w].iter().copied())
        .collect()
}

#[test]
fn photographs_give_the_reference_corners() {
    for name in ["camera.png", "brick.png", "gravel.png"] {
        let (photo, pw, ph) = photograph(name);
        for (w, h) in [(320, 240), (160, 120)] {
            let data = crop(&photo, pw, (pw - w) / 2, (ph - h) / 2, w, h);
            let img = ImageView::packed(&data, w, h).unwrap();
            for block_size in [3, 5, 7] {
                for (min_distance, capacity) in [(10.0, 200), (8.0, 100), (3.0, 500)] {
                    let cfg = CornerConfig {
                        block_size,
                        min_distance,
                        ..CornerConfig::default()
                    };
                    let got = detect_vec(&img, &cfg, capacity);
                    assert!(got.len() >= 10, "{name} {w}x{h}: {}", got.len());
                    assert_eq!(
                        got,
                        reference(&img, &cfg, capacity),
                        "{name} {w}x{h} {cfg:?}"
                    );
                }
            }
        }
        // The whole photograph, through a strided view of its right part.
        let img = ImageView::new(&photo[100..], pw - 100, ph, pw).unwrap();
        let cfg = CornerConfig::default();
        assert_eq!(
            detect_vec(&img, &cfg, 200),
            reference(&img, &cfg, 200),
            "{name}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

    #[test]
    fn random_images_give_the_reference_corners(
        w in 1usize..70,
        h in 1usize..70,
        seed in any::<u64>(),
        block_size in prop_oneof![Just(3usize), Just(5), Just(7)],
        quality_level in prop_oneof![Just(1.0f32), Just(0.5), Just(0.01), Just(1e-6)],
        min_distance in prop_oneof![Just(0.0f32), Just(1.0), Just(2.5), Just(10.0)],
        border in 0usize..14,
        min_response in prop_oneof![Just(0.0f32), Just(1.0), Just(100.0)],
        capacity in 0usize..40,
    ) {
        let data = random_image(w, h, seed);
        let img = ImageView::packed(&data, w, h).unwrap();
        let cfg = CornerConfig { quality_level, min_distance, block_size, border, min_response };
        prop_assert_eq!(detect_vec(&img, &cfg, capacity), reference(&img, &cfg, capacity));
    }
}

#[test]
fn response_rows_match_the_reference_image() {
    for (i, (w, h)) in [
        (1, 1),
        (3, 3),
        (5, 5),
        (8, 9),
        (9, 8),
        (12, 12),
        (17, 5),
        (31, 23),
        (64, 48),
    ]
    .into_iter()
    .enumerate()
    {
        let data = random_image(w, h, i as u64);
        let img = ImageView::packed(&data, w, h).unwrap();
        for block in [3, 5, 7] {
            let expected = reference_response(&img, block);
            let mut scratch = vec![0f32; window_len(w, block)];
            let mut rows = ResponseRows::new(&img, block, &mut scratch);
            let mut row = vec![f32::NAN; w];
            for (y, want) in expected.chunks_exact(w).enumerate() {
                let strongest = rows.next(y, &mut row);
                assert_eq!(row, want, "{w}x{h} block {block} row {y}");
                assert_eq!(strongest, want.iter().copied().fold(0.0, f32::max));
            }
        }
    }
}

#[test]
fn block_sums_beyond_f32_integers_match_the_reference() {
    // Stripes of period 4 give |gx| = 1020 at every pixel: a 7x7 block sums
    // 49 * 1020² > 2²⁴, where f32 sums round.
    const W: usize = 48;
    const H: usize = 40;
    let mut data = [0u8; W * H];
    for (i, p) in data.iter_mut().enumerate() {
        let (x, y) = (i % W, i / W);
        let stripe = (x / 2) % 2 == 1;
        let notch = (18..22).contains(&y) && (20..30).contains(&x);
        *p = if stripe != notch { 255 } else { 0 };
    }
    let img = ImageView::packed(&data, W, H).unwrap();
    for block_size in [3, 5, 7] {
        let want = reference_response(&img, block_size);
        assert!(want.iter().any(|&v| v > 0.0));
        let mut scratch = vec![0f32; window_len(W, block_size)];
        let mut rows = ResponseRows::new(&img, block_size, &mut scratch);
        let mut row = [0f32; W];
        for (y, want) in want.chunks_exact(W).enumerate() {
            rows.next(y, &mut row);
            assert_eq!(&row[..], want, "block {block_size} row {y}");
        }
        let cfg = CornerConfig {
            block_size,
            border: 2,
            min_distance: 2.0,
            ..CornerConfig::default()
        };
        let got = detect_vec(&img, &cfg, 100);
        assert!(!got.is_empty());
        assert_eq!(got, reference(&img, &cfg, 100), "block {block_size}");
    }
}

#[test]
fn the_random_images_have_corners_to_compare() {
    // The property above compares something: most random images have corners.
    let cfg = CornerConfig {
        border: 3,
        min_distance: 2.5,
        ..CornerConfig::default()
    };
    let with_corners = (0..20)
        .filter(|&seed| {
            let data = random_image(40, 30, seed);
            let img = ImageView::packed(&data, 40, 30).unwrap();
            detect_vec(&img, &cfg, 30).len() >= 3
        })
        .count();
    assert!(with_corners >= 15, "{with_corners}");
}

#[test]
fn finds_the_corners_of_a_bright_square_strongest_first() {
    let mut buf = [20u8; 40 * 40];
    for y in 12..28 {
        for x in 10..30 {
            buf[y * 40 + x] = 200;
        }
    }
    let img = ImageView::packed(&buf, 40, 40).unwrap();
    let cfg = CornerConfig {
        min_distance: 5.0,
        border: 3,
        ..CornerConfig::default()
    };
    let mut out = [Corner::default(); 8];
    let n = detect(&img, &cfg, &mut out);
    assert_eq!(n, 4, "{:?}", &out[..n]);
    for c in &out[..n] {
        let near = |a: usize, b: usize| a.abs_diff(b) <= 1;
        assert!(near(c.x, 10) || near(c.x, 29), "{c:?}");
        assert!(near(c.y, 12) || near(c.y, 27), "{c:?}");
    }
    assert!(out[..n].windows(2).all(|p| p[0].response >= p[1].response));
    // Capacity 2 keeps the two strongest; capacity 1 the strongest.
    let mut two = [Corner::default(); 2];
    assert_eq!(detect(&img, &cfg, &mut two), 2);
    assert_eq!(&two[..], &out[..2]);
    let mut one = [Corner::default(); 1];
    assert_eq!(detect(&img, &cfg, &mut one), 1);
    assert_eq!(one[0], out[0]);
}

#[test]
fn a_full_list_hands_weaker_corners_back_even_when_they_come_first() {
    // Weak corners (low contrast) in the top rows, strong ones below: the
    // provisional threshold is low while the weak rows stream by, so they
    // fill the list before the strong ones push them out.
    const W: usize = 90;
    const H: usize = 90;
    let mut buf = [50u8; W * H];
    let mut square = |x0: usize, y0: usize, level: u8| {
        for y in y0..y0 + 8 {
            for x in x0..x0 + 8 {
                buf[y * W + x] = level;
            }
        }
    };
    for i in 0..4 {
        square(14 + 16 * i, 14, 58); // weak, four corners each
        square(14 + 16 * i, 60, 250); // strong
    }
    let img = ImageView::packed(&buf, W, H).unwrap();
    let cfg = CornerConfig {
        min_distance: 3.0,
        quality_level: 1e-4,
        ..CornerConfig::default()
    };
    let all = detect_vec(&img, &cfg, 64);
    assert_eq!(all.len(), 32, "{all:?}");
    let mut out = [Corner::default(); 16];
    let n = detect(&img, &cfg, &mut out);
    assert_eq!(n, 16);
    assert_eq!(&out[..], &all[..16]);
    assert!(out.iter().all(|c| c.y >= 55), "{out:?}");
    // A quality level that cuts the weak ones leaves the same 16.
    let strict = CornerConfig {
        quality_level: 0.5,
        ..cfg
    };
    assert_eq!(detect_vec(&img, &strict, 64), all[..16].to_vec());
}

#[test]
fn uniform_image_and_bad_config() {
    let buf = [90u8; 30 * 30];
    let img = ImageView::packed(&buf, 30, 30).unwrap();
    let mut out = [Corner::default(); 8];
    assert_eq!(detect(&img, &CornerConfig::default(), &mut out), 0);
    let floorless = CornerConfig {
        min_response: 0.0,
        border: 1,
        ..CornerConfig::default()
    };
    assert_eq!(detect(&img, &floorless, &mut out), 0);
    let mut scratch = [0f32; 10];
    assert_eq!(
        detect_corners(&img, &CornerConfig::default(), &mut scratch, &mut out),
        Err(CornerError::ScratchTooSmall {
            needed: scratch_len(30, 30, 3),
            got: 10
        })
    );
    let bad = CornerConfig {
        block_size: 4,
        ..CornerConfig::default()
    };
    assert_eq!(
        detect_corners(&img, &bad, &mut scratch, &mut out),
        Err(CornerError::BlockSize)
    );
}

#[test]
fn scratch_grows_with_the_width_only() {
    assert_eq!(scratch_len(160, 120, 3), 160 * 15);
    assert_eq!(scratch_len(160, 10_000, 3), scratch_len(160, 1, 3));
    assert_eq!(scratch_len(320, 240, 7), 320 * 27);
    assert_eq!(scratch_len(usize::MAX, 2, 3), usize::MAX);
    // A tall image runs in the scratch of one sized for its width.
    const W: usize = 40;
    const H: usize = 400;
    let data = random_image(W, H, 3);
    let img = ImageView::packed(&data, W, H).unwrap();
    let cfg = CornerConfig {
        border: 2,
        min_distance: 4.0,
        ..CornerConfig::default()
    };
    let mut scratch = [0f32; scratch_len(W, 1, 3)];
    let mut out = [Corner::default(); 300];
    let n = detect_corners(&img, &cfg, &mut scratch, &mut out).unwrap();
    assert!(n > 50, "{n}");
    assert_eq!(out[..n].to_vec(), reference(&img, &cfg, 300));
    assert!(out[..n].iter().any(|c| c.y > 300));
}

#[test]
fn tiny_and_textureless_images_give_no_corners() {
    let data = random_image(12, 12, 5);
    let mut out = [Corner::default(); 8];
    for block_size in [3, 5, 7] {
        let cfg = CornerConfig {
            block_size,
            border: 1,
            min_response: 0.0,
            ..CornerConfig::default()
        };
        for (w, h) in [(1, 1), (1, 12), (12, 1), (2, 2), (3, 3), (4, 12), (12, 4)] {
            let img = ImageView::packed(&data[..w * h], w, h).unwrap();
            assert_eq!(
                detect(&img, &cfg, &mut out),
                0,
                "{w}x{h} block {block_size}"
            );
        }
        // Smaller than the block plus its gradient ring: no response at all.
        let side = block_size + 1;
        let img = ImageView::packed(&data[..side * side], side, side).unwrap();
        assert_eq!(detect(&img, &cfg, &mut out), 0, "block {block_size}");
    }
    // The smallest image with a response: 5x5 for 3x3 blocks, one pixel.
    let mut plus = [0u8; 25];
    plus[12] = 255;
    let img = ImageView::packed(&plus, 5, 5).unwrap();
    let cfg = CornerConfig {
        border: 1,
        ..CornerConfig::default()
    };
    let n = detect(&img, &cfg, &mut out);
    assert_eq!(&out[..n], &reference(&img, &cfg, 8)[..]);
    assert_eq!(n, 1);
    assert_eq!((out[0].x, out[0].y), (2, 2));
    // No room for corners: nothing, and no error.
    assert_eq!(detect(&img, &cfg, &mut []), 0);
}

#[test]
fn default_border_matches_the_default_tracker_window() {
    use crate::lk::{LkConfig, LostReason, TrackResult, TrackStatus, Tracker};
    use crate::pyramid::{Pyramid, PyramidStorage};
    assert_eq!(LK_DEFAULT_WINDOW, LkConfig::default().window);
    // A texture with corners everywhere, up to the edges.
    const W: usize = 64;
    const H: usize = 48;
    let mut img = [0u8; W * H];
    let mut seed = 7u32;
    for y in 0..H {
        for x in 0..W {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let checker = if (x / 5 + y / 4) % 2 == 0 { 60 } else { 190 };
            img[y * W + x] = (checker + (seed >> 28) as i32) as u8;
        }
    }
    let view = ImageView::packed(&img, W, H).unwrap();
    let cfg = CornerConfig::default();
    let mut out = [Corner::default(); 64];
    let n = detect(&view, &cfg, &mut out);
    assert!(n > 4, "{n}");
    let near_edge = out[..n]
        .iter()
        .map(|c| c.x.min(c.y).min(W - 1 - c.x).min(H - 1 - c.y))
        .min()
        .unwrap();
    assert_eq!(near_edge, cfg.border, "the border is reached");
    // Every corner can be tracked at level 0 (no OutOfBounds).
    let mut st = PyramidStorage::<0>::new();
    let pyr = Pyramid::build(&view, 1, &mut st).unwrap();
    let tracker = Tracker::new(LkConfig {
        levels: 1,
        ..LkConfig::default()
    })
    .unwrap();
    let mut points = [crate::geometry::Vec2::zeros(); 64];
    for (p, c) in points.iter_mut().zip(&out[..n]) {
        *p = c.position();
    }
    let mut results = [TrackResult::EMPTY; 64];
    tracker
        .track(&pyr, &pyr, &points[..n], &mut results[..n])
        .unwrap();
    for (c, r) in out[..n].iter().zip(&results[..n]) {
        assert_ne!(
            r.status,
            TrackStatus::Lost(LostReason::OutOfBounds),
            "{c:?}"
        );
    }
}
