//! LK on the 35x35 raw frame of an optical-flow sensor (PMW3901 class): a
//! textured 35x35 patch cut from a photograph, moved by a subpixel amount,
//! tracked with two levels and a small window.
//!
//! The frames are made the way a sensor makes them: each pixel integrates a
//! 4x4 block of the photograph, so moving the photograph by `k` photo pixels
//! moves the frame by exactly `k / 4` frame pixels, with no interpolation
//! model in the ground truth.

use test_support::images::{Gray, load, median};
use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};
use vslam_core::geometry::Vec2;
use vslam_core::lk::{LkConfig, TrackResult, Tracker};
use vslam_core::pyramid::{Pyramid, PyramidStorage, storage_bytes};

/// `g` as the library's image view.
fn view(g: &Gray) -> vslam_core::image::ImageView<'_> {
    vslam_core::image::ImageView::packed(&g.data, g.width, g.height).unwrap()
}

const SIDE: usize = 35;

const F: usize = 4;

/// The 35x35 frame whose pixel `(x, y)` integrates the photo's block at
/// `(left + F x, top + F y)`.
fn integrate(photo: &Gray, left: usize, top: usize) -> Gray {
    let mut data = Vec::with_capacity(SIDE * SIDE);
    for y in 0..SIDE {
        for x in 0..SIDE {
            let mut sum = 0u32;
            for yy in 0..F {
                for xx in 0..F {
                    sum += u32::from(photo.at(left + F * x + xx, top + F * y + yy));
                }
            }
            data.push(((sum + 8) / 16) as u8);
        }
    }
    Gray {
        data,
        width: SIDE,
        height: SIDE,
    }
}

/// Frames at photo offset `(x0, y0)`, the second moved by `(kx, ky)` photo pixels.
fn track_patch(name: &str, x0: usize, y0: usize, kx: isize, ky: isize) -> (f64, usize, usize) {
    let photo = load(name);
    let a = integrate(&photo, x0, y0);
    let b = integrate(
        &photo,
        x0.checked_add_signed(-kx).unwrap(),
        y0.checked_add_signed(-ky).unwrap(),
    );
    let (dx, dy) = (kx as f64 / F as f64, ky as f64 / F as f64);
    let (va, vb) = (view(&a), view(&b));
    let mut sa = PyramidStorage::<{ storage_bytes(SIDE, SIDE, 2) }>::new();
    let mut sb = PyramidStorage::<{ storage_bytes(SIDE, SIDE, 2) }>::new();
    let pa = Pyramid::build(&va, 2, &mut sa).unwrap();
    let pb = Pyramid::build(&vb, 2, &mut sb).unwrap();

    let cc = CornerConfig {
        min_distance: 4.0,
        border: 6,
        ..CornerConfig::default()
    };
    let mut scratch = [0f32; scratch_len(SIDE, SIDE, 3)];
    let mut corners = [Corner::default(); 12];
    let n = detect_corners(&va, &cc, &mut scratch, &mut corners).unwrap();
    let mut points: Vec<Vec2> = corners[..n].iter().map(Corner::position).collect();
    points.push(Vec2::new(17.0, 17.0));

    let config = LkConfig {
        window: 9,
        levels: 2,
        ..LkConfig::default()
    };
    let mut out = vec![TrackResult::EMPTY; points.len()];
    let counts = Tracker::new(config)
        .unwrap()
        .track(&pa, &pb, &points, &mut out)
        .unwrap();
    let mut errors: Vec<f64> = points
        .iter()
        .zip(&out)
        .filter(|(_, r)| r.is_tracked())
        .map(|(p, r)| {
            let ex = f64::from(r.position.x) - (f64::from(p.x) + dx);
            let ey = f64::from(r.position.y) - (f64::from(p.y) + dy);
            ex.hypot(ey)
        })
        .collect();
    let med = if errors.is_empty() {
        f64::INFINITY
    } else {
        median(&mut errors)
    };
    println!(
        "{name} 35x35 at ({x0}, {y0}) moved ({dx}, {dy}): {} of {} tracked, median error {med:.4} px, lost {:?}",
        counts.tracked,
        points.len(),
        counts.lost
    );
    (med, counts.tracked, points.len())
}

#[test]
fn a_35x35_flow_sensor_frame_tracks_a_subpixel_shift() {
    for (name, x0, y0, dx, dy) in [
        ("gravel.png", 240, 200, 3, -1),
        ("gravel.png", 60, 300, -7, 3),
        ("brick.png", 300, 120, 2, 1),
        ("camera.png", 200, 60, -1, 2),
    ] {
        let (med, tracked, total) = track_patch(name, x0, y0, dx, dy);
        assert!(total >= 5, "{name}: only {total} points");
        assert!(tracked * 10 >= total * 8, "{name}: {tracked} of {total}");
        assert!(med <= 0.1, "{name}: median error {med} px");
    }
}
