//! `To` from raw flow-sensor frames: per-feature pixel motion (Lucas-Kanade
//! between consecutive raw 35x35 frames, computed elsewhere and passed in as
//! plain displacements) combined robustly into one sensor displacement.
//!
//! Each feature gives a pixel speed and direction ([`FeatureMotion`]). The
//! combination is the component-wise median of the per-feature displacements
//! (breakdown point 50 %), its spread the median absolute deviation; pixels
//! become radians by the raw frame's angular pixel pitch and radians become
//! metres by the height above the floor. The floor texture moves opposite to
//! the sensor, so the sensor's motion is minus the image motion. The result is
//! a [`FlowStep`] like the counting path's.

use core::fmt;

use super::flow::{FlowStep, sensor_to_body};
use super::robust::median_in_place;
use crate::geometry::{Extrinsics, Vec2};
use crate::time::Timestamp;

/// Most features one step combines; further ones are ignored.
pub const MAX_FEATURES: usize = 64;

/// One tracked feature's pixel displacement between two raw frames.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FeatureMotion {
    /// Displacement along the frame's columns, pixels.
    pub dx: f32,
    /// Displacement along the frame's rows, pixels.
    pub dy: f32,
}

impl FeatureMotion {
    /// From a pixel speed (pixels/s) and direction (radians from the column
    /// axis) held over `dt` seconds, as an LK tracker may report them.
    pub fn from_speed_direction(speed: f32, direction: f32, dt: f32) -> Self {
        let d = speed * dt;
        FeatureMotion {
            dx: d * libm::cosf(direction),
            dy: d * libm::sinf(direction),
        }
    }

    /// Pixel speed over `dt` seconds (pixels/s); `None` for `dt <= 0`.
    pub fn speed(&self, dt: f32) -> Option<f32> {
        (dt > 0.0).then(|| libm::hypotf(self.dx, self.dy) / dt)
    }
    /// Direction of motion, radians from the column axis.
    pub fn direction(&self) -> f32 {
        libm::atan2f(self.dy, self.dx)
    }
}

/// Why raw-frame flow gave no step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RawFlowError {
    /// Fewer finite features than the configured minimum.
    TooFewFeatures,
    /// `t1` is not after `t0`.
    BadInterval,
    /// The heading change was not finite.
    NonFinite,
}

impl fmt::Display for RawFlowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RawFlowError::TooFewFeatures => "too few finite feature motions",
            RawFlowError::BadInterval => "raw frame interval does not move forward in time",
            RawFlowError::NonFinite => "non-finite heading change",
        })
    }
}

impl core::error::Error for RawFlowError {}

/// The raw frame's optics and the robust combination's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawFlowOptics {
    radians_per_pixel: f32,
    height: f32,
    mount: Extrinsics,
    min_features: u8,
    spread_half_px: f32,
}

impl RawFlowOptics {
    /// Checks and builds: angular pixel pitch (rad/pixel) and height (m) must be
    /// finite and positive; `min_features >= 1`. Returns `None` otherwise.
    pub fn new(
        radians_per_pixel: f32,
        height: f32,
        mount: Extrinsics,
        min_features: u8,
    ) -> Option<Self> {
        let ok = radians_per_pixel.is_finite()
            && radians_per_pixel > 0.0
            && height.is_finite()
            && height > 0.0
            && min_features >= 1;
        ok.then_some(RawFlowOptics {
            radians_per_pixel,
            height,
            mount,
            min_features,
            spread_half_px: 0.5,
        })
    }
    /// Metres of floor per pixel of image motion.
    pub fn metres_per_pixel(&self) -> f32 {
        self.radians_per_pixel * self.height
    }
    /// The sensor's mounting.
    pub fn mount(&self) -> &Extrinsics {
        &self.mount
    }
}

/// The robust combination of one frame pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawFlowEstimate {
    /// Median image displacement, pixels.
    pub median_px: Vec2,
    /// Median absolute deviation of the displacements, pixels (both axes summed).
    pub mad_px: f32,
    /// Finite features used.
    pub features: u16,
}

