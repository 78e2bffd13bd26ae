//! RANSAC for homographies (Fischler & Bolles, CACM 24(6), 1981), with the
//! adaptive number of samples of Hartley & Zisserman, *Multiple View
//! Geometry*, 2nd ed., Algorithm 4.5 and eq. 4.18:
//!
//! `k = log(1 - p) / log(1 - w^4)`
//!
//! for confidence `p` and the inlier fraction `w` of the best model so far,
//! capped by [`RansacParams::max_iterations`]. The best consensus set is then
//! re-fitted by the normalised DLT (the "local optimisation" of Chum, Matas &
//! Kittler, DAGM 2003, in its simplest form: once before refinement, up to
//! three times while the set grows without it) and refined by
//! Levenberg-Marquardt on the transfer error ([`super::refine`]), the inlier
//! set updated after each round; the returned mask is that of the final `H`.
//!
//! Everything runs in Hartley-normalised coordinates computed once for all
//! points; since the normalisation is a similarity, the pixel threshold
//! becomes a normalised one by a single scale. Minimal samples are solved by
//! the projective-basis construction ([`super::four_point`]); samples with
//! duplicate or collinear points, or whose four triangles change orientation
//! between the images (impossible for a plane in front of both cameras), are
//! dropped before scoring. The PRNG is PCG32 (`oorandom`), seeded by the
//! caller: the same seed and data give the same result on every platform.

use super::dlt::DltAccumulator;
use super::four_point::solve_normalized;
use super::normalize::Normalization;
use super::refine::{RefineParams, levenberg_marquardt};
use super::{Homography, HomographyError};
use crate::geometry::{Mat3, Vec2};

/// Settings of [`HomographyRansac`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RansacParams {
    /// Largest one-sided transfer error `||x2 - H x1||` of an inlier, image-2
    /// pixels (> 0).
    pub threshold_px: f32,
    /// Probability that at least one sample is all inliers, in `(0, 1)`.
    pub confidence: f32,
    /// Hard cap on samples drawn (degenerate ones included), >= 1.
    pub max_iterations: u32,
    /// Fewest inliers a result must have, >= 4. A minimal sample always
    /// agrees with its own four points, so a model with 4 or 5 inliers carries
    /// next to no evidence; the default asks for 8.
    pub min_inliers: usize,
    /// Seed of the PRNG: equal seeds and data give equal results.
    pub seed: u64,
    /// Refine the consensus model by Levenberg-Marquardt.
    pub refine: bool,
    /// Settings of that refinement.
    pub refine_params: RefineParams,
}

impl Default for RansacParams {
    /// 3 px, confidence 0.995, at most 2000 samples, at least 8 inliers,
    /// seed 0, refined.
    fn default() -> Self {
        RansacParams {
            threshold_px: 3.0,
            confidence: 0.995,
            max_iterations: 2000,
            min_inliers: 8,
            seed: 0,
            refine: true,
            refine_params: RefineParams::default(),
        }
    }
}

impl RansacParams {
    /// Checks the ranges documented on the fields.
    ///
    /// # Errors
    /// [`HomographyError::InvalidParameter`].
    pub fn validate(&self) -> Result<(), HomographyError> {
        let ok = self.threshold_px.is_finite()
            && self.threshold_px > 0.0
            && self.confidence > 0.0
            && self.confidence < 1.0
            && self.max_iterations >= 1
            && self.min_inliers >= 4
            && self.refine_params.relative_tolerance.is_finite()
            && self.refine_params.relative_tolerance >= 0.0;
        if ok {
            Ok(())
        } else {
            Err(HomographyError::InvalidParameter)
        }
    }
}

/// What a RANSAC run found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RansacReport {
    /// The final homography (re-fitted and, if asked, refined on the inliers).
    pub homography: Homography,
    /// Correspondences marked inlier in the mask.
    pub inlier_count: usize,
    /// Correspondences given.
    pub point_count: usize,
    /// Samples drawn (degenerate ones included).
    pub iterations: u32,
    /// Samples dropped as degenerate before scoring.
    pub degenerate_samples: u32,
    /// RMS transfer error of the inliers under the final `H`, image-2 pixels.
    pub rms_error_px: f32,
    /// Whether the Levenberg-Marquardt refinement changed the estimate.
    pub refined: bool,
    /// Levenberg-Marquardt iterations run, over all refinement rounds.
    pub refine_iterations: u32,
}

