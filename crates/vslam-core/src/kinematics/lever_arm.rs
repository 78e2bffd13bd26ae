//! The lever arm: a point at `r` from the body origin of a rigid body turning
//! at `w` moves with `v + w x r` (or, over a short step with small rotation
//! vector `w`, by `d + w x r`). Removing it gives the body origin's motion
//! from a sensor's ([`remove_lever_arm`]); adding it, a body point's motion
//! from the origin's ([`add_lever_arm`]). For a planar step of finite heading
//! change the exact displacement of a body point is [`planar_point_step`].

use crate::geometry::{Extrinsics, Vec2, Vec3};

/// The body origin's motion from the motion `at_point` of the point `r`
/// (body frame), the body turning by `rotation` (rad/s, or rad over a short
/// step): `at_point - rotation x r`.
#[inline(always)]
pub fn remove_lever_arm(at_point: &Vec3, rotation: &Vec3, r: &Vec3) -> Vec3 {
    at_point - rotation.cross(r)
}

/// The motion of the body point `r` from the body origin's motion
/// `at_origin`, the body turning by `rotation`: `at_origin + rotation x r`.
#[inline(always)]
pub fn add_lever_arm(at_origin: &Vec3, rotation: &Vec3, r: &Vec3) -> Vec3 {
    at_origin + rotation.cross(r)
}

/// A motion in a floor-facing sensor's x/y plane (a velocity or a short
/// displacement) to the body origin's, body frame: rotated by the mounting
/// `R_BS`, the lever arm of `t_BS` removed under `rotation` (body frame).
#[inline(always)]
pub fn sensor_plane_to_body(in_plane: &Vec2, mount: &Extrinsics, rotation: &Vec3) -> Vec3 {
    let at_sensor = mount.vector_to_body(&Vec3::new(in_plane.x, in_plane.y, 0.0));
    remove_lever_arm(&at_sensor, rotation, mount.t_bs())
}

/// The displacement of the body point `p` over a planar step that moved the
/// body origin by `translation` and turned it by `dyaw` about z, in the body
/// frame at the step's start: `translation + (Rz(dyaw) - I) p`.
pub fn planar_point_step(translation: &Vec3, dyaw: f32, p: &Vec3) -> Vec3 {
    let (s, c) = (libm::sinf(dyaw), libm::cosf(dyaw));
    let rotated = Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
    translation + rotated - p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Rot3;

    #[test]
    fn turning_in_place_moves_an_offset_sensor_not_the_origin() {
        // Sensor 0.1 m ahead, the body turns at 0.5 rad/s: it moves at 0.05 m/s left.
        let r = Vec3::new(0.1, 0.0, 0.0);
        let w = Vec3::new(0.0, 0.0, 0.5);
        let at_sensor = add_lever_arm(&Vec3::zeros(), &w, &r);
        assert!((at_sensor - Vec3::new(0.0, 0.05, 0.0)).norm() < 1e-7);
        assert!(remove_lever_arm(&at_sensor, &w, &r).norm() < 1e-7);
        let mount = Extrinsics::new(Rot3::from_euler_angles(0.0, 0.0, 1.0), r).unwrap();
        let in_plane = mount.vector_to_sensor(&at_sensor);
        let v = sensor_plane_to_body(&Vec2::new(in_plane.x, in_plane.y), &mount, &w);
        assert!(v.norm() < 1e-6, "{v:?}");
        // Exact: a quarter turn in place moves a point 0.1 m ahead to 0.1 m left.
        let q = core::f32::consts::FRAC_PI_2;
        let d = planar_point_step(&Vec3::zeros(), q, &r);
        assert!((d - Vec3::new(-0.1, 0.1, 0.0)).norm() < 1e-6);
    }
}
