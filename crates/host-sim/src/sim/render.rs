//! Images from the true pose: the upward camera's view of the textured
//! ceiling (exact pinhole perspective, 2x2 supersampled, bilinear texture),
//! and the forward camera's segmentation label map (ray-cast onto the floor).

use super::motion::TruthStep;
use super::world::{THRESHOLD_CLASS, WALL_CLASS, World};
use crate::pngio::GrayImage;

/// A level pinhole camera mounted on the body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// `[width, height]`, pixels.
    pub resolution: [usize; 2],
    /// `[fu, fv, cu, cv]`, pixels.
    pub intrinsics: [f64; 4],
    /// `R_BS`, row-major (columns are the camera axes in the body).
    pub r_bs: [[f64; 3]; 3],
    /// `t_BS`, metres.
    pub t_bs: [f64; 3],
    /// Frame rate, Hz.
    pub rate_hz: f64,
}

impl Camera {
    /// The upward ceiling camera: 320x240, 200 px focal length, 10 cm above
    /// the floor at the axle; camera x = body -y, camera y = body x, z = up.
    pub fn ceiling() -> Self {
        Camera {
            resolution: [320, 240],
            intrinsics: [200.0, 200.0, 159.5, 119.5],
            r_bs: [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            t_bs: [0.0, 0.0, 0.10],
            rate_hz: 10.0,
        }
    }

    /// The same camera at `width x height` pixels: the focal lengths scaled
    /// with the width and height, the principal point moved so that pixel
    /// areas keep their place (`c' = (c + 0.5) s - 0.5`, as 2x2 averaging
    /// gives at half size); `None` for an empty size.
    pub fn resized(&self, width: usize, height: usize) -> Option<Self> {
        let [w0, h0] = self.resolution;
        if width == 0 || height == 0 || w0 == 0 || h0 == 0 {
            return None;
        }
        let (sx, sy) = (width as f64 / w0 as f64, height as f64 / h0 as f64);
        let [fu, fv, cu, cv] = self.intrinsics;
        Some(Camera {
            resolution: [width, height],
            intrinsics: [
                fu * sx,
                fv * sy,
                (cu + 0.5) * sx - 0.5,
                (cv + 0.5) * sy - 0.5,
            ],
            ..*self
        })
    }

    /// The forward camera whose images the segmentation model labels:
    /// 80x60, pitched down 35 degrees, 15 cm ahead of the axle, 8 cm high.
    pub fn forward_segmentation() -> Self {
        let th = 35f64.to_radians();
        let (s, c) = th.sin_cos();
        // Columns: x_c = -y_b, y_c = (-sin, 0, -cos), z_c = (cos, 0, -sin).
        Camera {
            resolution: [80, 60],
            intrinsics: [60.0, 60.0, 39.5, 29.5],
            r_bs: [[0.0, -s, c], [-1.0, 0.0, 0.0], [0.0, -c, -s]],
            t_bs: [0.15, 0.0, 0.08],
            rate_hz: 2.0,
        }
    }

    /// The forward image camera `cam1` the segmentation model reads: the
    /// segmentation camera's pose and field of view at twice its resolution
    /// (160x120), so a model's half-resolution map has the geometry of `seg0`.
    pub fn forward_image() -> Self {
        let seg = Camera::forward_segmentation();
        let [fu, fv, cu, cv] = seg.intrinsics;
        Camera {
            resolution: [2 * seg.resolution[0], 2 * seg.resolution[1]],
            intrinsics: [2.0 * fu, 2.0 * fv, 2.0 * cu + 0.5, 2.0 * cv + 0.5],
            ..seg
        }
    }

    /// `T_BS` row-major, as in `sensor.yaml`.
    pub fn t_bs_matrix(&self) -> [f32; 16] {
        let r = self.r_bs;
        let t = self.t_bs;
        [
            r[0][0], r[0][1], r[0][2], t[0], r[1][0], r[1][1], r[1][2], t[1], r[2][0], r[2][1],
            r[2][2], t[2], 0.0, 0.0, 0.0, 1.0,
        ]
        .map(|v| v as f32)
    }

    /// World position of the camera centre and the world direction of pixel `(u, v)`.
    pub(crate) fn ray(&self, s: &TruthStep, u: f64, v: f64) -> ([f64; 3], [f64; 3]) {
        let [fu, fv, cu, cv] = self.intrinsics;
        let dc = [(u - cu) / fu, (v - cv) / fv, 1.0];
        let r = self.r_bs;
        let db = [
            r[0][0] * dc[0] + r[0][1] * dc[1] + r[0][2] * dc[2],
            r[1][0] * dc[0] + r[1][1] * dc[1] + r[1][2] * dc[2],
            r[2][0] * dc[0] + r[2][1] * dc[1] + r[2][2] * dc[2],
        ];
        let (sn, cs) = s.yaw.sin_cos();
        let rot = |b: [f64; 3]| [cs * b[0] - sn * b[1], sn * b[0] + cs * b[1], b[2]];
        let c = rot(self.t_bs);
        ([s.p[0] + c[0], s.p[1] + c[1], s.p[2] + c[2]], rot(db))
    }
}

/// A grayscale texture tiled by mirroring, so it has no seams.
#[derive(Clone)]
pub struct Texture {
    img: GrayImage,
}

impl Texture {
    /// The bundled ceiling texture (CC0 gravel photograph, see `data/images/README.md`).
    pub fn ceiling() -> Self {
        Texture::from_png(include_bytes!("../../../../data/images/gravel.png"))
    }

