//! The per-point pyramidal iteration (Bouguet 2000, section 2.4) and the
//! batch [`Tracker`].

use crate::geometry::Vec2;
use crate::image::ImageView;
use crate::pyramid::Pyramid;

use super::affine;
use super::config::{LkConfig, LkConfigError, LkError, MAX_WINDOW};
use super::sample::Bilinear;
use super::window::{self, LANES, MAX_CHUNKS, ROW, Row, SRC, SourceRows};
use super::{LostReason, TrackCounts, TrackResult, TrackStatus};

/// The template window of one point at one level: intensities, Scharr
/// gradients (zero past column `n`, so padded columns add nothing) and the
/// inverse of the spatial gradient matrix `G`; rows are [`Row`]s.
pub(super) struct Template {
    pub(super) n: usize,
    pub(super) t: [TplRow; MAX_WINDOW],
    pub(super) gx: [TplRow; MAX_WINDOW],
    pub(super) gy: [TplRow; MAX_WINDOW],
    /// 1 for the `n` window columns, 0 for the padding.
    mask: TplRow,
    /// `G⁻¹` as `[a, b, c]` for `[[a, b], [b, c]]`.
    g_inv: [f32; 3],
    /// Three consecutive rows of the sampled window with its one-pixel
    /// frame (the gradients' support), used as a ring while filling.
    patch: [Row; 3],
    /// A copied source row (near edges) and two horizontally interpolated
    /// rows: scratch of [`Template::mismatch`], kept here so that no call
    /// zeroes buffers.
    src: [u8; SRC],
    rows: [Row; 2],
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
    /// `sum |T - J|` (only when asked for, else 0).
    abs: f32,
}

impl Template {
    /// Storage for one template, filled per point and level by [`Template::fill`]
    /// (one instance serves a whole batch: no per-point zeroing of 12 KiB).
    fn empty() -> Self {
        Template {
            n: 0,
            t: [[0.0; TPL]; MAX_WINDOW],
            gx: [[0.0; TPL]; MAX_WINDOW],
            gy: [[0.0; TPL]; MAX_WINDOW],
            mask: [0.0; TPL],
            g_inv: [0.0; 3],
            patch: [[0.0; ROW]; 3],
            src: [0; SRC],
            rows: [[0.0; ROW]; 2],
        }
    }

