//! The per-point pyramidal iteration (Bouguet 2000, section 2.4) and the
//! batch [`Tracker`].

use crate::geometry::Vec2;
use crate::image::ImageView;
use crate::pyramid::Pyramid;

use super::affine;
use super::config::{LkConfig, LkConfigError, LkError, MAX_WINDOW};
use super::sample::{Bilinear, sample_clamped};
use super::{LostReason, TrackCounts, TrackResult, TrackStatus};

/// SIMD-friendly lane count of the window loops.
const LANES: usize = 8;
const AREA: usize = MAX_WINDOW * MAX_WINDOW;
const PATCH: usize = (MAX_WINDOW + 2) * (MAX_WINDOW + 2);

/// The template window of one point at one level: intensities, Scharr
/// gradients and the inverse of the spatial gradient matrix `G`.
pub(super) struct Template {
    pub(super) n: usize,
    pub(super) t: [f32; AREA],
    pub(super) gx: [f32; AREA],
    pub(super) gy: [f32; AREA],
    /// `G⁻¹` as `[a, b, c]` for `[[a, b], [b, c]]`.
    g_inv: [f32; 3],
    /// The sampled window with a one-pixel frame for the gradients.
    patch: [f32; PATCH],
}

/// Why a template could not be built.
enum TemplateFault {
    OutOfBounds,
    LowEigenvalue,
}

/// The sums one pass over the window yields.
struct Mismatch {
    /// `sum (T - J) gx`, `sum (T - J) gy`.
    b: Vec2,
    /// `sum |T - J|`.
    abs: f32,
}

impl Template {
    /// Samples the window of side `n` centred on `c` and its gradients.
    /// With `clamp`, a window hanging over the border repeats the edge pixels
    /// (the centre must still be inside); without, it is out of bounds.
    /// Storage for one template, filled per point and level by [`Template::fill`]
    /// (one instance serves a whole batch: no per-point zeroing of 16 KiB).
    fn empty() -> Self {
        Template {
            n: 0,
            t: [0.0; AREA],
            gx: [0.0; AREA],
            gy: [0.0; AREA],
            g_inv: [0.0; 3],
            patch: [0.0; PATCH],
        }
    }

