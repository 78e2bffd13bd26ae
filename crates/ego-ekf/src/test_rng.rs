//! A seeded xorshift generator for the unit tests (no dependency).

use crate::state::Vec3;

/// xorshift64 with values in [-0.5, 0.5).
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    /// The next value, in [-0.5, 0.5).
    pub(crate) fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    }

    /// A vector of three values, each in [-scale / 2, scale / 2).
    pub(crate) fn vec3(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * scale
    }
}
