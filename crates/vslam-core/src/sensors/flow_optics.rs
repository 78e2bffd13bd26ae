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