    fn fill(
        &mut self,
        image: &ImageView<'_>,
        c: Vec2,
        n: usize,
        min_eig: f32,
        clamp: bool,
    ) -> Result<(), TemplateFault> {
        let half = (n / 2) as f32;
        let m = n + 2;
        let (x, y) = (c.x - half - 1.0, c.y - half - 1.0);
        let patch = &mut self.patch;
        let sampled = match Bilinear::new(image, x, y, m, m) {
            Some(window) => window.sample(image, patch),
            None => clamp && inside(image, c) && sample_clamped(image, x, y, m, m, patch),
        };
        if !sampled {
            return Err(TemplateFault::OutOfBounds);
        }
        self.n = n;
        let tpl = self;
        let patch_rows = tpl.patch.chunks_exact(m).take(m);
        let triples = patch_rows
            .clone()
            .zip(patch_rows.clone().skip(1))
            .zip(patch_rows.skip(2));
        let outs = tpl
            .t
            .chunks_exact_mut(n)
            .zip(tpl.gx.chunks_exact_mut(n))
            .zip(tpl.gy.chunks_exact_mut(n));
        // Scharr, row by row over shifted slices (left, centre, right taps).
        for (((p0, p1), p2), ((t, gx), gy)) in triples.zip(outs) {
            let ((Some(a0), Some(a1), Some(a2)), (Some(b0), Some(b1), Some(b2))) =
                (taps(p0, n), taps(p1, n))
            else {
                return Err(TemplateFault::OutOfBounds);
            };
            let (Some(c0), Some(c1), Some(c2)) = taps(p2, n) else {
                return Err(TemplateFault::OutOfBounds);
            };
            t.copy_from_slice(b1);
            let x_taps = a0
                .iter()
                .zip(a2)
                .zip(b0.iter().zip(b2))
                .zip(c0.iter().zip(c2));
            for (g, (((&a0, &a2), (&b0, &b2)), (&c0, &c2))) in gx.iter_mut().zip(x_taps) {
                *g = (3.0 * (a2 - a0) + 10.0 * (b2 - b0) + 3.0 * (c2 - c0)) * (1.0 / 32.0);
            }
            let y_taps = a0
                .iter()
                .zip(c0)
                .zip(a1.iter().zip(c1))
                .zip(a2.iter().zip(c2));
            for (g, (((&a0, &c0), (&a1, &c1)), (&a2, &c2))) in gy.iter_mut().zip(y_taps) {
                *g = (3.0 * (c0 - a0) + 10.0 * (c1 - a1) + 3.0 * (c2 - a2)) * (1.0 / 32.0);
            }
        }
        // G = sum [gx² gx·gy; gx·gy gy²], in lanes.
        let area_px = n * n;
        let (gx8, gx_rest) = tpl.gx.get(..area_px).unwrap_or(&[]).as_chunks::<LANES>();
        let (gy8, gy_rest) = tpl.gy.get(..area_px).unwrap_or(&[]).as_chunks::<LANES>();
        let (mut sxx, mut sxy, mut syy) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        for (gx, gy) in gx8.iter().zip(gy8) {
            let lanes = sxx.iter_mut().zip(sxy.iter_mut()).zip(syy.iter_mut());
            for (((xx, xy), yy), (&gx, &gy)) in lanes.zip(gx.iter().zip(gy)) {
                *xx += gx * gx;
                *xy += gx * gy;
                *yy += gy * gy;
            }
        }
        let (mut gxx, mut gxy, mut gyy) = (
            sxx.iter().sum::<f32>(),
            sxy.iter().sum::<f32>(),
            syy.iter().sum::<f32>(),
        );
        for (&gx, &gy) in gx_rest.iter().zip(gy_rest) {
            gxx += gx * gx;
            gxy += gx * gy;
            gyy += gy * gy;
        }
        let area = (n * n) as f32;
        let half_diff = 0.5 * (gxx - gyy);
        let lambda_min = 0.5 * (gxx + gyy) - libm::sqrtf(half_diff * half_diff + gxy * gxy);
        let det = gxx * gyy - gxy * gxy;
        let well_conditioned = lambda_min / area >= min_eig && det > f32::EPSILON * area * area;
        if !well_conditioned {
            return Err(TemplateFault::LowEigenvalue);
        }
        tpl.g_inv = [gyy / det, -gxy / det, gxx / det];
        Ok(())
    }

    /// One pass over the window centred on `c` in `image`: the right-hand
    /// side `b` and the absolute error, or `None` when the window is outside.
    #[inline]
    fn mismatch(&self, image: &ImageView<'_>, c: Vec2, clamp: bool) -> Option<Mismatch> {
        let n = self.n;
        let half = (n / 2) as f32;
        let Some(window) = Bilinear::new(image, c.x - half, c.y - half, n, n) else {
            return if clamp && inside(image, c) {
                self.mismatch_clamped(image, c)
            } else {
                None
            };
        };
        // Eight lanes in local arrays: the loop body is straight-line code
        // over fixed-size arrays, which the compiler turns into SIMD; each
        // lane sums its own columns, so no float sum is reassociated.
        let rows = self
            .t
            .chunks_exact(n)
            .zip(self.gx.chunks_exact(n))
            .zip(self.gy.chunks_exact(n))
            .take(n);
        let ay = window.ay();
        let (mut sx, mut sy, mut sa) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        let (mut tail_x, mut tail_y, mut tail_a) = (0.0f32, 0.0f32, 0.0f32);
        let (mut top, mut bottom) = ([0.0f32; MAX_WINDOW], [0.0f32; MAX_WINDOW]);
        let (mut h0, mut h1) = (top.get_mut(..n)?, bottom.get_mut(..n)?);
        window.horizontal(image, 0, h0)?;
        for (i, ((t, gx), gy)) in rows.enumerate() {
            window.horizontal(image, i + 1, h1)?;
            let (t8, t_rest) = t.as_chunks::<LANES>();
            let (gx8, gx_rest) = gx.as_chunks::<LANES>();
            let (gy8, gy_rest) = gy.as_chunks::<LANES>();
            let (a8, a_rest) = h0.as_chunks::<LANES>();
            let (b8, b_rest) = h1.as_chunks::<LANES>();
            let chunks = t8.iter().zip(gx8).zip(gy8).zip(a8.iter().zip(b8));
            for (((t, gx), gy), (a, b)) in chunks {
                let lanes = sx.iter_mut().zip(sy.iter_mut()).zip(sa.iter_mut());
                let pixels = t.iter().zip(gx).zip(gy).zip(a.iter().zip(b));
                for (((x, y), s), (((&t, &gx), &gy), (&a, &b))) in lanes.zip(pixels) {
                    let d = t - (a + ay * (b - a));
                    *x += d * gx;
                    *y += d * gy;
                    *s += d.abs();
                }
            }
            let rest = t_rest
                .iter()
                .zip(gx_rest)
                .zip(gy_rest)
                .zip(a_rest.iter().zip(b_rest));
            for (((&t, &gx), &gy), (&a, &b)) in rest {
                let d = t - (a + ay * (b - a));
                tail_x += d * gx;
                tail_y += d * gy;
                tail_a += d.abs();
            }
            core::mem::swap(&mut h0, &mut h1);
        }
        Some(Mismatch {
            b: Vec2::new(
                sx.iter().sum::<f32>() + tail_x,
                sy.iter().sum::<f32>() + tail_y,
            ),
            abs: sa.iter().sum::<f32>() + tail_a,
        })
    }

