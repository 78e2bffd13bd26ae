//! What the floor means for the wheel measurement.
//!
//! The surface model (segmentation map -> ground classes -> grip table) sets
//! these parameters; the filter's wheel update reads them. Low grip is noise
//! and a wider gate, never an error.

use core::fmt;

/// Wheel-measurement parameters implied by the current floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GripParams {
    grip: f32,
    forward_std: f32,
    lateral_std: f32,
    forward_gate: f32,
    jolt_threshold: f32,
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
        GripParams {
            grip: 0.95,
            forward_std: 0.02,
            lateral_std: 0.01,
            forward_gate: 6.63, // chi-square, 1 DOF, 99 %
            jolt_threshold: 2.0,
        }
    }
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
        })
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
}

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