    /// Samples the window of side `n` centred on `c` and its gradients.
    /// With `clamp`, a window hanging over the border repeats the edge pixels
    /// (the centre must still be inside); without, it is out of bounds.
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
        let clamp = clamp && inside(image, c);
        let Some(src) = SourceRows::new(image, x, y, m, m, clamp) else {
            return Err(TemplateFault::OutOfBounds);
        };
        if n > MAX_WINDOW {
            return Err(TemplateFault::OutOfBounds);
        }
        self.n = n;
        for (k, v) in self.mask.iter_mut().enumerate() {
            *v = if k < n { 1.0 } else { 0.0 };
        }
        // (patch chunks, window chunks) for n = 3..=31, odd.
        let [gxx, gxy, gyy] = match (window::chunks(m), window::chunks(n)) {
            (1, _) => self.sample::<1, 1>(image, &src),
            (2, 1) => self.sample::<2, 1>(image, &src),
            (2, _) => self.sample::<2, 2>(image, &src),
            (3, 2) => self.sample::<3, 2>(image, &src),
            (3, _) => self.sample::<3, 3>(image, &src),
            (4, 3) => self.sample::<4, 3>(image, &src),
            (4, _) => self.sample::<4, 4>(image, &src),
            _ => self.sample::<MAX_CHUNKS, 4>(image, &src),
        };
        let area = (n * n) as f32;
        let half_diff = 0.5 * (gxx - gyy);
        let lambda_min = 0.5 * (gxx + gyy) - libm::sqrtf(half_diff * half_diff + gxy * gxy);
        let det = gxx * gyy - gxy * gxy;
        let well_conditioned = lambda_min / area >= min_eig && det > f32::EPSILON * area * area;
        if !well_conditioned {
            return Err(TemplateFault::LowEigenvalue);
        }
        self.g_inv = [gyy / det, -gxy / det, gxx / det];
        Ok(())
    }

    /// Samples the `n + 2` square patch (`P` chunks wide) row by row into
    /// the ring `self.patch`; once three rows are there, the template row
    /// between them and its Scharr gradients (`C` chunks wide) follow.
    /// Returns the sums `[gxx, gxy, gyy]` of `G`.
    #[inline(always)]
    fn sample<const P: usize, const C: usize>(
        &mut self,
        image: &ImageView<'_>,
        src: &SourceRows,
    ) -> [f32; 3] {
        let Template {
            n,
            t,
            gx,
            gy,
            mask,
            patch: [r0, r1, r2],
            src: buf,
            rows: [top, bottom],
            ..
        } = self;
        let mut sums = [[0.0f32; LANES]; 3];
        let (mut h0, mut h1) = (top, bottom);
        let need = P * LANES + 1;
        let weights = [src.ax, src.ay];
        window::horizontal::<P>(src.row(image, 0, need, buf), src.ax, h0);
        let inside = src.inside_rows(image);
        let (data, mut start, stride) = inside.unwrap_or((&[], 0, 0));
        let outputs = t.iter_mut().zip(gx.iter_mut()).zip(gy.iter_mut());
        let mut outputs = outputs.take(*n);
        // Ring slots: the oldest, the middle and the newest patch row.
        let (mut a, mut b, mut c) = (r0, r1, r2);
        for i in 0..*n + 2 {
            // Inside: the source rows are stride apart in the image buffer.
            start = start.saturating_add(stride);
            let next = match data.get(start..start.saturating_add(need)) {
                Some(next) if inside.is_some() => next,
                _ => src.row(image, i + 1, need, buf),
            };
            // The new row goes where the oldest was.
            patch_row::<P>(next, weights, [h0, h1], a);
            core::mem::swap(&mut h0, &mut h1);
            (a, b, c) = (b, c, a);
            if i >= 2
                && let Some(((t, gx), gy)) = outputs.next()
            {
                gradient_row::<C>([&*a, &*b, &*c], mask, [t, gx, gy], &mut sums);
            }
        }
        let [sxx, sxy, syy] = sums;
        [
            sxx.iter().sum::<f32>(),
            sxy.iter().sum::<f32>(),
            syy.iter().sum::<f32>(),
        ]
    }

    /// One pass over the window centred on `c` in `image`: the right-hand
    /// side `b` and, with `with_abs`, the absolute error; `None` when the
    /// window is outside (with `clamp`, only when its centre is).
    #[inline]
    fn mismatch(
        &mut self,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        with_abs: bool,
    ) -> Option<Mismatch> {
        let n = self.n;
        let half = (n / 2) as f32;
        let clamp = clamp && inside(image, c);
        let src = SourceRows::new(image, c.x - half, c.y - half, n, n, clamp)?;
        Some(match (window::chunks(n), with_abs) {
            (1, false) => self.mismatch_in::<1, false>(image, &src),
            (2, false) => self.mismatch_in::<2, false>(image, &src),
            (3, false) => self.mismatch_in::<3, false>(image, &src),
            (_, false) => self.mismatch_in::<4, false>(image, &src),
            (1, true) => self.mismatch_in::<1, true>(image, &src),
            (2, true) => self.mismatch_in::<2, true>(image, &src),
            (3, true) => self.mismatch_in::<3, true>(image, &src),
            (_, true) => self.mismatch_in::<4, true>(image, &src),
        })
    }

    /// [`Template::mismatch`] for rows of `C` chunks. Eight lanes in local
    /// arrays: the loop body is straight-line code over fixed-size arrays,
    /// which the compiler turns into SIMD; each lane sums its own columns.
    #[inline(always)]
    fn mismatch_in<const C: usize, const ABS: bool>(
        &mut self,
        image: &ImageView<'_>,
        src: &SourceRows,
    ) -> Mismatch {
        let mut sums = [[0.0f32; LANES]; 3];
        let Template {
            n,
            t,
            gx,
            gy,
            mask,
            src: buf,
            rows: [top, bottom],
            ..
        } = self;
        let (mut h0, mut h1) = (top, bottom);
        let need = C * LANES + 1;
        let weights = [src.ax, src.ay];
        window::horizontal::<C>(src.row(image, 0, need, buf), src.ax, h0);
        let rows = t.iter().zip(gx.iter()).zip(gy.iter()).take(*n);
        if let Some((data, mut start, stride)) = src.inside_rows(image) {
            // Inside: the source rows are stride apart in the image buffer.
            for (i, ((t, gx), gy)) in rows.enumerate() {
                start = start.saturating_add(stride);
                let next = match data.get(start..start.saturating_add(need)) {
                    Some(next) => next,
                    None => src.row(image, i + 1, need, buf),
                };
                mismatch_row::<C, ABS>(next, weights, [h0, h1], [t, gx, gy, mask], &mut sums);
                core::mem::swap(&mut h0, &mut h1);
            }
        } else {
            for (i, ((t, gx), gy)) in rows.enumerate() {
                let next = src.row(image, i + 1, need, buf);
                mismatch_row::<C, ABS>(next, weights, [h0, h1], [t, gx, gy, mask], &mut sums);
                core::mem::swap(&mut h0, &mut h1);
            }
        }
        let [sx, sy, sa] = sums;
        Mismatch {
            b: Vec2::new(sx.iter().sum::<f32>(), sy.iter().sum::<f32>()),
            abs: sa.iter().sum::<f32>(),
        }
    }

    /// `G⁻¹ b`.
    fn solve(&self, b: &Vec2) -> Vec2 {
        let [a, o, c] = self.g_inv;
        Vec2::new(a * b.x + o * b.y, o * b.x + c * b.y)
    }
}

