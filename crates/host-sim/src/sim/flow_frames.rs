//! Raw frames of the downward flow sensor: the floor under the sensor as the
//! PAA5100JE / PMW3901 images it (35 x 35 pixels, 42 degree field of view,
//! PMW3901MB datasheet), at the sensor's height, lit by its LED, exposed for
//! the shutter time, blurred by the motion during the exposure.
//!
//! - Floor: the photograph the world floors that room with
//!   ([`FloorLook::world`], the same textures the forward camera sees). The
//!   photographs resolve about 4 mm a texel, the sensor 0.66 mm a pixel at
//!   30 mm, so below the photograph's resolution a seeded value noise
//!   (fixed per floor point, two octaves) stands in for the floor's
//!   micro-texture ([`micro_texture`]): strong on carpet fibres, faint on
//!   glazed tile. This detail is synthetic.
//! - Geometry: pixel `(u, v)` looks at the floor point `((u - c) h / f,
//!   (v - c) h / f)` in the sensor frame (sensor x = body x, sensor y =
//!   body -y), `c = 17`, `f` = [`FOCAL_PX`], `h` the sensor's height
//!   (mounting height plus the body's lift). 2 x 2 samples a pixel.
//! - Light and exposure: the LED's fall-off `cos^4` of the off-axis angle;
//!   the chip's automatic exposure scales the frame to a mean of 110 levels;
//!   the shutter is the floor's nominal shutter of the counting model
//!   ([`flow_quality`]), the exposure [`EXPOSURE_PER_SHUTTER_S`] per unit
//!   (an assumption: the datasheet gives no unit).
//! - Motion blur: [`BLUR_SAMPLES`] poses spread over the exposure before the
//!   grab, along the true velocity and yaw rate.
//! - Noise: Gaussian, 1.5 levels plus 2 % of the value (read and shot noise),
//!   then rounded to the chip's 8 bits.
//! - No floor in focus (lifted, or outside every room): a dark frame of noise.

use super::drivers::FrameGrabber;
use super::floors::FloorLook;
use super::motion::{TRUTH_STEP_NS, TruthStep};
use super::sensors::{FlowModel, flow_quality};
use super::world::{Surface, World};
use crate::asl::{FlowFrameEntry, FlowMeta};
use crate::error::CliError;
use crate::pngio::{GrayImage, save_gray};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::path::Path;
use traction::vslam_core::Timestamp;
use traction::vslam_core::flow_frames::FOCAL_PX;
use traction::vslam_core::sensors::{FLOW_FRAME_LEN, FLOW_FRAME_SIDE};

/// Exposure time per unit of the shutter register, seconds (assumed).
pub const EXPOSURE_PER_SHUTTER_S: f64 = 0.25e-6;

/// Poses averaged over one exposure.
pub const BLUR_SAMPLES: usize = 6;

/// Mean level the automatic exposure aims at.
const TARGET_MEAN: f64 = 110.0;

/// One raw frame and the shutter it was exposed with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawFrame {
    /// 35 x 35 pixels, row-major.
    pub pixels: [u8; FLOW_FRAME_LEN],
    /// Shutter register value.
    pub shutter: u16,
}

/// Renders the flow sensor's raw frames.
#[derive(Clone)]
pub struct FlowFrameRenderer {
    look: FloorLook,
    model: FlowModel,
}

/// The micro-texture of `surface` at floor point `(x, y)` (metres): a value
/// in about `[-1, 1]` times the floor's amplitude; cell sizes and amplitudes
/// per floor kind.
pub fn micro_texture(surface: Surface, x: f64, y: f64) -> f64 {
    let (cell, amplitude, salt) = match surface {
        Surface::Carpet => (0.0010, 0.45, 1u64),
        Surface::Wood => (0.0008, 0.12, 2),
        Surface::Tile => (0.0008, 0.04, 3),
        Surface::Concrete => (0.0006, 0.22, 4),
    };
    let coarse = value_noise(x / (2.5 * cell), y / (2.5 * cell), salt);
    let fine = value_noise(x / cell, y / cell, salt + 16);
    amplitude * (0.5 * coarse + 0.7 * fine)
}

