//! Levenberg-Marquardt refinement of a homography on its inliers,
//! minimising the one-sided transfer error `sum ||x2 - H x1||^2` in image 2
//! (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., sec. 4.2.2 eq.
//! 4.6 and appendix A6.2; the same cost OpenCV's `findHomography` refines).
//!
//! The DLT minimises an algebraic error that weights points by their `w`;
//! this step moves the estimate to the geometric (maximum-likelihood for
//! noise in image 2) optimum. It works in Hartley-normalised coordinates with
//! `H_n[2][2] = 1` fixed (the centroid of the points cannot map to infinity for
//! a valid estimate, so that gauge is safe) and 8 free parameters; the normal
//! equations are small (8x8) and solved by Cholesky, with Marquardt's damping
//! `J^T J + lambda diag(J^T J)`.

use super::four_point::check_conditioning;
use super::normalize::Normalization;
use super::{Homography, HomographyError};
use crate::geometry::{Mat3, Vec2};
use nalgebra::{SMatrix, SVector};

type Mat8 = SMatrix<f32, 8, 8>;

/// Damped steps tried per iteration before giving up (lambda grows 10x each).
const MAX_REJECTED_STEPS: usize = 6;

/// A step below this fraction of the largest entry of `H` is converged.
const STEP_TOLERANCE: f32 = 1e-6;
type Vec8 = SVector<f32, 8>;

/// Settings of the Levenberg-Marquardt refinement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineParams {
    /// Most iterations (accepted or rejected steps).
    pub max_iterations: u32,
    /// Stop when a step lowers the cost by less than this fraction.
    pub relative_tolerance: f32,
}

impl Default for RefineParams {
    fn default() -> Self {
        RefineParams {
            max_iterations: 20,
            relative_tolerance: 1e-6,
        }
    }
}

/// What the refinement did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineReport {
    /// The refined homography.
    pub homography: Homography,
    /// Iterations run.
    pub iterations: u32,
    /// RMS transfer error before, image-2 pixels.
    pub initial_rms_px: f32,
    /// RMS transfer error after, image-2 pixels.
    pub final_rms_px: f32,
}

/// Refines `h` on the correspondences selected by `mask` (all if `mask` is
/// empty) by Levenberg-Marquardt on the one-sided transfer error.
///
/// Never makes the cost worse: if no step helps, `h` comes back unchanged.
///
/// # Errors
/// [`HomographyError::LengthMismatch`], [`HomographyError::TooFewPoints`]
/// (fewer than 4 selected), [`HomographyError::NonFinite`],
/// [`HomographyError::Degenerate`] (all selected points coincide).
pub fn refine_homography(
    h: &Homography,
    points1: &[Vec2],
    points2: &[Vec2],
    mask: &[bool],
    params: &RefineParams,
) -> Result<RefineReport, HomographyError> {
    if points1.len() != points2.len() || !(mask.is_empty() || mask.len() == points1.len()) {
        return Err(HomographyError::LengthMismatch);
    }
    let selected = |i: usize| mask.is_empty() || mask.get(i).copied().unwrap_or(false);
    let pairs = || {
        points1
            .iter()
            .zip(points2.iter())
            .enumerate()
            .filter(move |(i, _)| selected(*i))
            .map(|(_, p)| p)
    };
    let mut count = 0usize;
    for (index, (a, b)) in points1.iter().zip(points2.iter()).enumerate() {
        if selected(index)
            && !(a.x.is_finite() && a.y.is_finite() && b.x.is_finite() && b.y.is_finite())
        {
            return Err(HomographyError::NonFinite { index });
        }
        count += usize::from(selected(index));
    }
    if count < 4 {
        return Err(HomographyError::TooFewPoints { got: count });
    }
    let t1 = Normalization::from_points(pairs().map(|(a, _)| a))?;
    let t2 = Normalization::from_points(pairs().map(|(_, b)| b))?;
    let hn = t2.matrix() * h.matrix() * t1.inverse_matrix();
    let normalized = || pairs().map(|(a, b)| (t1.apply(a), t2.apply(b)));
    let out = levenberg_marquardt(&hn, normalized, params);
    let to_px = 1.0 / t2.scale();
    let homography = if out.iterations_accepted > 0 {
        Normalization::denormalize(&t1, &t2, &out.h).unwrap_or(*h)
    } else {
        *h
    };
    Ok(RefineReport {
        homography,
        iterations: out.iterations,
        initial_rms_px: out.initial_rms * to_px,
        final_rms_px: out.final_rms * to_px,
    })
}

/// Result of [`levenberg_marquardt`] in normalised coordinates.
pub(crate) struct LmOutcome {
    /// The refined matrix (the input if nothing was accepted).
    pub h: Mat3,
    pub iterations: u32,
    pub iterations_accepted: u32,
    /// RMS transfer error before and after, normalised image-2 units.
    pub initial_rms: f32,
    pub final_rms: f32,
}

