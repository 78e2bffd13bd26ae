//! Test images for the LK and corner tests, benches and examples: load the
//! photographs, crop them, warp them by a known homography, shift them by a
//! known offset, or make a seeded random texture.

use std::path::{Path, PathBuf};

/// An owned 8-bit grayscale image.
pub struct Gray {
    pub data: Vec<u8>,
    pub width: usize,
    pub height: usize,
}

impl Gray {
    pub fn at(&self, x: usize, y: usize) -> u8 {
        self.data[y * self.width + x]
    }

    /// The `w x h` window with its top-left corner at `(x0, y0)`.
    pub fn crop(&self, x0: usize, y0: usize, w: usize, h: usize) -> Gray {
        assert!(x0 + w <= self.width && y0 + h <= self.height);
        let mut data = Vec::with_capacity(w * h);
        for y in y0..y0 + h {
            data.extend_from_slice(&self.data[y * self.width + x0..y * self.width + x0 + w]);
        }
        Gray {
            data,
            width: w,
            height: h,
        }
    }

    /// The centred `w x h` window.
    pub fn crop_centre(&self, w: usize, h: usize) -> Gray {
        self.crop((self.width - w) / 2, (self.height - h) / 2, w, h)
    }

    /// Bilinear sample with the edge pixels repeated outside.
    pub fn sample(&self, x: f64, y: f64) -> f64 {
        let xc = x.clamp(0.0, (self.width - 1) as f64);
        let yc = y.clamp(0.0, (self.height - 1) as f64);
        let (x0, y0) = (xc.floor() as usize, yc.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (ax, ay) = (xc - x0 as f64, yc - y0 as f64);
        let p = |x, y| f64::from(self.at(x, y));
        (1.0 - ay) * ((1.0 - ax) * p(x0, y0) + ax * p(x1, y0))
            + ay * ((1.0 - ax) * p(x0, y1) + ax * p(x1, y1))
    }

    /// The image seen after the homography `h`: `out(x) = self(h⁻¹ x)`, so a
    /// point `p` of `self` appears at `h p` in the result.
    pub fn warp(&self, h: &Homography) -> Gray {
        let inv = h.inverse();
        let mut data = vec![0u8; self.width * self.height];
        for y in 0..self.height {
            for x in 0..self.width {
                let (sx, sy) = inv.apply(x as f64, y as f64);
                data[y * self.width + x] = self.sample(sx, sy).round().clamp(0.0, 255.0) as u8;
            }
        }
        Gray {
            data,
            width: self.width,
            height: self.height,
        }
    }
}

/// The repository's `data/images` folder.
pub fn images_dir() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    for base in [
        here,
        here.parent().unwrap_or(here),
        here.parent().and_then(Path::parent).unwrap_or(here),
    ] {
        let d = base.join("data/images");
        if d.is_dir() {
            return d;
        }
    }
    panic!("data/images not found above {}", here.display());
}

/// Loads an 8-bit grayscale PNG of `data/images` (RGB is converted).
pub fn load(name: &str) -> Gray {
    let path = images_dir().join(name);
    let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0u8; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = info.color_type.samples();
    let data = buf[..info.buffer_size()]
        .chunks_exact(channels)
        .map(|px| match px {
            [g] | [g, _] => *g,
            [r, g, b] | [r, g, b, _] => {
                ((u32::from(*r) * 299 + u32::from(*g) * 587 + u32::from(*b) * 114) / 1000) as u8
            }
            _ => unreachable!(),
        })
        .collect();
    Gray {
        data,
        width: w,
        height: h,
    }
}

/// A 3x3 homography in `f64`, row-major.
#[derive(Clone, Copy, Debug)]
pub struct Homography(pub [[f64; 3]; 3]);

impl Homography {
    /// Rotation by `deg` degrees and scale `s` about `(cx, cy)`, then a shift
    /// `(tx, ty)`, with the perspective row `(px, py)` (applied about the centre).
    pub fn similarity_about(
        cx: f64,
        cy: f64,
        deg: f64,
        s: f64,
        tx: f64,
        ty: f64,
        px: f64,
        py: f64,
    ) -> Self {
        let (sn, cs) = deg.to_radians().sin_cos();
        let to_origin = Homography([[1.0, 0.0, -cx], [0.0, 1.0, -cy], [0.0, 0.0, 1.0]]);
        let core = Homography([[s * cs, -s * sn, tx], [s * sn, s * cs, ty], [px, py, 1.0]]);
        let back = Homography([[1.0, 0.0, cx], [0.0, 1.0, cy], [0.0, 0.0, 1.0]]);
        back.mul(&core).mul(&to_origin)
    }

    pub fn mul(&self, o: &Homography) -> Homography {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.0[i][k] * o.0[k][j]).sum();
            }
        }
        Homography(r)
    }

    pub fn apply(&self, x: f64, y: f64) -> (f64, f64) {
        let m = &self.0;
        let w = m[2][0] * x + m[2][1] * y + m[2][2];
        (
            (m[0][0] * x + m[0][1] * y + m[0][2]) / w,
            (m[1][0] * x + m[1][1] * y + m[1][2]) / w,
        )
    }

    pub fn inverse(&self) -> Homography {
        let m = &self.0;
        let c = |r0: usize, c0: usize, r1: usize, c1: usize| {
            m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
        };
        let adj = [
            [c(1, 1, 2, 2), -c(0, 1, 2, 2), c(0, 1, 1, 2)],
            [-c(1, 0, 2, 2), c(0, 0, 2, 2), -c(0, 0, 1, 2)],
            [c(1, 0, 2, 1), -c(0, 0, 2, 1), c(0, 0, 1, 1)],
        ];
        let det = m[0][0] * adj[0][0] + m[0][1] * adj[1][0] + m[0][2] * adj[2][0];
        Homography(adj.map(|row| row.map(|v| v / det)))
    }
}

/// The median of `v` (sorted in place), NaN-free input expected.
pub fn median(v: &mut [f64]) -> f64 {
    assert!(!v.is_empty());
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// A smooth random texture (white noise blurred twice by a 5x5 box, stretched
/// to 20..235), seeded.
pub fn texture(width: usize, height: usize, seed: u64) -> Gray {
    let mut state = seed
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    let mut noise: Vec<f64> = (0..width * height)
        .map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 33) % 256) as f64
        })
        .collect();
    for _ in 0..2 {
        let src = noise.clone();
        for y in 0..height {
            for x in 0..width {
                let mut s = 0.0;
                let mut k = 0.0;
                for yy in y.saturating_sub(2)..(y + 3).min(height) {
                    for xx in x.saturating_sub(2)..(x + 3).min(width) {
                        s += src[yy * width + xx];
                        k += 1.0;
                    }
                }
                noise[y * width + x] = s / k;
            }
        }
    }
    let (lo, hi) = noise
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
    let data = noise
        .iter()
        .map(|v| (20.0 + 215.0 * (v - lo) / (hi - lo).max(1e-9)).round() as u8)
        .collect();
    Gray {
        data,
        width,
        height,
    }
}

/// The image moved by `(dx, dy)`: a point `p` appears at `p + (dx, dy)`.
pub fn shifted(img: &Gray, dx: f64, dy: f64) -> Gray {
    img.warp(&Homography([
        [1.0, 0.0, dx],
        [0.0, 1.0, dy],
        [0.0, 0.0, 1.0],
    ]))
}