/// Component-wise median and MAD of the finite displacements (at most
/// [`MAX_FEATURES`]); `None` when there are none.
pub fn combine(features: &[FeatureMotion]) -> Option<RawFlowEstimate> {
    let mut xs = [0.0f32; MAX_FEATURES];
    let mut ys = [0.0f32; MAX_FEATURES];
    let mut n = 0usize;
    let finite = features
        .iter()
        .filter(|f| f.dx.is_finite() && f.dy.is_finite());
    for (f, (x, y)) in finite.zip(xs.iter_mut().zip(ys.iter_mut())) {
        *x = f.dx;
        *y = f.dy;
        n += 1;
    }
    let mx = median_in_place(xs.get_mut(..n)?)?;
    let my = median_in_place(ys.get_mut(..n)?)?;
    for (x, y) in xs.iter_mut().zip(ys.iter_mut()).take(n) {
        *x = libm::fabsf(*x - mx);
        *y = libm::fabsf(*y - my);
    }
    let mad = median_in_place(xs.get_mut(..n)?)? + median_in_place(ys.get_mut(..n)?)?;
    Some(RawFlowEstimate {
        median_px: Vec2::new(mx, my),
        mad_px: mad,
        features: n as u16,
    })
}

/// One raw frame pair to a flow step: robust combination, pixels to metres,
/// sign flip (image motion is opposite to the sensor's), body frame, lever arm.
/// Confidence: `min(1, n / (4 * min_features)) / (1 + (MAD / 0.5 px)^2)`.
pub fn raw_flow_step(
    t0: Timestamp,
    t1: Timestamp,
    features: &[FeatureMotion],
    optics: &RawFlowOptics,
    dyaw: f32,
) -> Result<FlowStep, RawFlowError> {
    if t1 <= t0 {
        return Err(RawFlowError::BadInterval);
    }
    if !dyaw.is_finite() {
        return Err(RawFlowError::NonFinite);
    }
    let est = combine(features).ok_or(RawFlowError::TooFewFeatures)?;
    if est.features < u16::from(optics.min_features) {
        return Err(RawFlowError::TooFewFeatures);
    }
    let d_sensor = -est.median_px * optics.metres_per_pixel();
    let count = (f32::from(est.features) / (4.0 * f32::from(optics.min_features))).min(1.0);
    let spread = est.mad_px / optics.spread_half_px;
    let confidence = (count / (1.0 + spread * spread)).clamp(0.0, 1.0);
    Ok(FlowStep {
        t0,
        t1,
        d_body: sensor_to_body(d_sensor, &optics.mount, dyaw),
        dyaw,
        confidence,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_rejects_wild_features() {
        let mut f = [FeatureMotion { dx: 2.0, dy: -1.0 }; 9];
        f[0] = FeatureMotion { dx: 40.0, dy: 30.0 };
        f[1] = FeatureMotion {
            dx: f32::NAN,
            dy: 0.0,
        };
        f[2] = FeatureMotion { dx: -25.0, dy: 9.0 };
        let e = combine(&f).unwrap();
        assert_eq!(e.features, 8);
        assert_eq!(e.median_px, Vec2::new(2.0, -1.0));
        let o = RawFlowOptics::new(0.01, 0.02, Extrinsics::identity(), 2).unwrap();
        let st = raw_flow_step(Timestamp(0), Timestamp(10), &f, &o, 0.0).unwrap();
        // 2 px * 0.01 rad/px * 0.02 m = 0.0004 m, opposite to the image motion.
        assert!((st.d_body - Vec2::new(-0.0004, 0.0002)).norm() < 1e-7);
        assert!(st.confidence > 0.9);
        assert!((f[3].speed(0.5).unwrap() - 2.0 * libm::sqrtf(5.0)).abs() < 1e-5);
        assert!((f[3].direction() + libm::atan2f(1.0, 2.0)).abs() < 1e-6);
        let back =
            FeatureMotion::from_speed_direction(f[3].speed(0.5).unwrap(), f[3].direction(), 0.5);
        assert!((back.dx - 2.0).abs() < 1e-5 && (back.dy + 1.0).abs() < 1e-5);
    }

    #[test]
    fn too_few_or_bad_inputs_are_typed_errors() {
        let o = RawFlowOptics::new(0.01, 0.02, Extrinsics::identity(), 3).unwrap();
        let f = [FeatureMotion { dx: 1.0, dy: 1.0 }; 2];
        assert_eq!(
            raw_flow_step(Timestamp(0), Timestamp(1), &f, &o, 0.0),
            Err(RawFlowError::TooFewFeatures)
        );
        assert_eq!(
            raw_flow_step(Timestamp(0), Timestamp(1), &[], &o, 0.0),
            Err(RawFlowError::TooFewFeatures)
        );
        assert_eq!(
            raw_flow_step(Timestamp(1), Timestamp(1), &f, &o, 0.0),
            Err(RawFlowError::BadInterval)
        );
        assert!(RawFlowOptics::new(0.0, 0.02, Extrinsics::identity(), 3).is_none());
    }
}