    /// [`Template::mismatch`] for a window over the border (slow path).
    fn mismatch_clamped(&self, image: &ImageView<'_>, c: Vec2) -> Option<Mismatch> {
        let n = self.n;
        let half = (n / 2) as f32;
        let mut j = [0.0f32; AREA];
        if !sample_clamped(image, c.x - half, c.y - half, n, n, &mut j) {
            return None;
        }
        let mut m = Mismatch {
            b: Vec2::zeros(),
            abs: 0.0,
        };
        let area = n * n;
        let pixels = self.t.iter().zip(&self.gx).zip(&self.gy).zip(&j).take(area);
        for (((t, gx), gy), j) in pixels {
            let d = t - j;
            m.b += Vec2::new(d * gx, d * gy);
            m.abs += libm::fabsf(d);
        }
        Some(m)
    }

    /// `G⁻¹ b`.
    fn solve(&self, b: &Vec2) -> Vec2 {
        let [a, o, c] = self.g_inv;
        Vec2::new(a * b.x + o * b.y, o * b.x + c * b.y)
    }
}

/// What one directed pass (previous to next) found for one point.
struct Pass {
    position: Vec2,
    status: TrackStatus,
    residual: f32,
    iterations: u32,
}

impl Pass {
    fn lost(position: Vec2, reason: LostReason) -> Self {
        Pass {
            position,
            status: TrackStatus::Lost(reason),
            residual: f32::INFINITY,
            iterations: 0,
        }
    }
}

/// A pyramidal Lucas-Kanade tracker with checked settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracker {
    config: LkConfig,
}

impl Tracker {
    /// Checks `config`.
    pub fn new(config: LkConfig) -> Result<Self, LkConfigError> {
        config.validate()?;
        Ok(Tracker { config })
    }

    /// The settings.
    pub fn config(&self) -> &LkConfig {
        &self.config
    }

    /// Tracks every point of `points` from `prev` into `next`, writing
    /// `results[i]` for `points[i]`, and counts the outcomes.
    pub fn track(
        &self,
        prev: &Pyramid<'_>,
        next: &Pyramid<'_>,
        points: &[Vec2],
        results: &mut [TrackResult],
    ) -> Result<TrackCounts, LkError> {
        check_sizes(prev, next)?;
        if results.len() < points.len() {
            return Err(LkError::OutputTooSmall {
                points: points.len(),
                results: results.len(),
            });
        }
        let mut counts = TrackCounts::default();
        let mut tpl = Template::empty();
        for (r, p) in results.iter_mut().zip(points) {
            *r = self.track_checked(prev, next, *p, None, &mut tpl);
            counts.record(r.status);
        }
        Ok(counts)
    }

