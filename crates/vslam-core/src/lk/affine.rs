//! Optional affine refinement at level 0.
//!
//! The translational model of Bouguet's tracker is biased when the window
//! rotates or scales between frames (a robot turning under a ceiling camera):
//! the estimate drifts toward the gradient-weighted centre of the window,
//! a tenth of a pixel for 1.5 degrees with a 21x21 window. After the
//! translational pass converges, this stage refines a 6-parameter affine warp
//! `y = c + A x` of the window (x relative to the template centre) with the
//! inverse compositional algorithm: S. Baker and I. Matthews, "Lucas-Kanade 20
//! Years On: A Unifying Framework", IJCV 56(3), 2004, section 3.2. The
//! steepest-descent images `[gx, gy, gx·x, gx·y, gy·x, gy·y]` (coordinates
//! scaled to [-1, 1] for conditioning) and the Hessian come from the template
//! once; each iteration samples the warped window and solves a 6x6 system by
//! the precomputed Cholesky factor. A weak Gaussian prior on the deformation
//! (a Tikhonov term in the normal equations, toward `A = I`) keeps windows
//! whose affine parameters are unobservable (one straight edge, a T junction
//! of bricks) from drifting. Under [`super::Illumination::GainBias`] the
//! warped window is rescaled to the template's mean and spread at every
//! iteration, as in the translational pass (`gain`).

use nalgebra::{Cholesky, Matrix2, Matrix6, U6, Vector6};

use crate::geometry::Vec2;
use crate::image::ImageView;

use super::gain::{self, Moments};
use super::template::Template;

/// Weight of the prior toward no deformation, relative to the window's mean
/// gradient energy: it keeps the deformation bounded where the window does
/// not constrain it (a straight edge, a T junction) and costs little bias
/// where it does.
const PRIOR: f32 = 0.05;

/// The refined warp.
pub(super) struct AffineFit {
    /// Where the template centre lands.
    pub center: Vec2,
    /// Mean absolute intensity difference at the final warp (the normalised
    /// residual under the gain-bias model).
    pub residual: f32,
    /// Whether the last step was below epsilon.
    pub converged: bool,
    /// Iterations spent.
    pub iterations: u32,
}

/// Refines from the translational result `start` (with `moments`, under the
/// gain-bias model); `None` when the warped window leaves the image or the
/// Hessian is singular.
pub(super) fn refine(
    tpl: &Template<'_>,
    image: &ImageView<'_>,
    start: Vec2,
    max_iterations: u32,
    epsilon: f32,
    moments: Option<&Moments>,
) -> Option<AffineFit> {
    let n = tpl.n;
    let half = (n / 2) as f32;
    let s = 1.0 / half;
    let mut hessian = Matrix6::<f32>::zeros();
    for_each_sd(tpl, s, |sd, _| hessian += sd * sd.transpose());
    // Prior toward no deformation: weight PRIOR of the mean gradient energy.
    let lambda = PRIOR * 0.5 * (hessian.m11 + hessian.m22);
    hessian += Matrix6::from_diagonal(&Vector6::new(0.0, 0.0, lambda, lambda, lambda, lambda));
    let chol: Cholesky<f32, U6> = Cholesky::new(hessian)?;
    let compensation = moments.map(|m| Compensation::new(tpl, s, m));
    let mut center = start;
    let mut a = Matrix2::<f32>::identity();
    let mut converged = false;
    let mut iterations = 0;
    for k in 0..max_iterations {
        let (mut b, _) = match &compensation {
            None => evaluate(tpl, image, center, &a, s)?,
            Some(c) => c.evaluate(tpl, image, center, &a, s)?,
        };
        // The prior's gradient: the current deformation in step units.
        let q = (a - Matrix2::identity()) / s;
        b += Vector6::new(0.0, 0.0, q.m11, q.m12, q.m21, q.m22) * lambda;
        let dp = chol.solve(&b);
        let delta = Vec2::new(dp.x, dp.y);
        let d = Matrix2::new(dp.z, dp.w, dp.a, dp.b) * s;
        let m = (Matrix2::identity() + d).try_inverse()?;
        // W <- W o W(dp)^-1: A <- A (I + D)^-1, c <- c - A (I + D)^-1 delta.
        a *= m;
        center -= a * delta;
        iterations = k + 1;
        if !(center.x.is_finite() && center.y.is_finite()) {
            return None;
        }
        // Largest motion of a window pixel, to first order.
        if dp.norm_squared() <= epsilon * epsilon {
            converged = true;
            break;
        }
    }
    let residual = match &compensation {
        None => evaluate(tpl, image, center, &a, s)?.1 / (n * n) as f32,
        Some(c) => c.evaluate(tpl, image, center, &a, s)?.1,
    };
    Some(AffineFit {
        center,
        residual,
        converged,
        iterations,
    })
}

/// Calls `f(sd, t)` with the steepest-descent vector and the template value
/// of every window pixel, in row-major order.
fn for_each_sd(tpl: &Template<'_>, s: f32, mut f: impl FnMut(Vector6<f32>, f32)) {
    let n = tpl.n;
    let half = (n / 2) as f32;
    let rows = tpl.t.iter().zip(tpl.gx.iter()).zip(tpl.gy.iter()).take(n);
    for (i, ((t, gx), gy)) in rows.enumerate() {
        let y = (i as f32 - half) * s;
        for (j, ((&t, &gx), &gy)) in t.iter().zip(gx).zip(gy).take(n).enumerate() {
            let x = (j as f32 - half) * s;
            f(Vector6::new(gx, gy, gx * x, gx * y, gy * x, gy * y), t);
        }
    }
}

