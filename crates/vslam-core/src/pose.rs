//! Trajectory composition: `P_k = P_{k-1} [R_k s_k T_k; 0 1]`, starting from the
//! camera's initial pose in the world (seed: "compose the poses as
//! [R1 sT1;0 1]*[R2 sT2;0 1]*...").
//!
//! [`Trajectory`] keeps the running current pose plus a ring buffer of the
//! last `N` poses with a per-frame record `D` each. The current pose is
//! composed independently of the buffer, so it never depends on `N`.
//!
//! Camera to body: with the camera mounted by `T_BC` ([`Extrinsics`]),
//! `T_WB = T_WC T_BC^-1` and `T_WC0 = T_WB0 T_BC`.

use heapless::Deque;
use nalgebra::{Isometry3, Translation3};

use crate::geometry::{Extrinsics, Quat, Rot3, Vec3};
use crate::time::Timestamp;

/// A rigid pose, `f32`.
pub type Pose = Isometry3<f32>;

/// The identity pose, as a constant.
pub const POSE_IDENTITY: Pose = Pose::from_parts(
    nalgebra::Translation3::new(0.0, 0.0, 0.0),
    nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
);

/// The mounting `T_BC` as a pose.
pub fn mounting_pose(e: &Extrinsics) -> Pose {
    Pose::from_parts(
        Translation3::from(*e.t_bs()),
        Quat::from_rotation_matrix(e.r_bs()),
    )
}

/// `[R sT; 0 1]`.
pub fn relative_pose(r: &Rot3, t: &Vec3, s: f32) -> Pose {
    Pose::from_parts(Translation3::from(t * s), Quat::from_rotation_matrix(r))
}

/// The body pose `T_WB = T_WC T_BC^-1` from a camera pose.
pub fn body_from_camera(t_wc: &Pose, camera: &Extrinsics) -> Pose {
    t_wc * mounting_pose(camera).inverse()
}

/// The camera pose `T_WC = T_WB T_BC` from a body pose.
pub fn camera_from_body(t_wb: &Pose, camera: &Extrinsics) -> Pose {
    t_wb * mounting_pose(camera)
}

/// One stored trajectory entry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseEntry<D> {
    /// Time of the frame.
    pub t: Timestamp,
    /// Camera pose in the world after this frame, `T_WC`.
    pub t_wc: Pose,
    /// The per-frame record (e.g. the scale decision).
    pub record: D,
}

/// Composed camera poses in fixed memory.
#[derive(Clone, Debug)]
pub struct Trajectory<D, const N: usize> {
    camera: Extrinsics,
    current: Pose,
    t: Option<Timestamp>,
    frames: u32,
    recent: Deque<PoseEntry<D>, N>,
}

impl<D: Copy, const N: usize> Trajectory<D, N> {
    /// Starts at the body pose `t_wb0` with the camera mounted by `camera`.
    pub fn new(t_wb0: Pose, camera: Extrinsics) -> Self {
        Trajectory {
            camera,
            current: camera_from_body(&t_wb0, &camera),
            t: None,
            frames: 0,
            recent: Deque::new(),
        }
    }

    /// At the identity body pose with the camera at the body origin (a
    /// `const` value; see [`Trajectory::reset`]).
    pub const fn at_origin() -> Self {
        Trajectory {
            camera: Extrinsics::IDENTITY,
            current: POSE_IDENTITY,
            t: None,
            frames: 0,
            recent: Deque::new(),
        }
    }

    /// Starts over in place, as [`Trajectory::new`].
    pub fn reset(&mut self, t_wb0: Pose, camera: Extrinsics) {
        self.camera = camera;
        self.current = camera_from_body(&t_wb0, &camera);
        self.t = None;
        self.frames = 0;
        self.recent.clear();
    }

    /// Composes one frame: `P <- P [R sT; 0 1]` at time `t`, storing `record`.
    pub fn compose(&mut self, t: Timestamp, r: &Rot3, t_over_d: &Vec3, s: f32, record: D) {
        let step = relative_pose(r, t_over_d, if s.is_finite() { s } else { 0.0 });
        let next = self.current * step;
        if next.translation.vector.iter().all(|v| v.is_finite())
            && next.rotation.coords.iter().all(|v| v.is_finite())
        {
            self.current = next;
            // Keep the quaternion unit despite rounding over long runs.
            self.current.rotation.renormalize_fast();
        }
        self.t = Some(t);
        self.frames = self.frames.saturating_add(1);
        if self.recent.is_full() {
            self.recent.pop_front();
        }
        let _ = self.recent.push_back(PoseEntry {
            t,
            t_wc: self.current,
            record,
        });
    }

    /// The current camera pose `T_WC`.
    pub fn camera_pose(&self) -> &Pose {
        &self.current
    }

    /// The current body pose `T_WB`.
    pub fn body_pose(&self) -> Pose {
        body_from_camera(&self.current, &self.camera)
    }

    /// The camera mounting.
    pub fn camera(&self) -> &Extrinsics {
        &self.camera
    }

    /// Time of the last composed frame.
    pub fn last_time(&self) -> Option<Timestamp> {
        self.t
    }

    /// Frames composed since the start (not limited by `N`).
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// The last `N` entries, oldest first.
    pub fn recent(&self) -> impl Iterator<Item = &PoseEntry<D>> {
        self.recent.iter()
    }

    /// The newest entry.
    pub fn last(&self) -> Option<&PoseEntry<D>> {
        self.recent.back()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn composition_matches_the_product_and_ignores_capacity() {
        let cam = Extrinsics::new(
            Rot3::from_euler_angles(0.0, 0.0, 0.5),
            Vec3::new(0.1, 0.0, 0.3),
        )
        .unwrap();
        let mut small: Trajectory<(), 2> = Trajectory::new(Pose::identity(), cam);
        let mut big: Trajectory<(), 64> = Trajectory::new(Pose::identity(), cam);
        let r = Rot3::from_euler_angles(0.0, 0.0, 0.1);
        let t = Vec3::new(0.01, 0.002, 0.0);
        let mut expect = mounting_pose(&cam);
        for k in 0..20u64 {
            small.compose(Timestamp(k), &r, &t, 2.5, ());
            big.compose(Timestamp(k), &r, &t, 2.5, ());
            expect *= relative_pose(&r, &t, 2.5);
        }
        assert!((small.camera_pose().translation.vector - expect.translation.vector).norm() < 1e-5);
        assert_eq!(small.camera_pose(), big.camera_pose());
        assert_eq!(small.recent().count(), 2);
        assert_eq!(small.frames(), 20);
        // Body and camera poses round-trip through the mounting.
        let b = small.body_pose();
        let c = camera_from_body(&b, &cam);
        assert!((c.translation.vector - small.camera_pose().translation.vector).norm() < 1e-5);
    }
}