    /// [`Tracker::track`] with a predicted position in `next` for each point
    /// (e.g. from odometry or a homography); `guesses` pairs with `points`.
    pub fn track_with_guesses(
        &self,
        prev: &Pyramid<'_>,
        next: &Pyramid<'_>,
        points: &[Vec2],
        guesses: &[Vec2],
        results: &mut [TrackResult],
    ) -> Result<TrackCounts, LkError> {
        check_sizes(prev, next)?;
        if results.len() < points.len() || guesses.len() < points.len() {
            return Err(LkError::OutputTooSmall {
                points: points.len(),
                results: results.len().min(guesses.len()),
            });
        }
        let mut counts = TrackCounts::default();
        let mut tpl = Template::empty();
        for ((r, p), g) in results.iter_mut().zip(points).zip(guesses) {
            *r = self.track_checked(prev, next, *p, Some(*g), &mut tpl);
            counts.record(r.status);
        }
        Ok(counts)
    }

    /// Tracks one point; `guess` is its predicted position in `next`
    /// (`None`: where it was).
    pub fn track_point(
        &self,
        prev: &Pyramid<'_>,
        next: &Pyramid<'_>,
        point: Vec2,
        guess: Option<Vec2>,
    ) -> Result<TrackResult, LkError> {
        check_sizes(prev, next)?;
        let mut tpl = Template::empty();
        Ok(self.track_checked(prev, next, point, guess, &mut tpl))
    }

    fn track_checked(
        &self,
        prev: &Pyramid<'_>,
        next: &Pyramid<'_>,
        point: Vec2,
        guess: Option<Vec2>,
        tpl: &mut Template,
    ) -> TrackResult {
        let guess = guess.unwrap_or(point);
        let fwd = self.pass(prev, next, point, guess, tpl);
        let mut result = TrackResult {
            position: fwd.position,
            status: fwd.status,
            residual: fwd.residual,
            fb_error: None,
            iterations: fwd.iterations,
        };
        if let (Some(threshold), TrackStatus::Tracked) = (self.config.fb_threshold, fwd.status) {
            // Tracked back from where it landed, without a hint of the answer.
            let back = self.pass(next, prev, fwd.position, fwd.position, tpl);
            let error = (back.position - point).norm();
            let home = back.status.is_tracked() && error <= threshold;
            result.fb_error = Some(if back.status.is_tracked() {
                error
            } else {
                f32::INFINITY
            });
            if !home {
                result.status = TrackStatus::Lost(LostReason::ForwardBackward);
            }
        }
        result
    }

