//! Gain and bias between the two images: the [`super::Illumination::GainBias`]
//! model.
//!
//! Lamps switching and exposure adapting change a window by a gain and a
//! bias, `J ≈ α T + β`, which the constant-brightness residual `T - J` of
//! Bouguet's tracker reads as a mismatch (and a pull on the update wherever
//! the window has a mean gradient). Following H. Jin, P. Favaro and
//! S. Soatto, "Real-Time Feature Tracking and Outlier Rejection with Changes
//! in Illumination", ICCV 2001 (an affine photometric model in the LK
//! iteration), each iteration here removes gain and bias from the moving
//! window before the residual: `J` is rescaled to the template's mean and
//! standard deviation, `J' = μT + (σT / σJ) (J - μJ)`, and `b = sum (T - J') g`.
//! The rescaling needs only the window sums `sum J`, `sum J²` and
//! `sum J g`, gathered in the same pass as the constant model's
//! `sum (T - J) g` (one kernel, [`Compensated`]). The track is judged by the
//! normalised residual `sqrt(2 (1 - ZNCC))` = RMS(T - J') / σT, with ZNCC the
//! zero-mean normalised cross-correlation of template and window
//! (J. P. Lewis, "Fast Normalized Cross-Correlation", Vision Interface 1995):
//! 0 for a match up to gain and bias, 2 for an inverted window; it does not
//! depend on the window's contrast, so one limit serves bright and dark
//! scenes. A flat window (no spread to rescale) cannot be matched: it gives
//! no update and an infinite residual, never a division by zero.

use crate::fsqrt::sqrtf;
use crate::geometry::Vec2;
use crate::image::ImageView;

use super::isa::{Isa, twins};
use super::template::{RowKernel, Template, TplRow};
use super::window::{self, LANES, Row};

/// Lanes of the gain-bias sums: four, as five or six sums of the tracker's
/// eight lanes do not stay in registers (and then do not vectorise: measured
/// 2.5 times the instructions).
const QUAD: usize = 4;

/// A window whose variance is below this (levels², about 0.01 level of
/// standard deviation) is flat: its gain is undefined.
const MIN_VARIANCE: f32 = 1e-4;
/// The variance comes from `sum J²/N - mean²`; below this fraction of
/// `sum J²/N` it is rounding (f32 sums of a few hundred terms in lanes).
const VARIANCE_ROUNDING: f32 = 1e-5;

/// The template's moments at one level: what the compensation needs of it.
pub(super) struct Moments {
    /// Pixels in the window.
    count: f32,
    /// Mean intensity `μT`.
    pub(super) mean: f32,
    /// Standard deviation `σT`.
    sigma: f32,
    /// `sum (T - μT)`: zero up to rounding.
    centred: f32,
    /// `sum (T - μT) [gx gy]`.
    tg: Vec2,
    /// `sum [gx gy]`.
    g: Vec2,
}

/// The template's moments, or `None` when it is flat (no spread to match).
pub(super) fn moments(tpl: &Template<'_>) -> Option<Moments> {
    let n = tpl.n;
    let count = (n * n) as f32;
    // Sums about the centre sample (near the mean, for precision), in lanes:
    // c = T - o: sum c, sum c², sum c gx, sum c gy, sum gx, sum gy.
    let o = tpl
        .t
        .get(n / 2)
        .and_then(|row| row.get(n / 2))
        .copied()
        .unwrap_or(0.0);
    let mut sums = [[0.0f32; QUAD]; 6];
    let rows = tpl.t.iter().zip(tpl.gx.iter()).zip(tpl.gy.iter()).take(n);
    for ((t, gx), gy) in rows {
        moments_row(o, [t, gx, gy, &tpl.mask], &mut sums);
    }
    let [sc, scc, scx, scy, sx, sy] = sums.map(|s| s.iter().sum::<f32>());
    let shift = sc / count;
    let mean = o + shift;
    let variance = scc / count - shift * shift;
    // Also refuses a NaN variance.
    if variance.partial_cmp(&MIN_VARIANCE) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let g = Vec2::new(sx, sy);
    Some(Moments {
        count,
        mean,
        sigma: sqrtf(variance),
        centred: sc - count * shift,
        tg: Vec2::new(scx, scy) - g * shift,
        g,
    })
}

/// One template row's terms of [`moments`] (the whole row in lanes; the
/// mask and the zero gradients past the window drop the padding).
#[inline(never)]
fn moments_row(o: f32, [t, gx, gy, mask]: [&TplRow; 4], sums: &mut [[f32; QUAD]; 6]) {
    let [sc, scc, scx, scy, sx, sy] = sums;
    let (t8, _) = t.as_chunks::<QUAD>();
    let (gx8, _) = gx.as_chunks::<QUAD>();
    let (gy8, _) = gy.as_chunks::<QUAD>();
    let (m8, _) = mask.as_chunks::<QUAD>();
    for (((t, gx), gy), m) in t8.iter().zip(gx8).zip(gy8).zip(m8) {
        let lanes = sc.iter_mut().zip(scc.iter_mut()).zip(scx.iter_mut());
        let lanes = lanes
            .zip(scy.iter_mut())
            .zip(sx.iter_mut())
            .zip(sy.iter_mut());
        let pixels = t.iter().zip(gx).zip(gy).zip(m);
        for ((((((a, b), x), y), u), v), (((&t, &gx), &gy), &m)) in lanes.zip(pixels) {
            let c = (t - o) * m;
            *a += c;
            *b += c * c;
            *x += c * gx;
            *y += c * gy;
            *u += gx;
            *v += gy;
        }
    }
}

/// The gain and bias that map a window onto the template.
pub(super) struct Photometric {
    /// `σT / σJ`.
    pub(super) gain: f32,
    /// `μJ - μT`.
    pub(super) offset: f32,
    /// `σJ`.
    sigma: f32,
}

