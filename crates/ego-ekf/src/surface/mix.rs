//! A blend of floor kinds: the fraction of the ground in view that each
//! [`SurfaceKind`] covers. Fractions are non-negative and sum to one.

use super::classes::SurfaceKind;

/// Fractions of ground per [`SurfaceKind`], summing to one.
///
/// Built only through checked constructors, so a `SurfaceMix` always holds
/// finite, non-negative fractions with sum one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMix {
    fractions: [f32; SurfaceKind::COUNT],
}

impl SurfaceMix {
    /// All of the ground is `kind`.
    pub fn pure(kind: SurfaceKind) -> Self {
        let mut fractions = [0.0; SurfaceKind::COUNT];
        if let Some(f) = fractions.get_mut(kind.index()) {
            *f = 1.0;
        }
        SurfaceMix { fractions }
    }

    /// Normalises non-negative weights per kind (slot order of
    /// [`SurfaceKind::ALL`]). Negative or non-finite weights count as zero;
    /// `None` if nothing positive remains.
    pub fn from_weights(weights: &[f32; SurfaceKind::COUNT]) -> Option<Self> {
        let mut clean = [0.0f32; SurfaceKind::COUNT];
        for (c, w) in clean.iter_mut().zip(weights.iter()) {
            *c = if w.is_finite() && *w > 0.0 { *w } else { 0.0 };
        }
        let total: f32 = clean.iter().sum();
        if !(total.is_finite() && total > 0.0) {
            return None;
        }
        for c in clean.iter_mut() {
            *c /= total;
        }
        Some(SurfaceMix { fractions: clean })
    }

    /// The fraction of `kind`.
    pub fn fraction(&self, kind: SurfaceKind) -> f32 {
        self.fractions.get(kind.index()).copied().unwrap_or(0.0)
    }

    /// All fractions, in slot order of [`SurfaceKind::ALL`].
    pub fn fractions(&self) -> &[f32; SurfaceKind::COUNT] {
        &self.fractions
    }

    /// `(kind, fraction)` for every kind with a non-zero fraction.
    pub fn iter(&self) -> impl Iterator<Item = (SurfaceKind, f32)> + '_ {
        SurfaceKind::ALL
            .iter()
            .copied()
            .zip(self.fractions.iter().copied())
            .filter(|(_, f)| *f > 0.0)
    }

    /// The mix of the other kinds, renormalised; `None` when `kind` is all
    /// of it.
    pub fn without(&self, kind: SurfaceKind) -> Option<SurfaceMix> {
        let mut weights = self.fractions;
        if let Some(w) = weights.get_mut(kind.index()) {
            *w = 0.0;
        }
        SurfaceMix::from_weights(&weights)
    }

    /// The kind with the largest fraction (the first one on ties).
    pub fn dominant(&self) -> SurfaceKind {
        let mut best = SurfaceKind::Wood;
        let mut best_f = -1.0f32;
        for (k, f) in SurfaceKind::ALL.iter().zip(self.fractions.iter()) {
            if *f > best_f {
                best = *k;
                best_f = *f;
            }
        }
        best
    }

    /// `(1 - w) * self + w * other`, with `w` clamped to `[0, 1]` (NaN -> 0).
    pub fn blend(&self, other: &SurfaceMix, w: f32) -> SurfaceMix {
        let w = if w.is_nan() { 0.0 } else { w.clamp(0.0, 1.0) };
        let mut weights = [0.0f32; SurfaceKind::COUNT];
        for ((o, a), b) in weights
            .iter_mut()
            .zip(self.fractions.iter())
            .zip(other.fractions.iter())
        {
            *o = (1.0 - w) * a + w * b;
        }
        SurfaceMix::from_weights(&weights).unwrap_or(*self)
    }
}