impl RansacReport {
    /// Inliers over correspondences, in `[0, 1]`.
    pub fn inlier_ratio(&self) -> f32 {
        if self.point_count == 0 {
            0.0
        } else {
            self.inlier_count as f32 / self.point_count as f32
        }
    }
}

/// RANSAC homography estimator for up to `N` correspondences.
///
/// Owns its scratch (`2 N` normalised points, `16 N` bytes), so it can live
/// in a `static` on a microcontroller; no heap, no recursion.
#[derive(Clone, Debug)]
pub struct HomographyRansac<const N: usize> {
    params: RansacParams,
    norm1: [Vec2; N],
    norm2: [Vec2; N],
}

impl<const N: usize> HomographyRansac<N> {
    /// The largest number of correspondences one call accepts.
    pub const CAPACITY: usize = N;

    /// An estimator with checked parameters.
    ///
    /// # Errors
    /// [`HomographyError::InvalidParameter`] (see [`RansacParams::validate`]).
    pub fn new(params: RansacParams) -> Result<Self, HomographyError> {
        params.validate()?;
        Ok(HomographyRansac {
            params,
            norm1: [Vec2::zeros(); N],
            norm2: [Vec2::zeros(); N],
        })
    }

    /// The parameters.
    pub fn params(&self) -> &RansacParams {
        &self.params
    }

    /// Estimates `x2 ~ H x1` from `points1[i] -> points2[i]` and writes the
    /// inlier mask (`inliers[i]` is `true` for an inlier of the returned `H`).
    ///
    /// On error every mask entry is `false`.
    ///
    /// # Errors
    /// [`HomographyError::LengthMismatch`] (lists or mask differ in length),
    /// [`HomographyError::TooFewPoints`], [`HomographyError::TooManyPoints`]
    /// (more than `N`), [`HomographyError::NonFinite`],
    /// [`HomographyError::Degenerate`] (all points coincide),
    /// [`HomographyError::NoConsensus`] (no model with
    /// [`RansacParams::min_inliers`] inliers),
    /// [`HomographyError::NearSingular`].
    pub fn estimate(
        &mut self,
        points1: &[Vec2],
        points2: &[Vec2],
        inliers: &mut [bool],
    ) -> Result<RansacReport, HomographyError> {
        inliers.iter_mut().for_each(|m| *m = false);
        let result = self.run(points1, points2, inliers);
        if result.is_err() {
            inliers.iter_mut().for_each(|m| *m = false);
        }
        result
    }

