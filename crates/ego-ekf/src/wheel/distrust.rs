//! The scale pipeline's verdict on the wheels, held by the filter: after a
//! camera frame pair in which the wheels slipped or were an outlier
//! (`vslam_core::scale::FrameDecision::slip`, `wheel_outlier`), the wheel
//! samples up to a given time are fused with their forward and
//! differential noise inflated ([`WheelDistrust::factor_at`]).
//!
//! The verdict covers a frame interval that has already been fused (the
//! pair is judged when its second frame arrives), so it is held forward,
//! over the next interval, until the next pair's verdict renews or lets it
//! lapse: slip on a floor lasts longer than one frame interval. The wheels'
//! gate then works on the inflated variance, so a distrusted sample is
//! fused with little weight rather than gated; an infinite factor refuses
//! the forward and differential rows (the lateral and vertical ones are
//! fused, as for a gated sample, and the sample counts as gated). Samples
//! taken while the verdict holds are counted on their own
//! ([`WheelDistrust::counts`]), besides their one count in the wheel tally.

use vslam_core::{Reject, SampleCounts, Timestamp};

/// The standing distrust of the wheels and its tally.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelDistrust {
    until: Option<Timestamp>,
    factor: f32,
    counts: SampleCounts,
}

impl WheelDistrust {
    /// No distrust.
    pub const fn new() -> Self {
        WheelDistrust {
            until: None,
            factor: 0.0,
            counts: SampleCounts::new(),
        }
    }

    /// Distrusts the wheels by `factor` (the forward and differential
    /// noise's standard deviation is multiplied by it) for samples taken up
    /// to `until`. A later `until` extends the window; the factor is the
    /// latest one; an infinite factor refuses the rows. Errors:
    /// [`Reject::OutOfRange`] for a factor below 1 or NaN (nothing changes).
    pub fn distrust_until(&mut self, until: Timestamp, factor: f32) -> Result<(), Reject> {
        if factor.is_nan() || factor < 1.0 {
            return Err(Reject::OutOfRange);
        }
        self.until = Some(self.until.map_or(until, |u| u.max(until)));
        self.factor = factor;
        Ok(())
    }

    /// The noise factor for a sample taken at `t`: the distrust's factor
    /// while it holds, 1 otherwise.
    pub fn factor_at(&self, t: Timestamp) -> f32 {
        match self.until {
            Some(u) if t <= u => self.factor,
            _ => 1.0,
        }
    }

    /// Whether the distrust holds at `t`.
    pub fn holds_at(&self, t: Timestamp) -> bool {
        self.until.is_some_and(|u| t <= u)
    }

    /// Counts the outcome of a sample taken while the distrust held.
    pub fn record(&mut self, outcome: Result<(), Reject>) {
        self.counts.record(outcome);
    }

    /// Samples taken while the distrust held: fused with the inflated noise,
    /// gated or rejected (each also in the wheel tally).
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Lifts the distrust (the tally stays).
    pub fn clear(&mut self) {
        self.until = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_until_its_time_and_refuses_bad_factors() {
        let mut d = WheelDistrust::default();
        assert_eq!(d.factor_at(Timestamp(5)), 1.0);
        assert_eq!(
            d.distrust_until(Timestamp(10), 0.5),
            Err(Reject::OutOfRange)
        );
        assert_eq!(
            d.distrust_until(Timestamp(10), f32::NAN),
            Err(Reject::OutOfRange)
        );
        assert!(d.distrust_until(Timestamp(3), f32::INFINITY).is_ok());
        assert!(d.factor_at(Timestamp(3)).is_infinite());
        assert!(!d.holds_at(Timestamp(5)));
        d.distrust_until(Timestamp(10), 8.0).unwrap();
        assert_eq!(d.factor_at(Timestamp(10)), 8.0);
        assert_eq!(d.factor_at(Timestamp(11)), 1.0);
        // An earlier end does not shorten the window.
        d.distrust_until(Timestamp(7), 4.0).unwrap();
        assert_eq!(d.factor_at(Timestamp(9)), 4.0);
        d.clear();
        assert_eq!(d.factor_at(Timestamp(9)), 1.0);
    }
}
