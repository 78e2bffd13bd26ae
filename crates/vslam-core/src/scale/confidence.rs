//! Confidence of each transaction, `0..=1`.
//!
//! - Camera: from the homography's inlier count, inlier ratio and RMS
//!   residual (the usual RANSAC quality figures, Hartley & Zisserman ch. 4.7).
//! - Flow: from SQUAL, shutter and count saturation (PixArt PMW3901MB
//!   datasheet: SQUAL counts features, a long shutter means a dark or
//!   featureless floor, and the datasheet's validity rule marks SQUAL below
//!   0x19 at maximum shutter unreliable). Low quality lowers the confidence;
//!   it is not an error.
//! - Wheels: from the slip amount ([`super::slip`]) and coverage.

use super::camera::CameraMotion;
use crate::sensors::FlowSample;

fn unit(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// How camera quality figures map to confidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraConfidenceParams {
    /// Inliers at or below which confidence is zero (a homography needs 4).
    pub min_inliers: u16,
    /// Inliers at or above which the count no longer limits confidence.
    pub good_inliers: u16,
    /// Residual (pixels) at which the residual factor is one half.
    pub residual_half_px: f32,
}

impl Default for CameraConfidenceParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl CameraConfidenceParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = CameraConfidenceParams {
        min_inliers: 8,
        good_inliers: 60,
        residual_half_px: 1.5,
    };
}

/// Camera confidence: `count * ratio * 1 / (1 + (residual / half)^2)`.
pub fn camera_confidence(m: &CameraMotion, p: &CameraConfidenceParams) -> f32 {
    let span = f32::from(p.good_inliers.saturating_sub(p.min_inliers).max(1));
    let count = unit(f32::from(m.inliers().saturating_sub(p.min_inliers)) / span);
    let ratio = unit(m.inlier_ratio());
    let r = m.residual_px() / p.residual_half_px.max(1e-6);
    unit(count * ratio / (1.0 + r * r))
}

/// How flow report quality maps to confidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowConfidenceParams {
    /// SQUAL at or above which quality no longer limits confidence.
    pub squal_good: u8,
    /// Shutter at or below which exposure does not lower confidence.
    pub shutter_good: u16,
    /// Shutter at which the exposure factor reaches its floor.
    pub shutter_bad: u16,
    /// Exposure factor at `shutter_bad` and beyond.
    pub shutter_floor: f32,
    /// Factor for saturated counts (the motion is at least what was counted).
    pub saturated_factor: f32,
}

impl Default for FlowConfidenceParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl FlowConfidenceParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = FlowConfidenceParams {
        squal_good: 0x50,
        shutter_good: 0x0400,
        shutter_bad: 0x1F00,
        shutter_floor: 0.2,
        saturated_factor: 0.1,
    };
}

/// Confidence of one flow report; zero for reports the datasheet marks unreliable.
pub fn flow_sample_confidence(s: &FlowSample, p: &FlowConfidenceParams) -> f32 {
    if !s.is_valid() {
        return 0.0;
    }
    let squal = unit(f32::from(s.squal) / f32::from(p.squal_good.max(1)));
    let exposure = if s.shutter <= p.shutter_good {
        1.0
    } else {
        let span = f32::from(p.shutter_bad.saturating_sub(p.shutter_good).max(1));
        let x = unit(f32::from(s.shutter - p.shutter_good) / span);
        1.0 - x * (1.0 - unit(p.shutter_floor))
    };
    let sat = if s.is_saturated() {
        unit(p.saturated_factor)
    } else {
        1.0
    };
    unit(squal * exposure * sat)
}

/// Wheel confidence: `coverage / (1 + (slip / threshold)^2)`, and a factor
/// `1 / (1 + discontinuities)`: one half at the slip threshold.
pub fn wheel_confidence(
    slip_amount: f32,
    threshold: f32,
    coverage: f32,
    discontinuities: u16,
) -> f32 {
    let x = if threshold > 0.0 {
        slip_amount / threshold
    } else {
        f32::INFINITY
    };
    let slip = if x.is_finite() {
        1.0 / (1.0 + x * x)
    } else {
        0.0
    };
    unit(unit(coverage) * slip / (1.0 + f32::from(discontinuities)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Rot3, Vec3};
    use crate::time::Timestamp;

    #[test]
    fn camera_confidence_falls_with_fewer_inliers_and_larger_residual() {
        let p = CameraConfidenceParams::default();
        let m = |n, ratio, res| {
            CameraMotion::new(
                Timestamp(0),
                Timestamp(1),
                Rot3::identity(),
                Vec3::zeros(),
                n,
                ratio,
                res,
            )
            .unwrap()
        };
        let good = camera_confidence(&m(100, 0.9, 0.3), &p);
        assert!(good > 0.8);
        assert!(camera_confidence(&m(30, 0.9, 0.3), &p) < good);
        assert!(camera_confidence(&m(100, 0.5, 0.3), &p) < good);
        assert!(camera_confidence(&m(100, 0.9, 3.0), &p) < good);
        assert_eq!(camera_confidence(&m(5, 0.9, 0.3), &p), 0.0);
    }

    #[test]
    fn flow_confidence_follows_quality_and_is_zero_when_invalid() {
        let p = FlowConfidenceParams::default();
        let good = FlowSample {
            squal: 0x80,
            shutter: 0x100,
            ..FlowSample::default()
        };
        assert_eq!(flow_sample_confidence(&good, &p), 1.0);
        let dim = FlowSample {
            squal: 0x28,
            ..good
        };
        assert!((flow_sample_confidence(&dim, &p) - 0.5).abs() < 1e-6);
        let dark = FlowSample {
            shutter: 0x1E00,
            ..good
        };
        assert!(flow_sample_confidence(&dark, &p) < 0.3);
        let invalid = FlowSample {
            squal: 0x10,
            shutter: 0x1F40,
            ..good
        };
        assert_eq!(flow_sample_confidence(&invalid, &p), 0.0);
        let sat = FlowSample {
            dx: i16::MAX,
            ..good
        };
        assert!((flow_sample_confidence(&sat, &p) - 0.1).abs() < 1e-6);
    }

    #[test]
    fn wheel_confidence_is_half_at_the_threshold() {
        assert_eq!(wheel_confidence(0.0, 0.15, 1.0, 0), 1.0);
        assert!((wheel_confidence(0.15, 0.15, 1.0, 0) - 0.5).abs() < 1e-6);
        assert!((wheel_confidence(0.0, 0.15, 1.0, 1) - 0.5).abs() < 1e-6);
        assert_eq!(wheel_confidence(f32::NAN, 0.15, 1.0, 0), 0.0);
    }
}