    fn run(
        &mut self,
        points1: &[Vec2],
        points2: &[Vec2],
        inliers: &mut [bool],
    ) -> Result<RansacReport, HomographyError> {
        let n = points1.len();
        if points2.len() != n || inliers.len() != n {
            return Err(HomographyError::LengthMismatch);
        }
        if n < 4 {
            return Err(HomographyError::TooFewPoints { got: n });
        }
        if n > N {
            return Err(HomographyError::TooManyPoints {
                got: n,
                capacity: N,
            });
        }
        let n_u32 = u32::try_from(n).map_err(|_| HomographyError::TooManyPoints {
            got: n,
            capacity: N,
        })?;
        for (index, (a, b)) in points1.iter().zip(points2.iter()).enumerate() {
            if !(a.x.is_finite() && a.y.is_finite() && b.x.is_finite() && b.y.is_finite()) {
                return Err(HomographyError::NonFinite { index });
            }
        }
        let t1 = Normalization::from_points(points1.iter())?;
        let t2 = Normalization::from_points(points2.iter())?;
        for (d, s) in self.norm1.iter_mut().zip(points1.iter()) {
            *d = t1.apply(s);
        }
        for (d, s) in self.norm2.iter_mut().zip(points2.iter()) {
            *d = t2.apply(s);
        }
        let p = &self.params;
        let thr = p.threshold_px * t2.scale();
        let thr2 = thr * thr;
        if !(thr2 > 0.0) || !thr2.is_finite() {
            return Err(HomographyError::InvalidParameter);
        }
        let (a_all, b_all) = (
            self.norm1.get(..n).unwrap_or(&[]),
            self.norm2.get(..n).unwrap_or(&[]),
        );

        let mut rng = oorandom::Rand32::new(p.seed);
        let mut best: Option<Mat3> = None;
        let mut best_count = 0usize;
        let mut needed = p.max_iterations;
        let mut iterations = 0u32;
        let mut degenerate = 0u32;
        let log_fail = libm::logf(1.0 - p.confidence);
        while iterations < needed {
            iterations += 1;
            let idx = draw_four(&mut rng, n_u32);
            let pick = |s: &[Vec2]| idx.map(|i| s.get(i).copied().unwrap_or_else(Vec2::zeros));
            let (sa, sb) = (pick(a_all), pick(b_all));
            let Ok(h) = solve_normalized(&sa, &sb, true) else {
                degenerate += 1;
                continue;
            };
            let count = count_inliers(&h, a_all, b_all, thr2, best_count);
            if count > best_count {
                best_count = count;
                best = Some(h);
                needed = needed.min(adaptive_iterations(
                    best_count,
                    n,
                    log_fail,
                    p.max_iterations,
                ));
            }
        }
        let mut h = best.ok_or(HomographyError::NoConsensus)?;
        if best_count < p.min_inliers {
            return Err(HomographyError::NoConsensus);
        }
        mark_inliers(&h, a_all, b_all, thr2, inliers);

        // Local optimisation: re-fit on the consensus set while it grows.
        // With refinement one DLT re-fit suffices as the starting point: the
        // Levenberg-Marquardt rounds below re-fit and update the set again.
        let refits = if p.refine { 1 } else { 3 };
        for _ in 0..refits {
            let mut acc = DltAccumulator::new();
            for ((a, b), _) in a_all
                .iter()
                .zip(b_all.iter())
                .zip(inliers.iter())
                .filter(|(_, m)| **m)
            {
                acc.add(a, b, 1.0);
            }
            let Ok(refit) = acc.solve() else { break };
            let count = count_inliers(&refit, a_all, b_all, thr2, 0);
            if count < best_count {
                break;
            }
            let grew = count > best_count;
            h = refit;
            best_count = count;
            mark_inliers(&h, a_all, b_all, thr2, inliers);
            if !grew {
                break;
            }
        }

        let mut refined = false;
        let mut refine_iterations = 0u32;
        if p.refine {
            for _ in 0..3 {
                let pairs = || {
                    a_all
                        .iter()
                        .zip(b_all.iter())
                        .zip(inliers.iter())
                        .filter(|(_, m)| **m)
                        .map(|((a, b), _)| (*a, *b))
                };
                let out = levenberg_marquardt(&h, pairs, &p.refine_params);
                refine_iterations = refine_iterations.saturating_add(out.iterations);
                if out.iterations_accepted == 0 {
                    break;
                }
                let count = count_inliers(&out.h, a_all, b_all, thr2, 0);
                if count < p.min_inliers {
                    break;
                }
                h = out.h;
                refined = true;
                let before = best_count;
                best_count = count;
                let changed = mark_inliers(&h, a_all, b_all, thr2, inliers);
                if !changed && before == count {
                    break;
                }
            }
        }

        let count = mark_inliers_count(&h, a_all, b_all, thr2, inliers);
        if count < p.min_inliers {
            return Err(HomographyError::NoConsensus);
        }
        let homography = Normalization::denormalize(&t1, &t2, &h)?;
        let mut sum = 0.0f32;
        for ((a, b), _) in points1
            .iter()
            .zip(points2.iter())
            .zip(inliers.iter())
            .filter(|(_, m)| **m)
        {
            sum += homography.transfer_error_sq(a, b);
        }
        let rms_error_px = libm::sqrtf(sum / count as f32);
        Ok(RansacReport {
            homography,
            inlier_count: count,
            point_count: n,
            iterations,
            degenerate_samples: degenerate,
            rms_error_px,
            refined,
            refine_iterations,
        })
    }
}

