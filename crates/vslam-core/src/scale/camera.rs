//! The camera's input to the scale pipeline: one [`CameraMotion`] per pair of
//! frames, the selected solution of the homography decomposition.
//!
//! For a planar scene `n^T X = d` the homography `H = R + t n^T / d` only
//! fixes the translation up to the plane distance `d` (Faugeras & Lustman
//! 1988; Malis & Vargas 2007, INRIA RR-6303): the camera delivers `R` and the
//! unit-less `t/d`. The metric scale `s` that multiplies `t/d` is therefore the
//! plane (ceiling) distance itself, and comes from the wheels or the flow
//! sensor (seed: "slip-aware metric scale").
//!
//! Convention: `r` and `t_over_d` give the pose of the camera at `t1` in the
//! camera frame at `t0` (`p_c0 = r * p_c1 + t_over_d * d`), so that poses
//! compose as `[R1 sT1; 0 1] [R2 sT2; 0 1] ...`. A decomposition that returns
//! the point transfer `X1 = R X0 + t` converts with
//! [`CameraMotion::from_point_transfer`].

use core::fmt;

use crate::geometry::{Rot3, Vec3};
use crate::time::Timestamp;

/// Why a camera motion could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMotionError {
    /// A rotation, translation or quality field was NaN or infinite.
    NonFinite,
    /// `t1` is not after `t0`.
    BadInterval,
    /// The inlier ratio is outside `0..=1` or the residual is negative.
    BadQuality,
}

impl fmt::Display for CameraMotionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CameraMotionError::NonFinite => "camera motion has a non-finite field",
            CameraMotionError::BadInterval => {
                "camera motion interval does not move forward in time"
            }
            CameraMotionError::BadQuality => "inlier ratio outside 0..=1 or negative residual",
        })
    }
}

impl core::error::Error for CameraMotionError {}

/// The motion of the camera between two frames, up to the plane distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraMotion {
    t0: Timestamp,
    t1: Timestamp,
    r: Rot3,
    t_over_d: Vec3,
    inliers: u16,
    inlier_ratio: f32,
    residual_px: f32,
}

impl CameraMotion {
    /// Checks and builds the motion: pose of the camera at `t1` in the camera
    /// frame at `t0`, translation divided by the plane distance.
    pub fn new(
        t0: Timestamp,
        t1: Timestamp,
        r: Rot3,
        t_over_d: Vec3,
        inliers: u16,
        inlier_ratio: f32,
        residual_px: f32,
    ) -> Result<Self, CameraMotionError> {
        let finite = r.matrix().iter().all(|v| v.is_finite())
            && t_over_d.iter().all(|v| v.is_finite())
            && inlier_ratio.is_finite()
            && residual_px.is_finite();
        if !finite {
            return Err(CameraMotionError::NonFinite);
        }
        if t1 <= t0 {
            return Err(CameraMotionError::BadInterval);
        }
        if !(0.0..=1.0).contains(&inlier_ratio) || residual_px < 0.0 {
            return Err(CameraMotionError::BadQuality);
        }
        Ok(CameraMotion {
            t0,
            t1,
            r,
            t_over_d,
            inliers,
            inlier_ratio,
            residual_px,
        })
    }

    /// From a decomposition that maps points of frame 0 into frame 1,
    /// `X1 = R X0 + t` (with `t` already divided by `d`): the camera pose is the
    /// inverse, `r = R^T`, `t_over_d = -R^T t`.
    pub fn from_point_transfer(
        t0: Timestamp,
        t1: Timestamp,
        r_10: Rot3,
        t_10_over_d: Vec3,
        inliers: u16,
        inlier_ratio: f32,
        residual_px: f32,
    ) -> Result<Self, CameraMotionError> {
        let r = r_10.inverse();
        let t = -(r * t_10_over_d);
        CameraMotion::new(t0, t1, r, t, inliers, inlier_ratio, residual_px)
    }

    /// Time of the first frame.
    pub fn t0(&self) -> Timestamp {
        self.t0
    }
    /// Time of the second frame.
    pub fn t1(&self) -> Timestamp {
        self.t1
    }
    /// Rotation of the camera at `t1` relative to the camera at `t0`.
    pub fn r(&self) -> &Rot3 {
        &self.r
    }
    /// Translation of the camera, frame `t0`, divided by the plane distance.
    pub fn t_over_d(&self) -> &Vec3 {
        &self.t_over_d
    }
    /// `|T|`, the unit-less baseline.
    pub fn baseline(&self) -> f32 {
        self.t_over_d.norm()
    }
    /// Homography inliers.
    pub fn inliers(&self) -> u16 {
        self.inliers
    }
    /// Inliers over tracked features, `0..=1`.
    pub fn inlier_ratio(&self) -> f32 {
        self.inlier_ratio
    }
    /// RMS reprojection residual of the inliers, pixels.
    pub fn residual_px(&self) -> f32 {
        self.residual_px
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_fields_and_inverts_point_transfer() {
        let r = Rot3::from_euler_angles(0.0, 0.0, 0.3);
        let t = Vec3::new(0.1, -0.05, 0.0);
        let m = CameraMotion::from_point_transfer(Timestamp(0), Timestamp(1), r, t, 50, 0.8, 0.5)
            .unwrap();
        // Applying the pose to the transferred point gives the original point back.
        let x0 = Vec3::new(0.3, 0.2, 1.0);
        let x1 = r * x0 + t;
        let back = m.r() * x1 + m.t_over_d();
        assert!((back - x0).norm() < 1e-6);

        let bad = Vec3::new(f32::NAN, 0.0, 0.0);
        let e = CameraMotion::new(Timestamp(0), Timestamp(1), r, bad, 5, 0.5, 0.1);
        assert_eq!(e, Err(CameraMotionError::NonFinite));
        let e = CameraMotion::new(Timestamp(1), Timestamp(1), r, t, 5, 0.5, 0.1);
        assert_eq!(e, Err(CameraMotionError::BadInterval));
        let e = CameraMotion::new(Timestamp(0), Timestamp(1), r, t, 5, 1.5, 0.1);
        assert_eq!(e, Err(CameraMotionError::BadQuality));
    }
}