    /// A texture from PNG bytes (converted to gray); a 1x1 mid-gray texture
    /// if they do not decode.
    pub fn from_png(bytes: &[u8]) -> Self {
        let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
        dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
        let img = dec
            .read_info()
            .ok()
            .and_then(|mut r| {
                let mut buf = vec![0u8; r.output_buffer_size()?];
                let info = r.next_frame(&mut buf).ok()?;
                buf.truncate(info.width as usize * info.height as usize);
                Some(GrayImage {
                    width: info.width as usize,
                    height: info.height as usize,
                    data: buf,
                })
            })
            .unwrap_or(GrayImage {
                width: 1,
                height: 1,
                data: vec![128],
            });
        Texture { img }
    }

    fn texel(&self, x: i64, y: i64) -> f64 {
        let mirror = |v: i64, n: usize| -> usize {
            let n = n as i64;
            let m = v.rem_euclid(2 * n);
            (if m < n { m } else { 2 * n - 1 - m }) as usize
        };
        let (xi, yi) = (mirror(x, self.img.width), mirror(y, self.img.height));
        self.img.data[yi * self.img.width + xi] as f64
    }

    /// Bilinear sample at texel coordinates.
    pub fn sample(&self, x: f64, y: f64) -> f64 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (xi, yi) = (x0 as i64, y0 as i64);
        let top = self.texel(xi, yi) * (1.0 - fx) + self.texel(xi + 1, yi) * fx;
        let bot = self.texel(xi, yi + 1) * (1.0 - fx) + self.texel(xi + 1, yi + 1) * fx;
        top * (1.0 - fy) + bot * fy
    }
}