/// `sum sd (J(W(x)) - T(x))` and `sum |J(W(x)) - T(x)|` at the warp `(c, A)`,
/// or `None` when the warped window leaves the image.
fn evaluate(
    tpl: &Template<'_>,
    image: &ImageView<'_>,
    c: Vec2,
    a: &Matrix2<f32>,
    s: f32,
) -> Option<(Vector6<f32>, f32)> {
    let mut b = Vector6::<f32>::zeros();
    let mut abs = 0.0f32;
    warped(tpl, image, c, a, s, |sd, t, v| {
        let e = v - t;
        b += sd * e;
        abs += libm::fabsf(e);
    })?;
    Some((b, abs))
}

/// What the gain-bias model needs of the template for the affine warp.
struct Compensation<'m> {
    moments: &'m Moments,
    /// `sum sd`.
    sd: Vector6<f32>,
    /// `sum sd (T - μT)`.
    sd_t: Vector6<f32>,
}

impl<'m> Compensation<'m> {
    fn new(tpl: &Template<'_>, s: f32, moments: &'m Moments) -> Self {
        let (mut sd_sum, mut sd_t) = (Vector6::zeros(), Vector6::zeros());
        for_each_sd(tpl, s, |sd, t| {
            sd_sum += sd;
            sd_t += sd * (t - moments.mean);
        });
        Compensation {
            moments,
            sd: sd_sum,
            sd_t,
        }
    }

    /// [`evaluate`] with the warped window rescaled to the template's mean
    /// and spread: `sum sd (J' - T)` and the normalised residual; a flat
    /// window gives no update and an infinite residual.
    fn evaluate(
        &self,
        tpl: &Template<'_>,
        image: &ImageView<'_>,
        c: Vec2,
        a: &Matrix2<f32>,
        s: f32,
    ) -> Option<(Vector6<f32>, f32)> {
        let mean = self.moments.mean;
        let (mut sd_j, mut sum, mut sum_sq, mut cross) = (Vector6::zeros(), 0.0, 0.0, 0.0);
        warped(tpl, image, c, a, s, |sd, t, v| {
            let j = v - mean;
            sd_j += sd * j;
            sum += j;
            sum_sq += j * j;
            cross += (t - mean) * j;
        })?;
        let Some(p) = gain::fit(self.moments, sum, sum_sq) else {
            return Some((Vector6::zeros(), f32::INFINITY));
        };
        // sum sd (J' - T) = gain sum sd (J - μJ) - sum sd (T - μT).
        let b = (sd_j - self.sd * p.offset) * p.gain - self.sd_t;
        Some((b, gain::normalised_residual(self.moments, &p, cross)))
    }
}

/// Calls `f(sd, t, j)` with the steepest-descent vector, the template value
/// and the warped window's value of every window pixel; `None` when the
/// warped window leaves the image.
fn warped(
    tpl: &Template<'_>,
    image: &ImageView<'_>,
    c: Vec2,
    a: &Matrix2<f32>,
    s: f32,
    mut f: impl FnMut(Vector6<f32>, f32, f32),
) -> Option<()> {
    let half = (tpl.n / 2) as f32;
    // The window maps to a parallelogram: its four corners inside (with the
    // bilinear neighbour) keep every pixel inside.
    let (w, h) = (image.width() as f32 - 1.0, image.height() as f32 - 1.0);
    for (cx, cy) in [(-half, -half), (half, -half), (-half, half), (half, half)] {
        let p = c + a * Vec2::new(cx, cy);
        if !(p.x >= 0.0 && p.y >= 0.0 && p.x < w && p.y < h) {
            return None;
        }
    }
    let (n, mut j, mut ok) = (tpl.n, 0usize, true);
    for_each_sd(tpl, s, |sd, t| {
        let (col, row) = ((j % n) as f32 - half, (j / n) as f32 - half);
        j += 1;
        let p = c + a * Vec2::new(col, row);
        match bilinear(image, p.x, p.y) {
            Some(v) => f(sd, t, v),
            None => ok = false,
        }
    });
    ok.then_some(())
}

/// One bilinear sample; the caller has checked `(x, y)` is inside.
#[inline(always)]
fn bilinear(image: &ImageView<'_>, x: f32, y: f32) -> Option<f32> {
    let (fx, fy) = (libm::floorf(x), libm::floorf(y));
    let (ax, ay) = (x - fx, y - fy);
    let (x0, y0) = (fx as usize, fy as usize);
    let top = image.row(y0)?.get(x0..x0 + 2)?;
    let bottom = image.row(y0 + 1)?.get(x0..x0 + 2)?;
    let (&[p00, p01], &[p10, p11]) = (top, bottom) else {
        return None;
    };
    let [p00, p01, p10, p11] = [p00, p01, p10, p11].map(f32::from);
    Some((1.0 - ay) * ((1.0 - ax) * p00 + ax * p01) + ay * ((1.0 - ax) * p10 + ax * p11))
}
