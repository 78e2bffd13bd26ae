//! Shared helpers of the surface tests: a class table, synthetic label maps,
//! a seeded normal generator and the camera geometry used to draw maps.
#![allow(dead_code)]

use ego_ekf::surface::{ClassConfig, GroundCamera, SurfaceKind};
use proptest::prelude::RngExt;
use proptest::test_runner::{RngAlgorithm, TestRng};

pub const UNKNOWN: u8 = 0;
pub const WALL: u8 = 1;
pub const WOOD: u8 = 10;
pub const CARPET: u8 = 11;
pub const TILE: u8 = 12;
pub const CONCRETE: u8 = 13;
pub const STRIP: u8 = 14;

/// The test model's classes: 0 unknown, 1 wall, 10.. floors.
pub fn classes() -> ClassConfig {
    ClassConfig::from_lists(
        &[
            (WOOD, SurfaceKind::Wood),
            (CARPET, SurfaceKind::Carpet),
            (TILE, SurfaceKind::Tile),
            (CONCRETE, SurfaceKind::Concrete),
            (STRIP, SurfaceKind::Threshold),
        ],
        &[WALL],
    )
}

/// A packed `w x h` label map with `f(x, y)` as class id.
pub fn map(w: usize, h: usize, f: impl Fn(usize, usize) -> u8) -> Vec<u8> {
    let mut v = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            v.push(f(x, y));
        }
    }
    v
}

/// Seeded random source.
pub fn rng(seed: u8) -> TestRng {
    TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32])
}

/// One standard normal sample (Box-Muller).
pub fn normal(rng: &mut TestRng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-12);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// The camera of the tests: 480-row image, fy 400, cy 240, 10 cm high,
/// pitched 0.15 rad down, 10 cm ahead of the axle.
pub const FY: f64 = 400.0;
pub const CY: f64 = 240.0;
pub const IMAGE_H: f64 = 480.0;
pub const CAM_HEIGHT: f64 = 0.10;
pub const PITCH: f64 = 0.15;
pub const OFFSET: f64 = 0.10;

pub fn camera() -> GroundCamera {
    GroundCamera::new(
        FY as f32,
        CY as f32,
        IMAGE_H as f32,
        CAM_HEIGHT as f32,
        PITCH as f32,
        OFFSET as f32,
    )
    .unwrap()
}

/// The image row fraction (0 top, 1 bottom) where the floor point `d` metres
/// ahead of the axle appears: the forward projection of a floor point through
/// the pinhole, independent of the code under test (which goes the other way).
pub fn row_fraction_of_distance(d: f64) -> f64 {
    let along = d - OFFSET; // horizontal distance from the camera
    let depression = (CAM_HEIGHT / along).atan();
    let below_axis = depression - PITCH;
    (CY + FY * below_axis.tan()) / IMAGE_H
}

/// A label map of a forward view with the floor `near` up to `boundary` metres
/// ahead of the axle and `far` beyond it; walls above `horizon_fraction`.
pub fn boundary_map(
    w: usize,
    h: usize,
    horizon_fraction: f64,
    boundary: f64,
    near: u8,
    far: u8,
) -> Vec<u8> {
    let edge = if boundary <= OFFSET + 1e-6 {
        f64::INFINITY // boundary behind the camera: all of the view is `far`
    } else {
        row_fraction_of_distance(boundary)
    };
    map(w, h, |_, y| {
        let centre = (y as f64 + 0.5) / h as f64;
        if centre < horizon_fraction {
            WALL
        } else if centre > edge {
            near
        } else {
            far
        }
    })
}

/// A wood floor with a threshold strip `width` metres wide whose near edge is
/// `near_edge` metres ahead of the axle; walls above `horizon_fraction`.
pub fn strip_map(w: usize, h: usize, horizon_fraction: f64, near_edge: f64, width: f64) -> Vec<u8> {
    let visible = |d: f64| d > OFFSET + 1e-6;
    let lower = if visible(near_edge) {
        row_fraction_of_distance(near_edge)
    } else {
        f64::INFINITY
    };
    let upper = if visible(near_edge + width) {
        row_fraction_of_distance(near_edge + width)
    } else {
        f64::INFINITY
    };
    map(w, h, |_, y| {
        let centre = (y as f64 + 0.5) / h as f64;
        if centre < horizon_fraction {
            WALL
        } else if centre >= upper && centre <= lower {
            STRIP
        } else {
            WOOD
        }
    })
}