/// Four distinct indices below `n` (`n >= 4`), uniformly.
#[inline]
fn draw_four(rng: &mut oorandom::Rand32, n: u32) -> [usize; 4] {
    let mut idx = [0u32; 4];
    let mut filled = 0usize;
    while filled < 4 {
        let i = rng.rand_range(0..n.max(1));
        if !idx.iter().take(filled).any(|&j| j == i) {
            if let Some(slot) = idx.get_mut(filled) {
                *slot = i;
            }
            filled += 1;
        }
    }
    idx.map(|i| i as usize)
}

/// Samples needed for confidence `p` (`log_fail = log(1 - p)`) when `inliers`
/// of `n` points are inliers: eq. 4.18 of Hartley & Zisserman, capped.
fn adaptive_iterations(inliers: usize, n: usize, log_fail: f32, cap: u32) -> u32 {
    let w = inliers as f32 / n.max(1) as f32;
    let w4 = w * w * w * w;
    if w4 >= 1.0 - f32::EPSILON {
        return 1;
    }
    let denom = libm::logf(1.0 - w4);
    if !(denom < 0.0) {
        return cap;
    }
    let k = libm::ceilf(log_fail / denom);
    if !(k < cap as f32) {
        cap
    } else {
        (k as u32).max(1)
    }
}

/// Squared transfer error of one normalised pair, `INFINITY` at infinity.
#[inline(always)]
fn error_sq(h: &Mat3, a: &Vec2, b: &Vec2) -> f32 {
    let w = h.m31 * a.x + h.m32 * a.y + h.m33;
    let u = h.m11 * a.x + h.m12 * a.y + h.m13 - b.x * w;
    let v = h.m21 * a.x + h.m22 * a.y + h.m23 - b.y * w;
    let e = (u * u + v * v) / (w * w);
    if e.is_nan() { f32::INFINITY } else { e }
}

/// Inliers of `h`; stops early once it cannot exceed `to_beat`.
#[inline]
fn count_inliers(h: &Mat3, a: &[Vec2], b: &[Vec2], thr2: f32, to_beat: usize) -> usize {
    let n = a.len();
    let mut count = 0usize;
    for (i, (p, q)) in a.iter().zip(b.iter()).enumerate() {
        if error_sq(h, p, q) <= thr2 {
            count += 1;
        } else if count + (n - i - 1) <= to_beat {
            return count;
        }
    }
    count
}

/// Writes the inlier mask of `h`; returns whether any entry changed.
fn mark_inliers(h: &Mat3, a: &[Vec2], b: &[Vec2], thr2: f32, mask: &mut [bool]) -> bool {
    let mut changed = false;
    for ((p, q), m) in a.iter().zip(b.iter()).zip(mask.iter_mut()) {
        let inlier = error_sq(h, p, q) <= thr2;
        changed |= inlier != *m;
        *m = inlier;
    }
    changed
}

/// Writes the inlier mask of `h`; returns the inlier count.
fn mark_inliers_count(h: &Mat3, a: &[Vec2], b: &[Vec2], thr2: f32, mask: &mut [bool]) -> usize {
    mark_inliers(h, a, b, thr2, mask);
    mask.iter().filter(|m| **m).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hartley & Zisserman, Table 4.3, sample size 4, p = 0.99.
    #[test]
    fn adaptive_count_matches_the_textbook_table() {
        let log_fail = libm::logf(1.0 - 0.99);
        let table = [
            (5, 3),
            (10, 5),
            (20, 9),
            (25, 13),
            (30, 17),
            (40, 34),
            (50, 72),
        ];
        for (outlier_percent, samples) in table {
            let inliers = 100 - outlier_percent;
            assert_eq!(
                adaptive_iterations(inliers, 100, log_fail, 10_000),
                samples,
                "{outlier_percent} % outliers"
            );
        }
        assert_eq!(adaptive_iterations(100, 100, log_fail, 10_000), 1);
        assert_eq!(adaptive_iterations(10, 100, log_fail, 500), 500);
        assert_eq!(adaptive_iterations(0, 100, log_fail, 500), 500);
    }

    #[test]
    fn draws_are_distinct_and_in_range() {
        let mut rng = oorandom::Rand32::new(5);
        for n in 4..12u32 {
            for _ in 0..200 {
                let idx = draw_four(&mut rng, n);
                for (i, a) in idx.iter().enumerate() {
                    assert!(*a < n as usize);
                    assert!(idx.iter().skip(i + 1).all(|b| b != a));
                }
            }
        }
    }
}
