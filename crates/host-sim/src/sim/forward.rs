//! The forward image camera `cam1`: the floor ahead as the segmentation
//! model sees it, ray-cast from the true pose (2x2 supersampled).
//!
//! Floors are the photographs of [`FloorLook`], sampled bilinearly at their
//! real scale. What the world has no photograph for is synthetic: walls are
//! plain paint (a faint, low-contrast ceiling-texture mottle so they are not
//! perfectly flat), threshold strips grooved aluminium (bright, ridges every
//! 8 mm across the strip), cables dark rubber. A ray that meets the floor
//! outside every room, or more than 4 m away, sees wall, as in
//! [`super::render::render_labels`].

use super::floors::FloorLook;
use super::motion::TruthStep;
use super::render::{Camera, Texture};
use super::world::World;
use crate::pngio::GrayImage;

/// What the forward camera looks at.
pub struct Scene<'a> {
    /// Rooms, strips and cables.
    pub world: &'a World,
    /// The floors' photographs.
    pub look: &'a FloorLook,
    /// The walls' mottle.
    pub wall: &'a Texture,
}

/// What one ray from `c` along `d` (pixel `(u, v)`, robot yaw `yaw`) sees, as a gray value.
fn shade(scene: &Scene<'_>, c: [f64; 3], d: [f64; 3], (u, v): (f64, f64), yaw: f64) -> f64 {
    let (world, look, wall) = (scene.world, scene.look, scene.wall);
    let paint = || 178.0 + 0.12 * (wall.sample(u + 240.0 * yaw, v) - 128.0);
    if d[2] >= -1e-6 {
        return paint();
    }
    let k = -c[2] / d[2];
    let (x, y) = (c[0] + k * d[0], c[1] + k * d[1]);
    if ((x - c[0]).powi(2) + (y - c[1]).powi(2)).sqrt() > 4.0 {
        return paint();
    }
    match (world.strip_at(x), world.surface_at(x, y)) {
        (_, None) => paint(),
        (Some(strip), Some(_)) if strip.threshold => {
            let across = (x - strip.at) / 0.008;
            196.0 + 14.0 * (std::f64::consts::TAU * across).cos()
        }
        (Some(_), Some(_)) => 32.0,
        (None, Some(surface)) => look.of(surface).at(x, y),
    }
}

/// The forward camera's gray image at `s`.
pub fn render_forward(scene: &Scene<'_>, cam: &Camera, s: &TruthStep) -> GrayImage {
    let [w, h] = cam.resolution;
    let mut data = vec![0u8; w * h];
    const SUB: [f64; 2] = [-0.25, 0.25];
    for v in 0..h {
        for u in 0..w {
            let mut acc = 0.0;
            for dv in SUB {
                for du in SUB {
                    let (uu, vv) = (u as f64 + du, v as f64 + dv);
                    let (c, d) = cam.ray(s, uu, vv);
                    acc += shade(scene, c, d, (uu, vv), s.yaw);
                }
            }
            data[v * w + u] = (acc * 0.25).round().clamp(0.0, 255.0) as u8;
        }
    }
    GrayImage {
        width: w,
        height: h,
        data,
    }
}