/// Sum of squared transfer errors and the count; `INFINITY` if a point maps
/// to infinity.
#[inline]
fn cost<I: Iterator<Item = (Vec2, Vec2)>>(h: &Mat3, pairs: I) -> (f32, usize) {
    let mut sum = 0.0f32;
    let mut n = 0usize;
    for (a, b) in pairs {
        let w = h.m31 * a.x + h.m32 * a.y + h.m33;
        if !(libm::fabsf(w) > 1e-6) {
            return (f32::INFINITY, n);
        }
        let u = (h.m11 * a.x + h.m12 * a.y + h.m13) / w - b.x;
        let v = (h.m21 * a.x + h.m22 * a.y + h.m23) / w - b.y;
        sum += u * u + v * v;
        n += 1;
    }
    (sum, n)
}

/// Levenberg-Marquardt on the one-sided transfer error of normalised pairs.
pub(crate) fn levenberg_marquardt<F, I>(hn: &Mat3, pairs: F, params: &RefineParams) -> LmOutcome
where
    F: Fn() -> I,
    I: Iterator<Item = (Vec2, Vec2)>,
{
    let rms = |c: f32, n: usize| libm::sqrtf(c / (n.max(1) as f32));
    let (c0, n0) = cost(hn, pairs());
    let unchanged = LmOutcome {
        h: *hn,
        iterations: 0,
        iterations_accepted: 0,
        initial_rms: rms(c0, n0),
        final_rms: rms(c0, n0),
    };
    // Gauge: H_n[2][2] = 1.
    if !(libm::fabsf(hn.m33) > 1e-3 * hn.norm()) || !c0.is_finite() {
        return unchanged;
    }
    let mut h = hn / hn.m33;
    let (gauged, n) = cost(&h, pairs());
    if !gauged.is_finite() || n < 4 {
        return unchanged;
    }
    // Dividing by `H[2][2]` can cost a rounding error: a step must beat the
    // input's own cost, or the result could be worse than the input.
    let mut current = gauged.min(c0);
    let mut lambda = 1e-3f32;
    let mut iterations = 0;
    let mut accepted = 0;
    while iterations < params.max_iterations {
        iterations += 1;
        let mut jtj = Mat8::zeros();
        let mut jtr = Vec8::zeros();
        for (a, b) in pairs() {
            let w = h.m31 * a.x + h.m32 * a.y + h.m33;
            if !(libm::fabsf(w) > 1e-6) {
                continue;
            }
            let iw = 1.0 / w;
            let u = (h.m11 * a.x + h.m12 * a.y + h.m13) * iw;
            let v = (h.m21 * a.x + h.m22 * a.y + h.m23) * iw;
            let (x, y) = (a.x * iw, a.y * iw);
            let ju = Vec8::from([x, y, iw, 0.0, 0.0, 0.0, -u * x, -u * y]);
            let jv = Vec8::from([0.0, 0.0, 0.0, x, y, iw, -v * x, -v * y]);
            jtj.syger(1.0, &ju, &ju, 1.0);
            jtj.syger(1.0, &jv, &jv, 1.0);
            jtr.axpy(u - b.x, &ju, 1.0);
            jtr.axpy(v - b.y, &jv, 1.0);
        }
        jtj.fill_upper_triangle_with_lower_triangle();
        let mut improved = false;
        let mut converged = false;
        // Try a few damped steps until one lowers the cost.
        for _ in 0..MAX_REJECTED_STEPS {
            let damping = jtj.diagonal().map(|d| lambda * d.max(1e-9));
            let damped = jtj + Mat8::from_diagonal(&damping);
            let Some(chol) = damped.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let step = chol.solve(&(-jtr));
            // Steps at f32 resolution of H cannot change anything: converged.
            if step.amax() <= STEP_TOLERANCE * h.amax() {
                converged = true;
                break;
            }
            let [s0, s1, s2, s3, s4, s5, s6, s7]: [f32; 8] = step.into();
            let candidate = h + Mat3::new(s0, s1, s2, s3, s4, s5, s6, s7, 0.0);
            let (c, _) = cost(&candidate, pairs());
            if c.is_finite() && c < current && check_conditioning(&candidate).is_ok() {
                let gain = (current - c) / current.max(f32::MIN_POSITIVE);
                h = candidate;
                current = c;
                lambda = (lambda * 0.1).max(1e-7);
                improved = true;
                accepted += 1;
                converged = gain < params.relative_tolerance;
                break;
            }
            lambda *= 10.0;
        }
        if !improved || converged {
            break;
        }
    }
    LmOutcome {
        h,
        iterations,
        iterations_accepted: accepted,
        initial_rms: rms(c0, n0),
        final_rms: rms(current, n),
    }
}
