//! The per-point pyramidal iteration (Bouguet 2000, section 2.4) and the
//! batch [`Tracker`].

use crate::geometry::Vec2;
use crate::image::ImageView;
use crate::pyramid::Pyramid;

use super::affine;
use super::config::MAX_WINDOW;
use super::config::{Illumination, LkConfig, LkConfigError, LkError};
use super::gain::{self, Moments};
use super::sample::Bilinear;
use super::template::{Template, TemplateFault, TemplateRows};
use super::{LostReason, TrackCounts, TrackResult, TrackStatus};

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
        Ok(self.with_template(|tpl| self.batch(prev, next, points, None, results, tpl)))
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
        Ok(self.with_template(|tpl| self.batch(prev, next, points, Some(guesses), results, tpl)))
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
        Ok(self.with_template(|tpl| self.track_checked(prev, next, point, guess, tpl)))
    }

    /// Runs `f` with a template on the stack sized for the configured
    /// window: rows for 7, 11, 21 or [`MAX_WINDOW`] pixels, whichever is the
    /// smallest that holds it (2.7, 4.2, 8.1 or 11.9 KB of rows; a 160x120
    /// front end's 7x7 window does not pay for a 31x31 one).
    fn with_template<T>(&self, f: impl FnOnce(&mut Template<'_>) -> T) -> T {
        match self.config.window {
            0..=7 => with_rows::<7, T>(f),
            8..=11 => with_rows::<11, T>(f),
            12..=21 => with_rows::<21, T>(f),
            _ => with_rows::<MAX_WINDOW, T>(f),
        }
    }

    /// Tracks `points[i]` (from `guesses[i]`, or from where it was) into
    /// `results[i]` with the template `tpl`, and counts the outcomes. Out of
    /// line: one copy of the tracker's code serves every template size.
    #[inline(never)]
    fn batch(
        &self,
        prev: &Pyramid<'_>,
        next: &Pyramid<'_>,
        points: &[Vec2],
        guesses: Option<&[Vec2]>,
        results: &mut [TrackResult],
        tpl: &mut Template<'_>,
    ) -> TrackCounts {
        let mut counts = TrackCounts::default();
        for (i, (r, p)) in results.iter_mut().zip(points).enumerate() {
            let guess = guesses.and_then(|g| g.get(i)).copied();
            *r = self.track_checked(prev, next, *p, guess, tpl);
            counts.record(r.status);
        }
        counts
    }

    fn track_checked(
        &self,
        prev: &Pyramid<'_>,
        next: &Pyramid<'_>,
        point: Vec2,
        guess: Option<Vec2>,
        tpl: &mut Template<'_>,
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
        tpl: &mut Template<'_>,
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
        let mut last_residual = None;
        let mut moments = None;
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
            // The gain-bias model needs the template's spread.
            moments = match cfg.illumination {
                Illumination::Constant => None,
                Illumination::GainBias { .. } => match gain::moments(tpl) {
                    Some(m) => Some(m),
                    None if level == 0 => {
                        return Pass::lost(point + flow, LostReason::LowEigenvalue);
                    }
                    None => {
                        flow *= 2.0;
                        continue;
                    }
                },
            };
            let mut v = u + flow;
            let eps_sq = match cfg.coarse_epsilon {
                Some(coarse) if level > 0 => coarse * coarse,
                _ => eps_sq,
            };
            let mut previous_step = Vec2::zeros();
            converged = false;
            iterations = 0;
            last_residual = None;
            for k in 0..cfg.max_iterations {
                let Some((step, residual)) =
                    self.mismatch(tpl, &img_to, v, clamp, level == 0, moments.as_ref())
                else {
                    if level == 0 {
                        return Pass::lost(v, LostReason::OutOfBounds);
                    }
                    break;
                };
                v += step;
                iterations = k + 1;
                if step.norm_squared() <= eps_sq {
                    converged = true;
                    // Measured within epsilon of where the point ends: reuse it.
                    last_residual = Some(residual);
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
            let (limit, epsilon) = (cfg.max_iterations, cfg.epsilon);
            let fit = affine::refine(tpl, &base, position, limit, epsilon, moments.as_ref());
            let Some(fit) = fit else {
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
            match last_residual {
                Some(residual) => residual,
                None => match self.mismatch(tpl, &base, position, false, true, moments.as_ref()) {
                    Some((_, residual)) => residual,
                    None => return Pass::lost(position, LostReason::OutOfBounds),
                },
            }
        };
        let max_residual = match cfg.illumination {
            Illumination::Constant => cfg.max_residual,
            Illumination::GainBias { max_residual } => max_residual,
        };
        let status = if !converged {
            TrackStatus::Lost(LostReason::NotConverged)
        } else if residual > max_residual || residual.is_nan() {
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

impl Tracker {
    /// One pass over the window centred on `c` in `image` under the
    /// configured illumination model (`moments`: the template's, for
    /// [`Illumination::GainBias`]): the update step and, with `measure`, the
    /// residual the track is judged by (else 0); `None` when the window is
    /// outside.
    #[inline]
    fn mismatch(
        &self,
        tpl: &mut Template<'_>,
        image: &ImageView<'_>,
        c: Vec2,
        clamp: bool,
        measure: bool,
        moments: Option<&Moments>,
    ) -> Option<(Vec2, f32)> {
        match moments {
            None => {
                let m = tpl.mismatch(image, c, clamp, measure)?;
                let residual = m.abs / (self.config.window * self.config.window) as f32;
                Some((tpl.solve(&m.b), residual))
            }
            Some(moments) => {
                let (b, residual) = gain::mismatch(tpl, image, c, clamp, measure, moments)?;
                Some((tpl.solve(&b), residual))
            }
        }
    }
}

/// Runs `f` with a template whose rows (for windows up to `R` pixels) are
/// on this call's stack frame.
#[inline(never)]
fn with_rows<const R: usize, T>(f: impl FnOnce(&mut Template<'_>) -> T) -> T {
    let mut rows = TemplateRows::<R>::zeroed();
    f(&mut Template::empty(&mut rows))
}

fn check_sizes(prev: &Pyramid<'_>, next: &Pyramid<'_>) -> Result<(), LkError> {
    let (a, b) = (prev.base(), next.base());
    if a.width() != b.width() || a.height() != b.height() {
        return Err(LkError::SizeMismatch);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::ImageView;
    use crate::lk::TrackResult;
    use crate::pyramid::{PyramidStorage, storage_bytes};

    const W: usize = 96;
    const H: usize = 80;

    /// A smooth texture, shifted by `(dx, dy)` pixels.
    fn frame(dx: f32, dy: f32) -> [u8; W * H] {
        let mut f = [0u8; W * H];
        for (i, p) in f.iter_mut().enumerate() {
            let (x, y) = ((i % W) as f32 - dx, (i / W) as f32 - dy);
            let v = 128.0
                + 50.0 * libm::sinf(0.31 * x + 0.17 * y)
                + 40.0 * libm::cosf(0.23 * y - 0.11 * x)
                + 20.0 * libm::sinf(0.07 * x * y / 9.0);
            *p = v.clamp(0.0, 255.0) as u8;
        }
        f
    }

    /// Runs `f` with the 3-level pyramids of [`frame`] and of it shifted
    /// by `(1.3, -0.7)` pixels.
    fn with_pyramids(f: impl FnOnce(&Pyramid<'_>, &Pyramid<'_>)) {
        let (a, b) = (frame(0.0, 0.0), frame(1.3, -0.7));
        let (va, vb) = (
            ImageView::packed(&a, W, H).unwrap(),
            ImageView::packed(&b, W, H).unwrap(),
        );
        let mut sa = PyramidStorage::<{ storage_bytes(W, H, 3) }>::new();
        let mut sb = PyramidStorage::<{ storage_bytes(W, H, 3) }>::new();
        let pa = Pyramid::build(&va, 3, &mut sa).unwrap();
        let pb = Pyramid::build(&vb, 3, &mut sb).unwrap();
        f(&pa, &pb);
    }

    /// `a` and `b` are the same tracks, bit for bit.
    fn assert_same_tracks(a: &[TrackResult], b: &[TrackResult], window: usize) {
        assert_eq!(a.len(), b.len());
        for (s, f) in a.iter().zip(b) {
            assert_eq!(s.status, f.status, "window {window}");
            assert_eq!(s.position.x.to_bits(), f.position.x.to_bits());
            assert_eq!(s.position.y.to_bits(), f.position.y.to_bits());
            assert_eq!(s.residual.to_bits(), f.residual.to_bits());
            assert_eq!(s.iterations, f.iterations);
        }
    }

    /// Every window gets the same tracks from its sized template as from
    /// one of [`MAX_WINDOW`] rows, bit for bit, with the affine refinement
    /// and the forward-backward check (which reuse the template).
    #[test]
    fn a_template_sized_for_the_window_tracks_as_the_largest() {
        with_pyramids(|pa, pb| {
            let points: [Vec2; 6] =
                core::array::from_fn(|i| Vec2::new(8.0 + 15.3 * i as f32, 6.0 + 12.7 * i as f32));
            for window in [3, 7, 9, 11, 13, 21, 23, 31] {
                for affine_refinement in [false, true] {
                    let config = LkConfig {
                        window,
                        affine_refinement,
                        fb_threshold: Some(0.5),
                        ..LkConfig::default()
                    };
                    let tracker = Tracker::new(config).unwrap();
                    let mut sized = [TrackResult::EMPTY; 6];
                    let counts = tracker.track(pa, pb, &points, &mut sized).unwrap();
                    let mut full = [TrackResult::EMPTY; 6];
                    with_rows::<MAX_WINDOW, _>(|tpl| {
                        tracker.batch(pa, pb, &points, None, &mut full, tpl)
                    });
                    assert!(counts.tracked > 0, "window {window}: nothing tracked");
                    assert_same_tracks(&sized, &full, window);
                }
            }
        });
    }

    /// The row kernels' AVX2 copies (where this CPU and build have them)
    /// give the baseline's tracks bit for bit: every window, both
    /// illumination models, with the affine refinement and the
    /// forward-backward check, points inside and over the border.
    #[test]
    fn the_detected_instruction_set_tracks_as_the_baseline() {
        use crate::lk::Illumination;
        use crate::lk::isa::Isa;
        with_pyramids(|pa, pb| {
            let points: [Vec2; 8] = core::array::from_fn(|i| match i {
                6 => Vec2::new(2.5, 3.25),
                7 => Vec2::new(W as f32 - 4.0, H as f32 - 3.5),
                _ => Vec2::new(8.0 + 15.3 * i as f32, 6.0 + 12.7 * i as f32),
            });
            let mut compared = 0;
            for window in [3, 5, 7, 9, 11, 13, 21, 23, 31] {
                for affine_refinement in [false, true] {
                    for illumination in [Illumination::Constant, Illumination::GAIN_BIAS] {
                        let config = LkConfig {
                            window,
                            affine_refinement,
                            illumination,
                            fb_threshold: Some(0.5),
                            ..LkConfig::default()
                        };
                        let tracker = Tracker::new(config).unwrap();
                        let run = |isa: Isa| {
                            let mut out = [TrackResult::EMPTY; 8];
                            with_rows::<MAX_WINDOW, _>(|tpl| {
                                tpl.isa = isa;
                                tpl.column_order = false;
                                tracker.batch(pa, pb, &points, None, &mut out, tpl)
                            });
                            out
                        };
                        let (base, fast) = (run(Isa::BASELINE), run(Isa::detect()));
                        assert_same_tracks(&base, &fast, window);
                        compared += base.iter().filter(|r| r.status.is_tracked()).count();
                    }
                }
            }
            assert!(compared > 100, "only {compared} tracks compared");
        });
    }

    /// With `std` on x86-64 the AVX2 copies run exactly when the CPU has
    /// AVX2; elsewhere the baseline always does.
    #[test]
    fn detection_follows_the_cpu() {
        use crate::lk::isa::Isa;
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            extern crate std;
            assert_eq!(Isa::detect().avx2(), std::is_x86_feature_detected!("avx2"));
        }
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        assert_eq!(Isa::detect(), Isa::BASELINE);
    }
}