    /// One pass from `from` into `to`, starting at `guess` (level 0 pixels).
    fn pass(
        &self,
        from: &Pyramid<'_>,
        to: &Pyramid<'_>,
        point: Vec2,
        guess: Vec2,
        tpl: &mut Template,
    ) -> Pass {
        let cfg = &self.config;
        let finite = |v: &Vec2| v.x.is_finite() && v.y.is_finite();
        if !finite(&point) || !finite(&guess) {
            return Pass::lost(guess, LostReason::InvalidPoint);
        }
        let levels = cfg.levels.min(from.levels()).min(to.levels()).max(1);
        let eps_sq = cfg.epsilon * cfg.epsilon;
        // The displacement guess at the current level.
        let mut flow = (guess - point) / (1u32 << (levels - 1)) as f32;
        let mut iterations = 0;
        let mut converged = false;
        let mut have_l0 = false;
        let mut last_abs = None;
        for level in (0..levels).rev() {
            let scale = 1.0 / (1u32 << level) as f32;
            let (Some(img_from), Some(img_to)) = (from.level(level), to.level(level)) else {
                return Pass::lost(point + flow, LostReason::OutOfBounds);
            };
            let u = point * scale;
            // Coarse levels let windows hang over the border (as OpenCV's padded
            // pyramids do); level 0 demands the whole window inside.
            let clamp = level > 0;
            match tpl.fill(&img_from, u, cfg.window, cfg.min_eigenvalue, clamp) {
                Ok(()) => {}
                Err(fault) => {
                    if level == 0 {
                        let reason = match fault {
                            TemplateFault::OutOfBounds => LostReason::OutOfBounds,
                            TemplateFault::LowEigenvalue => LostReason::LowEigenvalue,
                        };
                        return Pass::lost(point + flow, reason);
                    }
                    // Coarse levels that cannot help pass the guess down (as OpenCV).
                    flow *= 2.0;
                    continue;
                }
            };
            let mut v = u + flow;
            let mut previous_step = Vec2::zeros();
            converged = false;
            iterations = 0;
            last_abs = None;
            for k in 0..cfg.max_iterations {
                let Some(m) = tpl.mismatch(&img_to, v, clamp) else {
                    if level == 0 {
                        return Pass::lost(v, LostReason::OutOfBounds);
                    }
                    break;
                };
                let step = tpl.solve(&m.b);
                v += step;
                iterations = k + 1;
                if step.norm_squared() <= eps_sq {
                    converged = true;
                    // Measured within epsilon of where the point ends: reuse it.
                    last_abs = Some(m.abs);
                    break;
                }
                // A step that undoes the previous one: settle in the middle.
                if k > 0 && (step + previous_step).norm_squared() <= eps_sq {
                    v -= step * 0.5;
                    converged = true;
                    break;
                }
                previous_step = step;
            }
            flow = v - u;
            if level > 0 {
                flow *= 2.0;
            } else {
                have_l0 = true;
            }
        }
        let mut position = point + flow;
        if !have_l0 {
            return Pass::lost(position, LostReason::OutOfBounds);
        };
        if !finite(&position) {
            return Pass::lost(position, LostReason::NotConverged);
        }
        let Some(base) = to.level(0) else {
            return Pass::lost(position, LostReason::OutOfBounds);
        };
        let residual = if cfg.affine_refinement && converged {
            let Some(fit) = affine::refine(tpl, &base, position, cfg.max_iterations, cfg.epsilon)
            else {
                return Pass::lost(position, LostReason::OutOfBounds);
            };
            position = fit.center;
            converged = fit.converged;
            iterations += fit.iterations;
            fit.residual
        } else {
            let half = (cfg.window / 2) as f32;
            let (x, y) = (position.x - half, position.y - half);
            if Bilinear::new(&base, x, y, cfg.window, cfg.window).is_none() {
                return Pass::lost(position, LostReason::OutOfBounds);
            }
            let abs = match last_abs {
                Some(abs) => abs,
                None => match tpl.mismatch(&base, position, false) {
                    Some(m) => m.abs,
                    None => return Pass::lost(position, LostReason::OutOfBounds),
                },
            };
            abs / (cfg.window * cfg.window) as f32
        };
        let status = if !converged {
            TrackStatus::Lost(LostReason::NotConverged)
        } else if residual > cfg.max_residual || residual.is_nan() {
            TrackStatus::Lost(LostReason::LargeResidual)
        } else {
            TrackStatus::Tracked
        };
        Pass {
            position,
            status,
            residual,
            iterations,
        }
    }
}

/// The left, centre and right `n`-wide slices of a patch row (`n + 2` wide).
type Taps<'a> = (Option<&'a [f32]>, Option<&'a [f32]>, Option<&'a [f32]>);
fn taps(p: &[f32], n: usize) -> Taps<'_> {
    (p.get(..n), p.get(1..=n), p.get(2..n + 2))
}

/// `c` lies inside the image (pixel centres `0..=width-1`).
fn inside(image: &ImageView<'_>, c: Vec2) -> bool {
    c.x >= 0.0
        && c.y >= 0.0
        && c.x <= (image.width() - 1) as f32
        && c.y <= (image.height() - 1) as f32
}

fn check_sizes(prev: &Pyramid<'_>, next: &Pyramid<'_>) -> Result<(), LkError> {
    let (a, b) = (prev.base(), next.base());
    if a.width() != b.width() || a.height() != b.height() {
        return Err(LkError::SizeMismatch);
    }
    Ok(())
}