/// One patch row: the next source row `next` interpolated horizontally into
/// `h1`, then blended with the previous one `h0` into `out` (out of line,
/// like [`mismatch_row`]).
#[inline(never)]
fn patch_row<const P: usize>(
    next: &[u8],
    [ax, ay]: [f32; 2],
    [h0, h1]: [&mut Row; 2],
    out: &mut Row,
) {
    window::horizontal_inline::<P>(next, ax, h1);
    window::vertical::<P>(h0, h1, ay, out);
}

/// One template row from three patch rows: the template (centre row,
/// shifted by one), the Scharr gradients masked to the window, and the
/// products `gx², gx gy, gy²` per lane into `sums` (out of line, like
/// [`mismatch_row`]).
#[inline(never)]
fn gradient_row<const C: usize>(
    [p0, p1, p2]: [&Row; 3],
    mask: &TplRow,
    [t, gx, gy]: [&mut TplRow; 3],
    sums: &mut [[f32; LANES]; 3],
) {
    let width = C * LANES;
    // Separable Scharr: smooth [3 10 3] down the columns and difference
    // across (gx), difference down the columns and smooth across (gy).
    let (mut smooth, mut diff) = ([0.0f32; ROW], [0.0f32; ROW]);
    for (((s, d), &a), (&b, &c)) in smooth
        .iter_mut()
        .zip(diff.iter_mut())
        .zip(p0)
        .zip(p1.iter().zip(p2))
    {
        *s = 3.0 * (a + c) + 10.0 * b;
        *d = c - a;
    }
    let (Some((s0, _, s2)), Some((d0, d1, d2)), Some((_, centre, _))) =
        (taps(&smooth), taps(&diff), taps(p1))
    else {
        return;
    };
    t.copy_from_slice(centre);
    for ((g, &m), (&s0, &s2)) in gx.iter_mut().zip(mask).zip(s0.iter().zip(s2)).take(width) {
        *g = (s2 - s0) * (m / 32.0);
    }
    let y_taps = d0.iter().zip(d1).zip(d2);
    for ((g, &m), ((&d0, &d1), &d2)) in gy.iter_mut().zip(mask).zip(y_taps).take(width) {
        *g = (3.0 * (d0 + d2) + 10.0 * d1) * (m / 32.0);
    }
    // G = sum [gx² gx·gy; gx·gy gy²], in lanes.
    let [sxx, sxy, syy] = sums;
    let (gx8, _) = gx.as_chunks::<LANES>();
    let (gy8, _) = gy.as_chunks::<LANES>();
    for (gx, gy) in gx8.iter().zip(gy8).take(C) {
        let lanes = sxx.iter_mut().zip(sxy.iter_mut()).zip(syy.iter_mut());
        for (((xx, xy), yy), (&gx, &gy)) in lanes.zip(gx.iter().zip(gy)) {
            *xx += gx * gx;
            *xy += gx * gy;
            *yy += gy * gy;
        }
    }
}

