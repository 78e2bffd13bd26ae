//! Pinhole intrinsics `K`, as far as the homography decomposition needs them.

use super::DecomposeError;
use crate::geometry::{Mat3, Vec2, Vec3};

/// Pinhole intrinsics (no distortion): focal lengths `fu, fv` and principal
/// point `cu, cv`, in pixels, as in an ASL `sensor.yaml`
/// (`intrinsics: [fu, fv, cu, cv]`).
///
/// `K = [[fu, 0, cu], [0, fv, cv], [0, 0, 1]]`; a pixel `x` and its normalised
/// ray `m = K^-1 x` (`m_z = 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeIntrinsics {
    fu: f32,
    fv: f32,
    cu: f32,
    cv: f32,
}

impl PinholeIntrinsics {
    /// Checked: finite, focal lengths positive.
    ///
    /// # Errors
    /// [`DecomposeError::InvalidIntrinsics`].
    pub fn new(fu: f32, fv: f32, cu: f32, cv: f32) -> Result<Self, DecomposeError> {
        let finite = fu.is_finite() && fv.is_finite() && cu.is_finite() && cv.is_finite();
        if !finite || fu <= 0.0 || fv <= 0.0 {
            return Err(DecomposeError::InvalidIntrinsics);
        }
        Ok(PinholeIntrinsics { fu, fv, cu, cv })
    }

    /// The identity `K`: pixels are already normalised coordinates.
    pub fn identity() -> Self {
        PinholeIntrinsics {
            fu: 1.0,
            fv: 1.0,
            cu: 0.0,
            cv: 0.0,
        }
    }

    /// `[fu, fv, cu, cv]`.
    pub fn to_array(&self) -> [f32; 4] {
        [self.fu, self.fv, self.cu, self.cv]
    }

    /// `K`.
    pub fn matrix(&self) -> Mat3 {
        Mat3::new(self.fu, 0.0, self.cu, 0.0, self.fv, self.cv, 0.0, 0.0, 1.0)
    }

    /// `K^-1`.
    pub fn inverse_matrix(&self) -> Mat3 {
        let (iu, iv) = (1.0 / self.fu, 1.0 / self.fv);
        Mat3::new(
            iu,
            0.0,
            -self.cu * iu,
            0.0,
            iv,
            -self.cv * iv,
            0.0,
            0.0,
            1.0,
        )
    }

    /// The normalised ray `K^-1 [u v 1]^T` of a pixel.
    pub fn ray(&self, pixel: &Vec2) -> Vec3 {
        Vec3::new(
            (pixel.x - self.cu) / self.fu,
            (pixel.y - self.cv) / self.fv,
            1.0,
        )
    }

    /// The pixel of a point in camera coordinates; `None` behind the camera.
    pub fn project(&self, p: &Vec3) -> Option<Vec2> {
        if !(p.z > 0.0) {
            return None;
        }
        let q = Vec2::new(self.fu * p.x / p.z + self.cu, self.fv * p.y / p.z + self.cv);
        (q.x.is_finite() && q.y.is_finite()).then_some(q)
    }
}
