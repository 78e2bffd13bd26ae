//! The per-point pyramidal iteration (Bouguet 2000, section 2.4) and the
//! batch [`Tracker`].

use crate::geometry::Vec2;
use crate::pyramid::Pyramid;

use super::affine;
use super::config::{LkConfig, LkConfigError, LkError};
use super::sample::Bilinear;
use super::template::{Template, TemplateFault};
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

fn check_sizes(prev: &Pyramid<'_>, next: &Pyramid<'_>) -> Result<(), LkError> {
    let (a, b) = (prev.base(), next.base());
    if a.width() != b.width() || a.height() != b.height() {
        return Err(LkError::SizeMismatch);
    }
    Ok(())
}
