//! How a downward flow sensor's counts become the robot's motion: the one
//! home of the arithmetic (PixArt PMW3901MB / PAA5100JE; PX4 `OpticalFlow`
//! fusion). Counts to angle by `counts_per_radian`, angle to metres by the
//! sensor's height above the floor (small-angle), the sensor-plane motion
//! rotated into the body frame by the mounting `R_BS` and the lever arm of
//! `t_BS` removed ([`crate::kinematics::lever_arm`]).
//!
//! Sign convention: the counts are taken as the sensor's own motion over the
//! floor along its `+x`/`+y` axes; a chip that reports the floor's apparent
//! motion instead is described by a mounting rotated by 180 degrees about z.

use crate::geometry::{Extrinsics, Vec2, Vec3};
use crate::kinematics::sensor_plane_to_body;
use crate::sensors::FlowSample;

/// How a downward flow sensor's counts become metres: its resolution and its
/// mounting. Counts to angle by `counts_per_radian`, angle to metres by the
/// height of the sensor above the floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowOptics {
    counts_per_radian: f32,
    height: f32,
    mount: Extrinsics,
}

/// Why flow optics could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlowOpticsError {
    /// `counts_per_radian` must be finite and positive.
    BadResolution,
    /// The height above the floor must be finite and positive.
    BadHeight,
}

impl core::fmt::Display for FlowOpticsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FlowOpticsError::BadResolution => "counts per radian must be finite and positive",
            FlowOpticsError::BadHeight => "flow sensor height must be finite and positive",
        })
    }
}

impl core::error::Error for FlowOpticsError {}

impl FlowOptics {
    /// Checks and builds the optics.
    pub fn new(
        counts_per_radian: f32,
        height: f32,
        mount: Extrinsics,
    ) -> Result<Self, FlowOpticsError> {
        if !(counts_per_radian.is_finite() && counts_per_radian > 0.0) {
            return Err(FlowOpticsError::BadResolution);
        }
        if !(height.is_finite() && height > 0.0) {
            return Err(FlowOpticsError::BadHeight);
        }
        Ok(FlowOptics {
            counts_per_radian,
            height,
            mount,
        })
    }
    /// Counts per radian of angular flow.
    pub fn counts_per_radian(&self) -> f32 {
        self.counts_per_radian
    }
    /// Height of the sensor above the floor, metres.
    pub fn height(&self) -> f32 {
        self.height
    }
    /// The sensor's mounting `T_BS`.
    pub fn mount(&self) -> &Extrinsics {
        &self.mount
    }
    /// Counts to angular flow, radians.
    pub fn counts_to_radians(&self, counts: f32) -> f32 {
        counts / self.counts_per_radian
    }
    /// Counts to metres of floor travelled under the sensor (small-angle).
    pub fn counts_to_metres(&self, counts: f32) -> f32 {
        self.counts_to_radians(counts) * self.height
    }
    /// A report's floor travel `[x, y]` under the sensor, metres, sensor
    /// axes (small-angle, at the optics' height; rotation not compensated).
    pub fn floor_displacement(&self, s: &FlowSample) -> Vec2 {
        Vec2::new(
            self.counts_to_metres(f32::from(s.dx)),
            self.counts_to_metres(f32::from(s.dy)),
        )
    }
    /// A motion in the sensor's x/y plane (a velocity, or a displacement over
    /// a short step) to the body origin's, body frame: rotated by the
    /// mounting, the lever arm removed under the body's `rotation` (rad/s,
    /// or rad over the step), see [`crate::kinematics::sensor_plane_to_body`].
    pub fn to_body(&self, in_plane: &Vec2, rotation: &Vec3) -> Vec3 {
        sensor_plane_to_body(in_plane, &self.mount, rotation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Rot3;
    use crate::time::Timestamp;

    #[test]
    fn counts_become_the_body_origins_motion() {
        // Sensor x along body y, 0.1 m ahead of the body origin.
        let mount = Extrinsics::new(
            Rot3::from_euler_angles(0.0, 0.0, core::f32::consts::FRAC_PI_2),
            Vec3::new(0.1, 0.0, 0.0),
        )
        .unwrap();
        let o = FlowOptics::new(500.0, 0.02, mount).unwrap();
        let s = FlowSample {
            t: Timestamp(0),
            dx: 250,
            dy: -125,
            ..FlowSample::default()
        };
        // 250 counts / 500 per rad * 0.02 m = 0.01 m; -125 counts = -0.005 m.
        let d = o.floor_displacement(&s);
        assert!((d - Vec2::new(0.01, -0.005)).norm() < 1e-7);
        // Not turning: sensor x is body y, sensor y is body -x.
        let b = o.to_body(&d, &Vec3::zeros());
        assert!((b - Vec3::new(0.005, 0.01, 0.0)).norm() < 1e-7, "{b:?}");
        // Turning in place by 0.1 rad: the sensor moves 0.01 m to the left
        // (sensor +x), the origin not at all.
        let turn = o.to_body(&Vec2::new(0.01, 0.0), &Vec3::new(0.0, 0.0, 0.1));
        assert!(turn.norm() < 1e-7, "{turn:?}");
        assert_eq!(
            FlowOptics::new(0.0, 0.02, mount),
            Err(FlowOpticsError::BadResolution)
        );
    }
}