/// The ceiling as the upward camera sees it at `s`.
pub fn render_ceiling(world: &World, cam: &Camera, tex: &Texture, s: &TruthStep) -> GrayImage {
    let [w, h] = cam.resolution;
    let mut data = vec![0u8; w * h];
    const SUB: [f64; 2] = [-0.25, 0.25];
    for v in 0..h {
        for u in 0..w {
            let mut acc = 0.0;
            for dv in SUB {
                for du in SUB {
                    let (c, d) = cam.ray(s, u as f64 + du, v as f64 + dv);
                    let value = if d[2] > 1e-6 {
                        let k = (world.ceiling_height - c[2]) / d[2];
                        tex.sample(
                            (c[0] + k * d[0]) / world.ceiling_texel,
                            (c[1] + k * d[1]) / world.ceiling_texel,
                        )
                    } else {
                        0.0
                    };
                    acc += value;
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

/// The class ids the segmentation model would give the forward camera's view at `s`.
pub fn render_labels(world: &World, cam: &Camera, s: &TruthStep) -> GrayImage {
    let [w, h] = cam.resolution;
    let mut data = vec![WALL_CLASS; w * h];
    for v in 0..h {
        for u in 0..w {
            let (c, d) = cam.ray(s, u as f64, v as f64);
            if d[2] >= -1e-6 {
                continue;
            }
            let k = -c[2] / d[2];
            let (x, y) = (c[0] + k * d[0], c[1] + k * d[1]);
            if ((x - c[0]).powi(2) + (y - c[1]).powi(2)).sqrt() > 4.0 {
                continue;
            }
            let class = match (world.strip_at(x), world.surface_at(x, y)) {
                (_, None) => WALL_CLASS,
                (Some(strip), Some(_)) if strip.threshold => THRESHOLD_CLASS,
                (Some(_), Some(_)) => 0,
                (None, Some(surface)) => surface.class_id(),
            };
            data[v * w + u] = class;
        }
    }
    GrayImage {
        width: w,
        height: h,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::world::Surface;

    #[test]
    fn a_resized_camera_scales_its_intrinsics_as_2x2_averaging() {
        let cam = Camera::ceiling();
        let half = cam.resized(160, 120).expect("a size");
        assert_eq!(half.resolution, [160, 120]);
        assert_eq!(half.intrinsics, [100.0, 100.0, 79.5, 59.5]);
        assert_eq!(
            (half.r_bs, half.t_bs, half.rate_hz),
            (cam.r_bs, cam.t_bs, cam.rate_hz)
        );
        assert_eq!(cam.resized(320, 240), Some(cam));
        assert_eq!(cam.resized(0, 120), None);
        // The same ray through the same point of a pixel at either size.
        let s = at(0.3, 0.4);
        let (c0, d0) = cam.ray(&s, 100.0, 60.0);
        let (c1, d1) = half.ray(&s, 49.75, 29.75);
        for k in 0..3 {
            assert!((c0[k] - c1[k]).abs() < 1e-12 && (d0[k] - d1[k]).abs() < 1e-12);
        }
    }

    fn at(x: f64, yaw: f64) -> TruthStep {
        TruthStep {
            t_ns: 0,
            p: [x, 0.0, 0.0],
            yaw,
            v: 0.0,
            w: 0.0,
            vel: [0.0; 3],
            acc: [0.0; 3],
            surface: None,
            wheel_angle: [0.0; 2],
            episode: None,
        }
    }

    #[test]
    fn ceiling_moves_against_the_robot() {
        let world = World::office();
        let cam = Camera::ceiling();
        let tex = Texture::ceiling();
        let a = render_ceiling(&world, &cam, &tex, &at(1.0, 0.0));
        // Moving forward by exactly one ceiling pixel footprint shifts the image by one row.
        let px = (world.ceiling_height - 0.10) / 200.0;
        let b = render_ceiling(&world, &cam, &tex, &at(1.0 + px, 0.0));
        let w = a.width;
        let mut err = 0.0;
        let mut n = 0.0;
        for v in 20..200 {
            for u in 20..300 {
                err += (a.data[v * w + u] as f64 - b.data[(v - 1) * w + u] as f64).abs();
                n += 1.0;
            }
        }
        assert!(err / n < 3.0, "mean abs diff {}", err / n);
        assert!(a.data.iter().any(|&p| p != a.data[0]), "texture visible");
    }

    #[test]
    fn labels_see_the_floor_ahead() {
        let world = World::office();
        let cam = Camera::forward_segmentation();
        // At x = 3.5 heading +x, the carpet starts 0.5 m ahead: the bottom rows are wood,
        // rows nearer the horizon are carpet, and the strip shows between them.
        let l = render_labels(&world, &cam, &at(3.5, 0.0));
        let bottom = l.data[(l.height - 1) * l.width + l.width / 2];
        assert_eq!(bottom, Surface::Wood.class_id());
        let col: Vec<u8> = (0..l.height)
            .map(|v| l.data[v * l.width + l.width / 2])
            .collect();
        assert!(col.contains(&Surface::Carpet.class_id()), "{col:?}");
        assert!(col.contains(&THRESHOLD_CLASS), "{col:?}");
        // Facing the end wall of the tile room, the top rows are wall.
        let l = render_labels(&world, &cam, &at(12.2, 0.0));
        assert_eq!(l.data[0], WALL_CLASS);
        assert_eq!(l.data[(l.height - 1) * l.width], Surface::Tile.class_id());
    }
}
