//! Frames and rigid transforms shared by every crate.
//!
//! - World `W`: z up.
//! - Body `B`: x forward, y left, z up, origin mid-axle on the floor.
//! - Sensor `S`: each sensor's own frame, mounted by `T_BS` with
//!   `p_B = R_BS p_S + t_BS` (the ASL/EuRoC convention).
//!
//! Names carry their frames: `r_bs` rotates sensor vectors into the body,
//! `p_wb` is the body origin in the world.

use core::fmt;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector2, Vector3};

/// 2-vector, `f32`.
pub type Vec2 = Vector2<f32>;
/// 3-vector, `f32`.
pub type Vec3 = Vector3<f32>;
/// 3x3 matrix, `f32`.
pub type Mat3 = Matrix3<f32>;
/// Rotation matrix, `f32`.
pub type Rot3 = Rotation3<f32>;
/// Unit quaternion (Hamilton), `f32`.
pub type Quat = UnitQuaternion<f32>;

/// Why a transform could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransformError {
    /// An entry was NaN or infinite.
    NonFinite,
    /// The rotation block is not orthonormal with determinant +1.
    NotARotation,
    /// The last row of a 4x4 homogeneous matrix is not `[0 0 0 1]`.
    NotRigid,
}

impl fmt::Display for TransformError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TransformError::NonFinite => "transform has a non-finite entry",
            TransformError::NotARotation => "rotation block is not a proper rotation",
            TransformError::NotRigid => "last row of the 4x4 transform is not [0 0 0 1]",
        })
    }
}

impl core::error::Error for TransformError {}

/// The mounting of a sensor in the body, `T_BS`: `p_B = R_BS p_S + t_BS`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extrinsics {
    r_bs: Rot3,
    t_bs: Vec3,
}

impl Default for Extrinsics {
    fn default() -> Self {
        Extrinsics::identity()
    }
}

impl Extrinsics {
    /// Tolerance on `R^T R - I` and `det R - 1` when checking a rotation.
    pub const ROTATION_TOLERANCE: f32 = 1e-3;

    /// A sensor at the body origin, axes aligned with the body.
    pub const fn identity() -> Self {
        Self::IDENTITY
    }

    /// [`Extrinsics::identity`] as a constant.
    pub const IDENTITY: Self = Extrinsics {
        r_bs: Rot3::from_matrix_unchecked(nalgebra::Matrix3::new(
            1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0,
        )),
        t_bs: Vec3::new(0.0, 0.0, 0.0),
    };

    /// From a rotation and a translation (already a proper rotation by type).
    pub fn new(r_bs: Rot3, t_bs: Vec3) -> Result<Self, TransformError> {
        if !t_bs.iter().all(|v| v.is_finite()) || !r_bs.matrix().iter().all(|v| v.is_finite()) {
            return Err(TransformError::NonFinite);
        }
        Ok(Extrinsics { r_bs, t_bs })
    }

    /// From a row-major 4x4 homogeneous matrix, as in an ASL `sensor.yaml`
    /// (`T_BS: {cols: 4, rows: 4, data: [...]}`). The rotation block is checked
    /// and re-orthonormalised.
    pub fn from_row_major(data: &[f32; 16]) -> Result<Self, TransformError> {
        if !data.iter().all(|v| v.is_finite()) {
            return Err(TransformError::NonFinite);
        }
        let [
            r00,
            r01,
            r02,
            tx,
            r10,
            r11,
            r12,
            ty,
            r20,
            r21,
            r22,
            tz,
            l0,
            l1,
            l2,
            l3,
        ] = *data;
        let tol = Self::ROTATION_TOLERANCE;
        if libm::fabsf(l0) > tol
            || libm::fabsf(l1) > tol
            || libm::fabsf(l2) > tol
            || libm::fabsf(l3 - 1.0) > tol
        {
            return Err(TransformError::NotRigid);
        }
        let m = Mat3::new(r00, r01, r02, r10, r11, r12, r20, r21, r22);
        let err = (m.transpose() * m - Mat3::identity()).abs().max();
        if err > tol || libm::fabsf(m.determinant() - 1.0) > tol {
            return Err(TransformError::NotARotation);
        }
        let r = Rot3::from_matrix_eps(&m, 1e-7, 20, Rot3::identity());
        Ok(Extrinsics {
            r_bs: r,
            t_bs: Vec3::new(tx, ty, tz),
        })
    }

    /// The rotation `R_BS`.
    pub fn r_bs(&self) -> &Rot3 {
        &self.r_bs
    }

    /// The translation `t_BS` (sensor origin in the body frame).
    pub fn t_bs(&self) -> &Vec3 {
        &self.t_bs
    }

    /// A point in the sensor frame, expressed in the body frame.
    pub fn point_to_body(&self, p_s: &Vec3) -> Vec3 {
        self.r_bs * p_s + self.t_bs
    }

    /// A direction (velocity, axis) in the sensor frame, expressed in the body frame.
    pub fn vector_to_body(&self, v_s: &Vec3) -> Vec3 {
        self.r_bs * v_s
    }

    /// A direction in the body frame, expressed in the sensor frame.
    pub fn vector_to_sensor(&self, v_b: &Vec3) -> Vec3 {
        self.r_bs.inverse() * v_b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_major_round_trip_and_checks() {
        // Camera looking up: sensor z along body z, sensor x along body -y.
        let data = [
            0.0, 1.0, 0.0, 0.10, //
            -1.0, 0.0, 0.0, 0.00, //
            0.0, 0.0, 1.0, 0.25, //
            0.0, 0.0, 0.0, 1.0,
        ];
        let e = Extrinsics::from_row_major(&data).unwrap();
        let p = e.point_to_body(&Vec3::new(1.0, 0.0, 0.0));
        assert!((p - Vec3::new(0.10, -1.0, 0.25)).norm() < 1e-6);
        let v = e.vector_to_sensor(&e.vector_to_body(&Vec3::new(0.3, -0.2, 0.9)));
        assert!((v - Vec3::new(0.3, -0.2, 0.9)).norm() < 1e-6);

        let mut bad = data;
        bad[0] = 2.0;
        assert_eq!(
            Extrinsics::from_row_major(&bad),
            Err(TransformError::NotARotation)
        );
        let mut bad = data;
        bad[15] = 0.0;
        assert_eq!(
            Extrinsics::from_row_major(&bad),
            Err(TransformError::NotRigid)
        );
        let mut bad = data;
        bad[3] = f32::NAN;
        assert_eq!(
            Extrinsics::from_row_major(&bad),
            Err(TransformError::NonFinite)
        );
        // A reflection is orthonormal but not a rotation.
        let mut bad = data;
        bad[10] = -1.0;
        assert_eq!(
            Extrinsics::from_row_major(&bad),
            Err(TransformError::NotARotation)
        );
    }
}
