//! The scale pipeline's verdict on the wheels in [`EgoEkf`] (see
//! [`crate::wheel::distrust`]).

use vslam_core::{Reject, SampleCounts, Timestamp};

use super::EgoEkf;

impl EgoEkf {
    /// Fuses the wheel samples taken up to `until` with their forward and
    /// differential noise's standard deviation multiplied by `factor` (at
    /// least 1; infinite: those rows are refused and the sample counts as
    /// gated): the scale pipeline found the wheels slipping or an outlier
    /// (see [`crate::wheel::distrust`]). A later `until` extends a standing
    /// distrust; the factor is the latest. Errors: [`Reject::OutOfRange`]
    /// for a factor below 1 or NaN (nothing changes).
    pub fn distrust_wheels_until(&mut self, until: Timestamp, factor: f32) -> Result<(), Reject> {
        self.distrust.distrust_until(until, factor)
    }

    /// The wheel noise factor for a sample taken at `t` (1 without distrust).
    pub fn wheel_noise_factor(&self, t: Timestamp) -> f32 {
        self.distrust.factor_at(t)
    }

    /// Wheel samples taken while the scale pipeline's distrust held: fused
    /// with the inflated noise, gated or rejected (each sample also counted
    /// once in [`EgoEkf::wheel_counts`]).
    pub fn wheel_distrust_counts(&self) -> &SampleCounts {
        self.distrust.counts()
    }

    /// Horizontal impacts seen and the wheel samples gated strictly around
    /// them (see [`crate::impact`]).
    pub fn impacts(&self) -> &crate::impact::ImpactWatch {
        &self.impact
    }
}