/// One window row of [`Template::mismatch`]: interpolates the next source
/// row `next` horizontally into `h1`; then with `d = T - J` and
/// `J = h0 + ay (h1 - h0)` adds `d gx`, `d gy` and (with `ABS`) `|d|` per
/// lane into `sums`. Kept out of line: inlined into the large caller, the
/// compiler stops vectorising it.
#[inline(never)]
fn mismatch_row<const C: usize, const ABS: bool>(
    next: &[u8],
    [ax, ay]: [f32; 2],
    [h0, h1]: [&mut Row; 2],
    [t, gx, gy, mask]: [&TplRow; 4],
    sums: &mut [[f32; LANES]; 3],
) {
    window::horizontal_inline::<C>(next, ax, h1);
    let [sx, sy, sa] = sums;
    let (t8, _) = t.as_chunks::<LANES>();
    let (gx8, _) = gx.as_chunks::<LANES>();
    let (gy8, _) = gy.as_chunks::<LANES>();
    let (a8, _) = h0.as_chunks::<LANES>();
    let (b8, _) = h1.as_chunks::<LANES>();
    let (m8, _) = mask.as_chunks::<LANES>();
    let chunks = t8.iter().zip(gx8).zip(gy8).zip(a8.iter().zip(b8)).zip(m8);
    for ((((t, gx), gy), (a, b)), m) in chunks.take(C) {
        let lanes = sx.iter_mut().zip(sy.iter_mut()).zip(sa.iter_mut());
        let pixels = t.iter().zip(gx).zip(gy).zip(a.iter().zip(b)).zip(m);
        for (((x, y), s), ((((&t, &gx), &gy), (&a, &b)), &m)) in lanes.zip(pixels) {
            let d = t - (a + ay * (b - a));
            *x += d * gx;
            *y += d * gy;
            if ABS {
                *s += d.abs() * m;
            }
        }
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
            let eps_sq = match cfg.coarse_epsilon {
                Some(coarse) if level > 0 => coarse * coarse,
                _ => eps_sq,
            };
            let mut previous_step = Vec2::zeros();
            converged = false;
            iterations = 0;
            last_abs = None;
            for k in 0..cfg.max_iterations {
                let Some(m) = tpl.mismatch(&img_to, v, clamp, level == 0) else {
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
                None => match tpl.mismatch(&base, position, false, true) {
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

/// Width of the template rows the gradients fill (`MAX_WINDOW` rounded up to lanes).
const TPL: usize = MAX_WINDOW.div_ceil(LANES) * LANES;
/// One template row: intensities, gradients or the column mask.
pub(super) type TplRow = [f32; TPL];

/// The left, centre and right [`TPL`]-wide views of a patch row.
type Taps<'a> = (&'a [f32; TPL], &'a [f32; TPL], &'a [f32; TPL]);
fn taps(p: &Row) -> Option<Taps<'_>> {
    Some((
        p.first_chunk::<TPL>()?,
        p.get(1..)?.first_chunk::<TPL>()?,
        p.get(2..)?.first_chunk::<TPL>()?,
    ))
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
