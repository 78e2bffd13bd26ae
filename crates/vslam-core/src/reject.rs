//! Why a sample was not fused, and the per-sensor counts of what happened.
//!
//! Nothing is lost silently: every sample a consumer sees is either fused, or
//! rejected with a [`Reject`] reason (gating is one reason among them), and
//! [`SampleCounts`] keeps the tally, as PX4 EKF2 keeps per-sensor status.

use core::fmt;

/// The reason a sample was not fused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Reject {
    /// A field was NaN or infinite.
    NonFinite = 0,
    /// The time stamp is earlier than the previous sample's.
    OutOfOrder = 1,
    /// The time stamp equals the previous sample's.
    Duplicate = 2,
    /// The step from the previous sample is longer than the consumer allows.
    Gap = 3,
    /// A field lies outside what the sensor can report or the robot can
    /// physically do (a wheel speed, a gyro rate's jump).
    OutOfRange = 4,
    /// A field sits at the sensor's limit, so the true value is unknown.
    Saturated = 5,
    /// The measurement failed the consumer's statistical (chi-square) gate.
    Gated = 6,
    /// The sample carries no usable information: the sensor marked it so,
    /// or its output froze.
    LowQuality = 7,
    /// The bus transaction failed.
    Bus = 8,
    /// The sensor's own integrity check (parity, error flag, product id) failed.
    Integrity = 9,
    /// The consumer was not ready for this kind of sample (e.g. not initialised).
    NotReady = 10,
    /// The geometry of the sample is degenerate for this consumer.
    Degenerate = 11,
}

impl Reject {
    /// How many reasons there are.
    pub const COUNT: usize = 12;

    /// Every reason, in counter order.
    pub const ALL: [Reject; Reject::COUNT] = [
        Reject::NonFinite,
        Reject::OutOfOrder,
        Reject::Duplicate,
        Reject::Gap,
        Reject::OutOfRange,
        Reject::Saturated,
        Reject::Gated,
        Reject::LowQuality,
        Reject::Bus,
        Reject::Integrity,
        Reject::NotReady,
        Reject::Degenerate,
    ];

    /// A short snake_case name, stable for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Reject::NonFinite => "non_finite",
            Reject::OutOfOrder => "out_of_order",
            Reject::Duplicate => "duplicate",
            Reject::Gap => "gap",
            Reject::OutOfRange => "out_of_range",
            Reject::Saturated => "saturated",
            Reject::Gated => "gated",
            Reject::LowQuality => "low_quality",
            Reject::Bus => "bus",
            Reject::Integrity => "integrity",
            Reject::NotReady => "not_ready",
            Reject::Degenerate => "degenerate",
        }
    }

    /// The counter slot of this reason.
    pub const fn index(self) -> usize {
        self as usize
    }
}

impl fmt::Display for Reject {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl core::error::Error for Reject {}

/// Per-sensor tally: samples fused, and samples rejected by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleCounts {
    fused: u32,
    rejected: [u32; Reject::COUNT],
}

impl SampleCounts {
    /// All counts zero.
    pub const fn new() -> Self {
        SampleCounts {
            fused: 0,
            rejected: [0; Reject::COUNT],
        }
    }

    /// Counts one fused sample.
    pub fn fused_one(&mut self) {
        self.fused = self.fused.saturating_add(1);
    }

    /// Counts one rejected sample under `reason`.
    pub fn rejected_one(&mut self, reason: Reject) {
        if let Some(c) = self.rejected.get_mut(reason.index()) {
            *c = c.saturating_add(1);
        }
    }

    /// Counts the outcome of one sample.
    pub fn record(&mut self, outcome: Result<(), Reject>) {
        match outcome {
            Ok(()) => self.fused_one(),
            Err(r) => self.rejected_one(r),
        }
    }

    /// Samples fused.
    pub const fn fused(&self) -> u32 {
        self.fused
    }

    /// Samples rejected by the statistical gate.
    pub fn gated(&self) -> u32 {
        self.rejected(Reject::Gated)
    }

