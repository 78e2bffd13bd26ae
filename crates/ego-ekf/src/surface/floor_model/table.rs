//! The perceptron's weights in the order one cell's scores read them
//! ([`MlpTable`]), and the scores from that order.
//!
//! Each hidden unit's record holds its input weights, its bias and its
//! seven output weights back to back, so one pass over the table computes a
//! cell's scores: on Arm cores with a floating-point unit (`floor_model::arm`,
//! built for those targets only) whole records are loaded a few registers at
//! a time (`VLDM`), elsewhere [`MlpTable::scores`] reads them in Rust. Both
//! add the same products in the same order as [`MlpWeights::scores`], so the
//! scores have the same bits.

use super::{CLASSES, FEATURES, HIDDEN, MlpWeights};

/// Floats of one hidden unit's record: its input weights, its bias, then
/// its weight in each class's score.
pub const UNIT: usize = FEATURES + 1 + CLASSES;

/// [`MlpWeights`] laid out for one pass per cell (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct MlpTable {
    /// Subtracted from each feature.
    pub(super) mean: [f32; FEATURES],
    /// Multiplies each centred feature.
    pub(super) scale: [f32; FEATURES],
    /// Where each class's score starts: `-0.0` (the empty sum).
    pub(super) start: [f32; CLASSES],
    /// One record per hidden unit ([`UNIT`] floats).
    pub(super) units: [[f32; UNIT]; HIDDEN],
    /// Added to each class's score last.
    pub(super) b2: [f32; CLASSES],
}

impl MlpTable {
    /// The table of `w`.
    #[allow(clippy::indexing_slicing)] // i < FEATURES, j < HIDDEN, k < CLASSES: the arrays' lengths
    pub const fn new(w: &MlpWeights) -> Self {
        let mut units = [[0.0f32; UNIT]; HIDDEN];
        let mut j = 0;
        while j < HIDDEN {
            let mut i = 0;
            while i < FEATURES {
                units[j][i] = w.w1[j][i];
                i += 1;
            }
            units[j][FEATURES] = w.b1[j];
            let mut k = 0;
            while k < CLASSES {
                units[j][FEATURES + 1 + k] = w.w2[k][j];
                k += 1;
            }
            j += 1;
        }
        MlpTable {
            mean: w.mean,
            scale: w.scale,
            start: [-0.0; CLASSES],
            units,
            b2: w.b2,
        }
    }

    /// Class scores (logits) for one feature vector: [`MlpWeights::scores`]
    /// bit for bit (a non-finite feature may give a NaN of other bits).
    #[inline]
    pub fn scores(&self, f: &[f32; FEATURES]) -> [f32; CLASSES] {
        #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
        if let Some(s) = super::arm::scores(self, f) {
            return s;
        }
        self.scores_portable(f)
    }

    /// [`MlpTable::scores`] in Rust on every target.
    pub fn scores_portable(&self, f: &[f32; FEATURES]) -> [f32; CLASSES] {
        let mut x = [0.0f32; FEATURES];
        for ((xi, fi), (m, s)) in x.iter_mut().zip(f).zip(self.mean.iter().zip(&self.scale)) {
            *xi = (fi - m) * s;
        }
        let mut out = self.start;
        for record in &self.units {
            let Some((row, rest)) = record.split_first_chunk::<FEATURES>() else {
                continue;
            };
            let Some((b, ws)) = rest.split_first() else {
                continue;
            };
            let a: f32 = row.iter().zip(&x).map(|(w, v)| w * v).sum::<f32>() + b;
            // ReLU as a compare (`f32::max` is a call to the software
            // `fmaxf` on a Cortex-M4, which has no `VMAXNM`).
            if a > 0.0 {
                for (o, w) in out.iter_mut().zip(ws) {
                    *o += w * a;
                }
            }
        }
        for (o, b) in out.iter_mut().zip(&self.b2) {
            *o += b;
        }
        out
    }
}