/// The gain and bias from the window's sums `sum (J - μT)` and
/// `sum (J - μT)²` (offset by the template mean for precision); `None` when
/// the window is flat.
pub(super) fn fit(m: &Moments, sum: f32, sum_sq: f32) -> Option<Photometric> {
    let offset = sum / m.count;
    let second = sum_sq / m.count;
    let variance = second - offset * offset;
    let floor = VARIANCE_ROUNDING * second + MIN_VARIANCE;
    if variance.partial_cmp(&floor) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let sigma = sqrtf(variance);
    let gain = m.sigma / sigma;
    gain.is_finite().then_some(Photometric {
        gain,
        offset,
        sigma,
    })
}

/// `sqrt(2 (1 - ZNCC))` from `sum (T - μT)(J - μT)`; 0 to 2, infinite if
/// the sums were not finite.
pub(super) fn normalised_residual(m: &Moments, p: &Photometric, cross: f32) -> f32 {
    let covariance = cross - p.offset * m.centred;
    let zncc = covariance / (m.count * m.sigma * p.sigma);
    let r = sqrtf((2.0 * (1.0 - zncc)).clamp(0.0, 4.0));
    if r.is_finite() { r } else { f32::INFINITY }
}

/// The gain-compensated right-hand side `sum (T - J') [gx gy]` and, with
/// `measure`, the normalised residual (else 0) of the window centred on `c`;
/// `None` when the window is outside. A flat window gives no update and an
/// infinite residual.
pub(super) fn mismatch(
    tpl: &mut Template<'_>,
    image: &ImageView<'_>,
    c: Vec2,
    clamp: bool,
    measure: bool,
    m: &Moments,
) -> Option<(Vec2, f32)> {
    let sums = if measure {
        tpl.sweep(image, c, clamp, &Compensated::<true> { mean: m.mean })?
    } else {
        tpl.sweep(image, c, clamp, &Compensated::<false> { mean: m.mean })?
    };
    let [sx, sy, sum, sum_sq, tj] = sums.map(|s| s.iter().sum::<f32>());
    let Some(p) = fit(m, sum, sum_sq) else {
        return Some((Vec2::zeros(), f32::INFINITY));
    };
    // sum (J - μJ) g = sum (J - μT) g - (μJ - μT) sum g.
    let jg = Vec2::new(sx, sy) - m.g * p.offset;
    let b = m.tg - jg * p.gain;
    let residual = if measure {
        // sum (T - μT)(J - μT) = sum T (J - μT) - μT sum (J - μT).
        normalised_residual(m, &p, tj - m.mean * sum)
    } else {
        0.0
    };
    Some((b, residual))
}

/// The gain-bias kernel: with `J' = J - μT`, sums `J' gx`, `J' gy`, `J'`,
/// `J'²` and, with `CROSS`, `T J'`.
struct Compensated<const CROSS: bool> {
    /// `μT`.
    mean: f32,
}

impl<const CROSS: bool> RowKernel for Compensated<CROSS> {
    type Sums = [[f32; QUAD]; 5];
    #[inline(always)]
    fn row<const C: usize>(
        &self,
        isa: Isa,
        next: &[u8],
        weights: [f32; 2],
        h: [&mut Row; 2],
        tpl: [&TplRow; 4],
        sums: &mut [[f32; QUAD]; 5],
    ) {
        compensated_row::<C, CROSS>(isa, next, weights, h, tpl, self.mean, sums);
    }
}

twins! {
    /// One window row of the gain-bias kernel (out of line, as the constant
    /// model's row, so that it vectorises; in [`QUAD`] lanes, which keep the
    /// five sums in registers).
    fn compensated_row<const C: usize, const CROSS: bool>(
        isa,
        next: &[u8],
        weights: [f32; 2],
        h: [&mut Row; 2],
        tpl: [&TplRow; 4],
        mean: f32,
        sums: &mut [[f32; QUAD]; 5],
    ) => compensated_row_body;
}

#[inline(always)]
fn compensated_row_body<const C: usize, const CROSS: bool>(
    next: &[u8],
    [ax, ay]: [f32; 2],
    [h0, h1]: [&mut Row; 2],
    [t, gx, gy, mask]: [&TplRow; 4],
    mean: f32,
    sums: &mut [[f32; QUAD]; 5],
) {
    window::horizontal_inline::<C>(next, ax, h1);
    let [sx, sy, s1, s2, st] = sums;
    let (t4, _) = t.as_chunks::<QUAD>();
    let (gx4, _) = gx.as_chunks::<QUAD>();
    let (gy4, _) = gy.as_chunks::<QUAD>();
    let (a4, _) = h0.as_chunks::<QUAD>();
    let (b4, _) = h1.as_chunks::<QUAD>();
    let (m4, _) = mask.as_chunks::<QUAD>();
    let chunks = t4.iter().zip(gx4).zip(gy4).zip(a4.iter().zip(b4)).zip(m4);
    for ((((t, gx), gy), (a, b)), m) in chunks.take(C * LANES / QUAD) {
        let lanes = sx.iter_mut().zip(sy.iter_mut()).zip(s1.iter_mut());
        let lanes = lanes.zip(s2.iter_mut()).zip(st.iter_mut());
        let pixels = t.iter().zip(gx).zip(gy).zip(a.iter().zip(b)).zip(m);
        for (((((x, y), s1), s2), st), ((((&t, &gx), &gy), (&a, &b)), &m)) in lanes.zip(pixels) {
            let j = (a + ay * (b - a) - mean) * m;
            *x += j * gx;
            *y += j * gy;
            *s1 += j;
            *s2 += j * j;
            if CROSS {
                *st += t * j;
            }
        }
    }
}