    /// Samples rejected for `reason`.
    pub fn rejected(&self, reason: Reject) -> u32 {
        self.rejected.get(reason.index()).copied().unwrap_or(0)
    }

    /// Samples rejected for any reason, gating included.
    pub fn rejected_total(&self) -> u32 {
        self.rejected.iter().fold(0u32, |a, b| a.saturating_add(*b))
    }

    /// Every sample seen: fused plus rejected.
    pub fn seen(&self) -> u32 {
        self.fused.saturating_add(self.rejected_total())
    }

    /// `(reason, count)` for every reason, in counter order.
    pub fn by_reason(&self) -> impl Iterator<Item = (Reject, u32)> + '_ {
        Reject::ALL
            .iter()
            .copied()
            .zip(self.rejected.iter().copied())
    }

    /// Adds `other`'s counts to these (saturating).
    pub fn add(&mut self, other: &SampleCounts) {
        self.fused = self.fused.saturating_add(other.fused);
        for (c, o) in self.rejected.iter_mut().zip(other.rejected.iter()) {
            *c = c.saturating_add(*o);
        }
    }
}

/// `fused 12, gated 3, rejected: non_finite 2, out_of_order 1`: the fused and
/// gated counts, then every other reason with a count, in counter order, by
/// its [`Reject::name`].
impl fmt::Display for SampleCounts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "fused {}, gated {}", self.fused, self.gated())?;
        let mut others = self
            .by_reason()
            .filter(|(r, n)| *r != Reject::Gated && *n > 0)
            .peekable();
        if others.peek().is_some() {
            f.write_str(", rejected:")?;
            for (i, (r, n)) in others.enumerate() {
                let sep = if i == 0 { " " } else { ", " };
                write!(f, "{sep}{r} {n}")?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    #[test]
    fn reasons_print_their_names() {
        assert_eq!(Reject::NonFinite.to_string(), "non_finite");
        assert_eq!(Reject::OutOfOrder.to_string(), "out_of_order");
        assert_eq!(Reject::NotReady.to_string(), "not_ready");
        for r in Reject::ALL {
            assert_eq!(r.to_string(), r.name());
        }
    }

    #[test]
    fn counts_print_fused_gated_and_each_reason() {
        let mut c = SampleCounts::new();
        assert_eq!(c.to_string(), "fused 0, gated 0");
        for _ in 0..12 {
            c.fused_one();
        }
        for _ in 0..3 {
            c.rejected_one(Reject::Gated);
        }
        c.rejected_one(Reject::OutOfOrder);
        c.rejected_one(Reject::NonFinite);
        c.rejected_one(Reject::NonFinite);
        assert_eq!(
            c.to_string(),
            "fused 12, gated 3, rejected: non_finite 2, out_of_order 1"
        );
        let mut total = SampleCounts::new();
        total.add(&c);
        total.add(&c);
        assert_eq!(total.fused(), 24);
        assert_eq!(total.rejected(Reject::NonFinite), 4);
        assert_eq!(total.seen(), 2 * c.seen());
    }

    #[test]
    fn every_reason_has_its_own_slot_and_name() {
        for (i, r) in Reject::ALL.iter().enumerate() {
            assert_eq!(r.index(), i);
            for other in &Reject::ALL[i + 1..] {
                assert_ne!(r.name(), other.name());
            }
        }
    }

    #[test]
    fn counts_add_up() {
        let mut c = SampleCounts::new();
        c.record(Ok(()));
        c.record(Err(Reject::Gated));
        c.record(Err(Reject::NonFinite));
        c.record(Err(Reject::NonFinite));
        assert_eq!(c.fused(), 1);
        assert_eq!(c.gated(), 1);
        assert_eq!(c.rejected(Reject::NonFinite), 2);
        assert_eq!(c.seen(), 4);
        assert_eq!(c.by_reason().map(|(_, n)| n).sum::<u32>(), 3);
    }
}
