//! What the floor means for the wheel measurement.
//!
//! The surface model (segmentation map -> ground classes -> grip table) sets
//! these parameters; the filter's wheel update reads them. Low grip is noise,
//! a wider gate and an expected slip in the wheel measurement's mean, never
//! an error.

use core::fmt;

/// Wheel-measurement parameters implied by the current floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GripParams {
    grip: f32,
    forward_std: f32,
    lateral_std: f32,
    forward_gate: f32,
    jolt_threshold: f32,
    slip: f32,
    learn_radius: bool,
}

/// Why grip parameters were refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GripError {
    /// The grip coefficient must lie in (0, 1].
    GripOutOfRange,
    /// Standard deviations, gate and jolt threshold must be finite and positive.
    NotPositive,
}

impl fmt::Display for GripError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            GripError::GripOutOfRange => "grip coefficient must lie in (0, 1]",
            GripError::NotPositive => "noise, gate and jolt threshold must be finite and positive",
        })
    }
}

impl core::error::Error for GripError {}

impl Default for GripParams {
    /// A hard floor with good grip (wood-like).
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl GripParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = GripParams {
        grip: 0.95,
        forward_std: 0.02,
        lateral_std: 0.01,
        forward_gate: 6.63, // chi-square, 1 DOF, 99 %
        jolt_threshold: 2.0,
        slip: 0.0,
        learn_radius: true,
    };
}

impl GripParams {
    /// Checks and builds the parameters.
    ///
    /// - `grip`: coefficient in (0, 1], 1 = no slip expected;
    /// - `forward_std`: forward wheel-velocity noise, m/s;
    /// - `lateral_std`: noise of the lateral and vertical non-holonomic constraints, m/s;
    /// - `forward_gate`: chi-square gate (1 DOF) of the forward component;
    /// - `jolt_threshold`: vertical specific-force deviation, m/s^2, the surface explains.
    pub fn new(
        grip: f32,
        forward_std: f32,
        lateral_std: f32,
        forward_gate: f32,
        jolt_threshold: f32,
    ) -> Result<Self, GripError> {
        if !(grip > 0.0 && grip <= 1.0) {
            return Err(GripError::GripOutOfRange);
        }
        let positive = |v: f32| v.is_finite() && v > 0.0;
        if ![forward_std, lateral_std, forward_gate, jolt_threshold]
            .iter()
            .all(|v| positive(*v))
        {
            return Err(GripError::NotPositive);
        }
        Ok(GripParams {
            grip,
            forward_std,
            lateral_std,
            forward_gate,
            jolt_threshold,
            slip: 0.0,
            learn_radius: true,
        })
    }

    /// The same parameters with the expected slip `slip`: the fraction of
    /// the wheels' rolling speed the ground does not take, so the robot's
    /// expected speed is `(1 - slip)` times the wheels' (seed 004 claim 5:
    /// the velocity derived from the grip). Values outside `[0, MAX_SLIP]`
    /// (NaN as 0) are clamped into it.
    pub fn with_slip(mut self, slip: f32) -> Self {
        self.slip = if slip.is_nan() {
            0.0
        } else {
            slip.clamp(0.0, MAX_SLIP)
        };
        self
    }

    /// The same parameters with the wheel radii learning (`true`) or held
    /// (`false`: a Schmidt consider parameter in the wheel update, see
    /// [`crate::wheel::update`]). On a low-grip floor the wheels' over-count
    /// is the floor's slip, not the radius.
    pub fn with_learn_radius(mut self, learn: bool) -> Self {
        self.learn_radius = learn;
        self
    }

    /// Grip coefficient in (0, 1].
    pub fn grip(&self) -> f32 {
        self.grip
    }
    /// Forward wheel-velocity noise, m/s.
    pub fn forward_std(&self) -> f32 {
        self.forward_std
    }
    /// Lateral and vertical constraint noise, m/s.
    pub fn lateral_std(&self) -> f32 {
        self.lateral_std
    }
    /// Chi-square gate (1 DOF) of the forward component.
    pub fn forward_gate(&self) -> f32 {
        self.forward_gate
    }
    /// Vertical specific-force deviation, m/s^2, the surface explains.
    pub fn jolt_threshold(&self) -> f32 {
        self.jolt_threshold
    }
    /// Expected slip in `[0, MAX_SLIP]`: the wheels' forward and
    /// differential speeds are scaled by `1 - slip`. 0 unless set.
    pub fn slip(&self) -> f32 {
        self.slip
    }
    /// Whether the wheel update may move the wheel radii (true unless set).
    pub fn learn_radius(&self) -> bool {
        self.learn_radius
    }
}

/// Largest expected slip [`GripParams::with_slip`] accepts.
pub const MAX_SLIP: f32 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_ranges() {
        assert!(GripParams::new(0.5, 0.1, 0.01, 6.6, 3.0).is_ok());
        assert_eq!(
            GripParams::new(0.0, 0.1, 0.01, 6.6, 3.0),
            Err(GripError::GripOutOfRange)
        );
        assert_eq!(
            GripParams::new(1.1, 0.1, 0.01, 6.6, 3.0),
            Err(GripError::GripOutOfRange)
        );
        assert_eq!(
            GripParams::new(f32::NAN, 0.1, 0.01, 6.6, 3.0),
            Err(GripError::GripOutOfRange)
        );
        assert_eq!(
            GripParams::new(0.5, -0.1, 0.01, 6.6, 3.0),
            Err(GripError::NotPositive)
        );
        assert_eq!(
            GripParams::new(0.5, 0.1, 0.01, f32::INFINITY, 3.0),
            Err(GripError::NotPositive)
        );
    }
}
