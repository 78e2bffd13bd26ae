//! A robust running estimate of the scale.
//!
//! Under a planar ceiling the scale `s` is the camera-to-ceiling distance
//! `d`, nearly constant from frame to frame. A median over a fixed window
//! (capacity `N` in the type, no allocator) with the median absolute
//! deviation as spread (Hampel identifier: `sigma ~ 1.4826 MAD`, Rousseeuw &
//! Croux 1993) ignores single bad values and flags them.

use heapless::Deque;

/// `1.4826 * MAD` estimates sigma for Gaussian data.
pub const MAD_TO_SIGMA: f32 = 1.4826;

/// The running estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobustEstimate {
    /// Median of the window.
    pub scale: f32,
    /// Robust sigma of the window (`1.4826 MAD`, floored at `rel_floor * scale`).
    pub sigma: f32,
    /// Values in the window.
    pub count: u16,
}

impl RobustEstimate {
    /// How many sigmas `s` lies from the median.
    pub fn z(&self, s: f32) -> f32 {
        let z = libm::fabsf(s - self.scale) / self.sigma;
        if z.is_finite() { z } else { f32::INFINITY }
    }
}

/// Settings of the running scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobustParams {
    /// Values needed before the estimate is reported and outliers are flagged.
    pub min_count: u16,
    /// A value further than this many sigmas is an outlier.
    pub gate_sigmas: f32,
    /// Sigma floor relative to the median (a window of equal values has MAD 0).
    pub rel_floor: f32,
}

impl Default for RobustParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl RobustParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = RobustParams {
        min_count: 5,
        gate_sigmas: 4.0,
        rel_floor: 0.02,
    };
}

/// What one new value did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobustUpdate {
    /// The value lay beyond the gate of the estimate before it.
    pub outlier: bool,
    /// Its distance in sigmas from the previous estimate, if there was one.
    pub z: Option<f32>,
    /// The estimate after the value.
    pub estimate: Option<RobustEstimate>,
}

/// Median/MAD over the last `N` positive finite values.
#[derive(Clone, Debug)]
pub struct RobustScale<const N: usize> {
    params: RobustParams,
    window: Deque<f32, N>,
}

impl<const N: usize> RobustScale<N> {
    /// An empty window.
    pub const fn new(params: RobustParams) -> Self {
        RobustScale {
            params,
            window: Deque::new(),
        }
    }

    /// The settings.
    pub fn params(&self) -> &RobustParams {
        &self.params
    }

    /// Forgets every value.
    pub fn clear(&mut self) {
        self.window.clear();
    }

    /// Forgets every value and takes `params`, as [`RobustScale::new`].
    pub fn reset(&mut self, params: RobustParams) {
        self.params = params;
        self.window.clear();
    }

    /// The estimate, once `min_count` values are in.
    pub fn estimate(&self) -> Option<RobustEstimate> {
        let n = self.window.len();
        if n == 0 || n < usize::from(self.params.min_count) {
            return None;
        }
        let mut buf = [0.0f32; N];
        for (b, v) in buf.iter_mut().zip(self.window.iter()) {
            *b = *v;
        }
        let vals = buf.get_mut(..n)?;
        let med = median_in_place(vals)?;
        for v in vals.iter_mut() {
            *v = libm::fabsf(*v - med);
        }
        let mad = median_in_place(vals)?;
        let sigma = (MAD_TO_SIGMA * mad)
            .max(self.params.rel_floor * med)
            .max(f32::MIN_POSITIVE);
        Some(RobustEstimate {
            scale: med,
            sigma,
            count: n as u16,
        })
    }

    /// Whether `s` would be flagged against the current estimate.
    pub fn is_outlier(&self, s: f32) -> bool {
        !(s.is_finite() && s > 0.0)
            || self
                .estimate()
                .is_some_and(|e| e.z(s) > self.params.gate_sigmas)
    }

    /// Judges `s` against the current estimate, then adds it (non-positive or
    /// non-finite values are flagged and not added). The median absorbs single
    /// bad values; a lasting change (a new room's ceiling) takes over after
    /// half a window.
    pub fn push(&mut self, s: f32) -> RobustUpdate {
        let before = self.estimate();
        let z = before.map(|e| e.z(s));
        let outlier = self.is_outlier(s);
        if s.is_finite() && s > 0.0 {
            if self.window.is_full() {
                self.window.pop_front();
            }
            let _ = self.window.push_back(s);
        }
        RobustUpdate {
            outlier,
            z,
            estimate: self.estimate(),
        }
    }
}

/// Median of `v` (sorted in place, NaN sorted last by `total_cmp`); `None` when empty.
pub fn median_in_place(v: &mut [f32]) -> Option<f32> {
    v.sort_unstable_by(|a, b| a.total_cmp(b));
    let n = v.len();
    let hi = *v.get(n / 2)?;
    if n % 2 == 1 {
        Some(hi)
    } else {
        Some(0.5 * (hi + *v.get(n / 2 - 1)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_bad_values_are_flagged_and_do_not_move_the_median() {
        let mut r: RobustScale<9> = RobustScale::new(RobustParams::default());
        for s in [2.0, 2.02, 1.98, 2.01, 1.99] {
            assert!(!r.push(s).outlier);
        }
        let u = r.push(3.5);
        assert!(u.outlier);
        assert!((u.estimate.unwrap().scale - 2.0).abs() < 0.011);
        assert!(r.push(f32::NAN).outlier);
        assert!(r.push(-1.0).outlier);
        assert_eq!(r.estimate().unwrap().count, 6);
    }

    #[test]
    fn a_lasting_change_takes_over() {
        let mut r: RobustScale<7> = RobustScale::new(RobustParams::default());
        for _ in 0..7 {
            r.push(2.0);
        }
        for _ in 0..4 {
            r.push(2.5);
        }
        assert_eq!(r.estimate().unwrap().scale, 2.5);
    }
}
