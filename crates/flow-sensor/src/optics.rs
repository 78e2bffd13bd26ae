//! From counts to angular flow and to metres of floor: thin helpers over
//! `vslam_core::sensors::FlowOptics`, which owns the arithmetic.

use crate::variant::Variant;
use core::fmt;
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{FlowOptics, FlowOpticsError, FlowSample};

/// Why optics for a variant could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OpticsError {
    /// The variant has no published counts-per-radian; pass a calibrated one.
    NoDefaultResolution,
    /// The resolution or height was rejected.
    Optics(FlowOpticsError),
}

impl fmt::Display for OpticsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OpticsError::NoDefaultResolution => {
                f.write_str("no default counts per radian for this variant; calibrate one")
            }
            OpticsError::Optics(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for OpticsError {}

/// Optics with the variant's default counts per radian
/// ([`Variant::default_counts_per_radian`]), `height` metres above the floor.
pub fn default_optics(
    variant: Variant,
    height: f32,
    mount: Extrinsics,
) -> Result<FlowOptics, OpticsError> {
    let cpr = variant
        .default_counts_per_radian()
        .ok_or(OpticsError::NoDefaultResolution)?;
    FlowOptics::new(cpr, height, mount).map_err(OpticsError::Optics)
}

/// The sample's angular flow `[x, y]`, radians, sensor axes.
pub fn angular_flow(sample: &FlowSample, optics: &FlowOptics) -> [f32; 2] {
    [
        optics.counts_to_radians(f32::from(sample.dx)),
        optics.counts_to_radians(f32::from(sample.dy)),
    ]
}

/// The floor travel `[x, y]` under the sensor, metres, sensor axes
/// (small-angle, at the optics' height; rotation not compensated).
pub fn floor_displacement(sample: &FlowSample, optics: &FlowOptics) -> [f32; 2] {
    let d = optics.floor_displacement(sample);
    [d.x, d.y]
}