/// Bilinear value noise in `[-1, 1]` on the integer lattice, hashed from the
/// lattice point and `salt` (splitmix64).
fn value_noise(x: f64, y: f64, salt: u64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (xi, yi) = (x0 as i64, y0 as i64);
    let h = |i: i64, j: i64| -> f64 {
        let mut z = (i as u64)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add((j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
            .wrapping_add(salt.wrapping_mul(0x1656_67B1_9E37_79F9));
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let top = h(xi, yi) * (1.0 - fx) + h(xi + 1, yi) * fx;
    let bottom = h(xi, yi + 1) * (1.0 - fx) + h(xi + 1, yi + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

impl FlowFrameRenderer {
    /// The renderer of `model`'s sensor over the world's floors.
    pub fn new(model: &FlowModel) -> Self {
        FlowFrameRenderer {
            look: FloorLook::world(),
            model: *model,
        }
    }

    /// The reflectance of the floor at world point `(x, y)`: photograph and
    /// micro-texture, `None` outside every room.
    fn reflectance(&self, world: &World, x: f64, y: f64) -> Option<f64> {
        let surface = world.surface_at(x, y)?;
        let photo = self.look.of(surface).at(x, y) / 255.0;
        Some((photo * (1.0 + micro_texture(surface, x, y))).max(0.0))
    }

    /// The frame grabbed at truth step `s`.
    pub fn render(&self, world: &World, s: &TruthStep, rng: &mut ChaCha8Rng) -> RawFrame {
        let lifted = s.episode == Some(super::script::EpisodeKind::Lifted);
        let [tx, ty, tz] = self.model.t_bs;
        let surface = {
            let (sn, cs) = s.yaw.sin_cos();
            world.surface_at(s.p[0] + cs * tx - sn * ty, s.p[1] + sn * tx + cs * ty)
        };
        let shutter = flow_quality(if lifted { None } else { surface }).2;
        let mut radiance = [0f64; FLOW_FRAME_LEN];
        let noise = |rng: &mut ChaCha8Rng, v: f64| {
            Normal::new(0.0, 1.5 + 0.02 * v)
                .map(|n| n.sample(rng))
                .unwrap_or(0.0)
        };
        if lifted || surface.is_none() {
            let mut pixels = [0u8; FLOW_FRAME_LEN];
            for p in pixels.iter_mut() {
                *p = (12.0 + noise(rng, 12.0)).round().clamp(0.0, 255.0) as u8;
            }
            return RawFrame {
                pixels,
                shutter: shutter as u16,
            };
        }
        let h = tz + s.p[2];
        let c = (FLOW_FRAME_SIDE as f64 - 1.0) / 2.0;
        let f = f64::from(FOCAL_PX);
        let exposure = shutter * EXPOSURE_PER_SHUTTER_S;
        const SUB: [f64; 2] = [-0.25, 0.25];
        for k in 0..BLUR_SAMPLES {
            // Poses over the exposure that ends at the grab.
            let tau = exposure * (k as f64 + 0.5) / BLUR_SAMPLES as f64;
            let yaw = s.yaw - s.w * tau;
            let (px, py) = (s.p[0] - s.vel[0] * tau, s.p[1] - s.vel[1] * tau);
            let (sn, cs) = yaw.sin_cos();
            for (i, r) in radiance.iter_mut().enumerate() {
                let (u, v) = ((i % FLOW_FRAME_SIDE) as f64, (i / FLOW_FRAME_SIDE) as f64);
                let mut acc = 0.0;
                for dv in SUB {
                    for du in SUB {
                        let (us, vs) = (u + du - c, v + dv - c);
                        // Sensor (x, y) = body (x, -y).
                        let bx = tx + us * h / f;
                        let by = ty - vs * h / f;
                        let (wx, wy) = (px + cs * bx - sn * by, py + sn * bx + cs * by);
                        let rho = self.reflectance(world, wx, wy).unwrap_or(0.0);
                        let tan2 = (us * us + vs * vs) / (f * f);
                        acc += rho / ((1.0 + tan2) * (1.0 + tan2));
                    }
                }
                *r += acc / 4.0;
            }
        }
        let mean = radiance.iter().sum::<f64>() / FLOW_FRAME_LEN as f64;
        let gain = if mean > 0.0 { TARGET_MEAN / mean } else { 1.0 };
        let mut pixels = [0u8; FLOW_FRAME_LEN];
        for (p, r) in pixels.iter_mut().zip(&radiance) {
            let v = r * gain;
            *p = (v + noise(rng, v)).round().clamp(0.0, 255.0) as u8;
        }
        RawFrame {
            pixels,
            shutter: shutter as u16,
        }
    }
}

/// One grab of [`grabs`]: its time, the rendered frame (for its shutter)
/// and the pixels the driver read.
pub struct Grab {
    /// Time of the grab.
    pub t: Timestamp,
    /// The frame the chip simulator was given.
    pub frame: RawFrame,
    /// The pixels read back through the driver's frame-grab path.
    pub pixels: [u8; FLOW_FRAME_LEN],
}

/// Raw frames at every flow report time (`model.rate_hz`) of `truth`
/// (from its first step on), each rendered and grabbed through the chip
/// simulator and the driver ([`FrameGrabber`]). The noise has its own
/// generator seeded from `seed`, so the other streams do not change with it.
pub fn grabs<'a>(
    world: &'a World,
    model: &FlowModel,
    truth: &'a [TruthStep],
    seed: u64,
) -> Result<impl Iterator<Item = Result<Grab, CliError>> + 'a, CliError> {
    let renderer = FlowFrameRenderer::new(model);
    let mut grabber = FrameGrabber::new()?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x00F1_0F4A_3EF1_0F4A);
    let every = ((1e9 / model.rate_hz) as u64 / TRUTH_STEP_NS).max(1) as usize;
    Ok(truth.iter().step_by(every).map(move |s| {
        let frame = renderer.render(world, s, &mut rng);
        let pixels = grabber.grab(&frame)?;
        Ok(Grab {
            t: Timestamp(s.t_ns),
            frame,
            pixels,
        })
    }))
}

/// The `flowraw0` stream of a run: the [`grabs`] of `truth`, written as
/// `root/mav0/flowraw0/data/<t>.png`.
pub fn record(
    world: &World,
    model: &FlowModel,
    truth: &[TruthStep],
    seed: u64,
    root: &Path,
) -> Result<(FlowMeta, Vec<FlowFrameEntry>), CliError> {
    let dir = root.join("mav0/flowraw0/data");
    std::fs::create_dir_all(&dir)
        .map_err(|e| CliError::file(&dir, format!("cannot create: {e}")))?;
    let mut entries = Vec::new();
    for grab in grabs(world, model, truth, seed)? {
        let Grab { t, frame, pixels } = grab?;
        let path = dir.join(format!("{}.png", t.0));
        save_gray(
            &path,
            &GrayImage {
                width: FLOW_FRAME_SIDE,
                height: FLOW_FRAME_SIDE,
                data: pixels.to_vec(),
            },
        )?;
        entries.push(FlowFrameEntry {
            t,
            path,
            shutter: frame.shutter,
        });
    }
    let meta = FlowMeta {
        rate_hz: model.rate_hz,
        t_bs: model.t_bs_matrix(),
        height: model.t_bs[2],
        counts_per_radian: model.counts_per_radian,
    };
    Ok((meta, entries))
}

#[cfg(test)]
mod tests {
    use super::*;
    use traction::vslam_core::flow_frames::high_pass;

    fn step(x: f64, v: f64) -> TruthStep {
        TruthStep {
            t_ns: 0,
            p: [x, 0.5, 0.0],
            yaw: 0.0,
            v,
            w: 0.0,
            vel: [v, 0.0, 0.0],
            acc: [0.0; 3],
            surface: Some(Surface::Wood),
            wheel_angle: [0.0; 2],
            episode: None,
        }
    }

    fn contrast(f: &RawFrame) -> f64 {
        let m = f.pixels.iter().map(|&p| p as f64).sum::<f64>() / FLOW_FRAME_LEN as f64;
        (f.pixels
            .iter()
            .map(|&p| (p as f64 - m).powi(2))
            .sum::<f64>()
            / FLOW_FRAME_LEN as f64)
            .sqrt()
    }

    #[test]
    fn frames_show_the_floor_move_against_the_sensor_and_blur_at_speed() {
        let world = World::office();
        let r = FlowFrameRenderer::new(&FlowModel::paa5100());
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let pitch = r.model.t_bs[2] / f64::from(FOCAL_PX);
        let a = r.render(&world, &step(1.0, 0.0), &mut rng);
        // Four pixels forward: the floor moves four columns to the left.
        let b = r.render(&world, &step(1.0 + 4.0 * pitch, 0.0), &mut rng);
        // Compared without the LED's fall-off, which stays where it is.
        let (mut ha, mut hb) = ([0u8; FLOW_FRAME_LEN], [0u8; FLOW_FRAME_LEN]);
        high_pass(&a.pixels, &mut ha);
        high_pass(&b.pixels, &mut hb);
        // b(x) = a(x + k) fits best at k = 4 among shifts 0..=8.
        let diff = |k: usize| {
            let mut d = 0.0;
            for y in 0..FLOW_FRAME_SIDE {
                for x in 0..FLOW_FRAME_SIDE - 8 {
                    let pa = ha[y * FLOW_FRAME_SIDE + x + k] as f64;
                    let pb = hb[y * FLOW_FRAME_SIDE + x] as f64;
                    d += (pa - pb).abs();
                }
            }
            d
        };
        let costs: Vec<f64> = (0..=8).map(diff).collect();
        let best = (0..=8).min_by(|a, b| costs[*a].total_cmp(&costs[*b]));
        assert_eq!(best, Some(4), "{costs:?}");
        assert!(contrast(&a) > 8.0, "contrast {}", contrast(&a));
        let fast = r.render(&world, &step(1.0, 4.0), &mut rng);
        assert!(
            contrast(&fast) < contrast(&a),
            "motion blur lowers contrast"
        );
        let mut lifted = step(1.0, 0.0);
        lifted.episode = Some(super::super::script::EpisodeKind::Lifted);
        assert!(contrast(&r.render(&world, &lifted, &mut rng)) < 4.0);
    }
}
