//! What the floor explains at one instant: the jolt thresholds of the
//! current floor and of a threshold strip, the dominant floor and the floor
//! boundaries around now. [`super::SurfaceModel::jolt_context`] makes it per
//! IMU step; the jolt monitor ([`crate::events`]) judges each jolt against
//! it. A leaf: it needs only the floor kinds and the grip parameters.

use vslam_core::Timestamp;

use super::classes::SurfaceKind;
use crate::grip::GripParams;

/// What the floor explains, at one instant (from the surface model).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JoltContext {
    /// The jolt the current floor explains, m/s^2.
    pub jolt_threshold: f32,
    /// The jolt the current floor explains without a threshold strip's
    /// share of it (the floors beside the strip; the conservative default
    /// when the strip is all of it), m/s^2. A strip explains jolts only at a
    /// floor boundary ([`crate::events`]).
    pub floor_jolt_threshold: f32,
    /// The jolt a threshold strip explains, m/s^2.
    pub strip_threshold: f32,
    /// The dominant floor, if known.
    pub surface: Option<SurfaceKind>,
    /// The last floor-boundary crossing, if any.
    pub last_crossing: Option<Timestamp>,
    /// The next anticipated floor-boundary crossing, if any.
    pub next_crossing: Option<Timestamp>,
    /// Forward speed, m/s (for the distance to a crossing).
    pub forward_speed: f32,
}

impl JoltContext {
    /// A context without surface awareness: one fixed threshold, no boundaries.
    pub fn fixed(jolt_threshold: f32) -> Self {
        JoltContext {
            jolt_threshold,
            floor_jolt_threshold: jolt_threshold,
            strip_threshold: jolt_threshold,
            surface: None,
            last_crossing: None,
            next_crossing: None,
            forward_speed: 0.0,
        }
    }

    /// A context from grip parameters alone (no boundary information).
    pub fn from_params(params: &GripParams, surface: Option<SurfaceKind>) -> Self {
        JoltContext {
            surface,
            ..JoltContext::fixed(params.jolt_threshold())
        }
    }
}
