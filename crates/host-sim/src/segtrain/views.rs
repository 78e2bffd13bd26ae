//! Random forward-camera views with their true labels, for training and
//! scoring the floor model.
//!
//! A view is a near floor and a far floor meeting at a line ahead of the
//! robot (with a threshold strip there 60 % of the time), a cable on the
//! near floor 30 % of the time and a wall 0.1-3 m beyond the boundary; the
//! robot stands at a random place with a random heading. Each floor kind
//! takes a random photograph of the chosen split ([`FloorPhoto::held_out`]).
//! The image is rendered by `cam1` ([`render_forward`]) with a random
//! brightness gain (0.8-1.2) and gray noise (sigma 2), the labels by the
//! segmentation camera ([`render_labels`]) from the same pose.

use crate::pngio::GrayImage;
use crate::sim::floors::{FloorLook, FloorTexture, KINDS, PHOTOS};
use crate::sim::forward::{Scene, render_forward};
use crate::sim::motion::TruthStep;
use crate::sim::render::{Camera, Texture, render_labels};
use crate::sim::world::{ACROSS, Room, Strip, World};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// One rendered view.
pub struct View {
    /// `cam1`'s image.
    pub image: GrayImage,
    /// The true class ids at the map's resolution.
    pub labels: GrayImage,
}

/// `count` views with the photographs of one split (`held_out`), from `seed`.
pub fn views(held_out: bool, count: usize, seed: u64) -> Vec<View> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pool: Vec<Vec<FloorTexture>> = KINDS
        .iter()
        .map(|k| {
            PHOTOS
                .iter()
                .filter(|p| p.surface == *k && p.held_out == held_out)
                .map(FloorTexture::new)
                .collect()
        })
        .collect();
    let wall = Texture::ceiling();
    let (cam, seg) = (Camera::forward_image(), Camera::forward_segmentation());
    let noise = Normal::new(0.0, 2.0).unwrap_or_else(|_| unreachable!());
    (0..count)
        .map(|_| {
            let look = FloorLook {
                textures: std::array::from_fn(|k| {
                    let p = &pool[k];
                    p[rng.random_range(0..p.len())].clone()
                }),
            };
            let x0: f64 = rng.random_range(-20.0..20.0);
            let boundary = x0 + rng.random_range(0.15..1.0);
            let wall_x = boundary + rng.random_range(0.1..3.0);
            let near = KINDS[rng.random_range(0..KINDS.len())];
            let far = KINDS[rng.random_range(0..KINDS.len())];
            let mut strips = Vec::new();
            if rng.random_bool(0.6) {
                strips.push(Strip {
                    at: boundary,
                    width: 0.04,
                    height: 0.006,
                    threshold: true,
                    span: ACROSS,
                });
            }
            if rng.random_bool(0.3) {
                strips.push(Strip {
                    at: x0 + rng.random_range(0.1..0.6),
                    width: 0.008,
                    height: 0.012,
                    threshold: false,
                    span: ACROSS,
                });
            }
            let world = World {
                rooms: vec![
                    Room {
                        min: [-100.0, -100.0],
                        max: [boundary, 100.0],
                        surface: near,
                    },
                    Room {
                        min: [boundary, -100.0],
                        max: [wall_x, 100.0],
                        surface: far,
                    },
                ],
                strips,
                ..World::office()
            };
            let yaw = if rng.random_bool(0.7) {
                rng.random_range(-0.8..0.8)
            } else {
                rng.random_range(-std::f64::consts::PI..std::f64::consts::PI)
            };
            let pose = TruthStep {
                t_ns: 0,
                p: [x0, rng.random_range(-20.0..20.0), 0.0],
                yaw,
                v: 0.0,
                w: 0.0,
                vel: [0.0; 3],
                acc: [0.0; 3],
                surface: None,
                wheel_angle: [0.0; 2],
                episode: None,
            };
            let scene = Scene {
                world: &world,
                look: &look,
                wall: &wall,
            };
            let mut image = render_forward(&scene, &cam, &pose);
            let gain: f64 = rng.random_range(0.8..1.2);
            for p in &mut image.data {
                let v = gain * f64::from(*p) + noise.sample(&mut rng);
                *p = v.round().clamp(0.0, 255.0) as u8;
            }
            View {
                image,
                labels: render_labels(&world, &seg, &pose),
            }
        })
        .collect()
}
