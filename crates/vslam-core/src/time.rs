//! Time: integer nanoseconds, as in the ASL/EuRoC dataset format.
//!
//! Time is never accumulated in floats. Durations are differences of
//! [`Timestamp`]s and become `f32` seconds only at the point of use
//! ([`Timestamp::seconds_since`]). [`SampleClock`] is the one place that decides
//! whether a new sample's time stamp is usable relative to the previous one.

use crate::reject::Reject;

/// A point in time, nanoseconds since an arbitrary epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Timestamp(pub u64);

impl Timestamp {
    /// The time stamp `ns` nanoseconds after the epoch.
    pub const fn from_nanos(ns: u64) -> Self {
        Timestamp(ns)
    }

    /// Nanoseconds since the epoch.
    pub const fn as_nanos(self) -> u64 {
        self.0
    }

    /// Nanoseconds from `earlier` to `self`, or `None` if `earlier` is later.
    pub const fn nanos_since(self, earlier: Timestamp) -> Option<u64> {
        self.0.checked_sub(earlier.0)
    }

    /// Seconds from `earlier` to `self` as `f32`, or `None` if `earlier` is later.
    pub fn seconds_since(self, earlier: Timestamp) -> Option<f32> {
        // Split so that large epochs keep their sub-second precision.
        self.nanos_since(earlier).map(nanos_to_seconds)
    }

    /// `self` plus `ns` nanoseconds, or `None` on overflow.
    pub const fn checked_add_nanos(self, ns: u64) -> Option<Timestamp> {
        match self.0.checked_add(ns) {
            Some(v) => Some(Timestamp(v)),
            None => None,
        }
    }
}

/// Converts a nanosecond count to `f32` seconds without losing the fraction
/// to the magnitude of the whole seconds first.
pub fn nanos_to_seconds(ns: u64) -> f32 {
    let whole = (ns / 1_000_000_000) as f32;
    let frac = (ns % 1_000_000_000) as f32 / 1e9;
    whole + frac
}

/// Decides, sample by sample, whether a stream's time stamps are usable.
///
/// - a time stamp before the previous one is [`Reject::OutOfOrder`] (the clock
///   keeps the previous time);
/// - the same time stamp again is [`Reject::Duplicate`];
/// - a step larger than `max_step_ns` is [`Reject::Gap`]: the sample cannot be
///   integrated over such an interval, but the clock re-anchors on it so that
///   the stream recovers with its next sample.
///
/// On success it returns the step in seconds (`None` for the first sample).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleClock {
    last: Option<Timestamp>,
    max_step_ns: u64,
}

impl SampleClock {
    /// A clock that accepts steps up to `max_step_ns` nanoseconds.
    pub const fn new(max_step_ns: u64) -> Self {
        SampleClock {
            last: None,
            max_step_ns,
        }
    }

    /// The time stamp of the last accepted (or re-anchoring) sample.
    pub const fn last(&self) -> Option<Timestamp> {
        self.last
    }

    /// The largest accepted step, nanoseconds.
    pub const fn max_step_ns(&self) -> u64 {
        self.max_step_ns
    }

    /// Forgets the previous sample: the next one starts the stream again.
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// Whether `t` is later than the last accepted sample (or there is none):
    /// the time stamps [`SampleClock::accept`] does not refuse as
    /// [`Reject::OutOfOrder`] or [`Reject::Duplicate`]. Changes nothing.
    pub fn follows(&self, t: Timestamp) -> bool {
        self.last
            .is_none_or(|last| t.nanos_since(last).is_some_and(|d| d > 0))
    }

    /// Checks `t` against the previous sample; see the type's documentation.
    pub fn accept(&mut self, t: Timestamp) -> Result<Option<f32>, Reject> {
        let Some(last) = self.last else {
            self.last = Some(t);
            return Ok(None);
        };
        match t.nanos_since(last) {
            None => Err(Reject::OutOfOrder),
            Some(0) => Err(Reject::Duplicate),
            Some(step) if step > self.max_step_ns => {
                self.last = Some(t);
                Err(Reject::Gap)
            }
            Some(step) => {
                self.last = Some(t);
                Ok(Some(nanos_to_seconds(step)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_keep_precision_at_large_epochs() {
        let a = Timestamp(1_403_636_579_758_555_392);
        let b = Timestamp(a.0 + 4_000_000);
        let dt = b.seconds_since(a);
        assert_eq!(dt, Some(0.004));
        assert_eq!(a.seconds_since(b), None);
    }

    #[test]
    fn clock_rejects_with_reasons_and_recovers_after_gap() {
        let mut c = SampleClock::new(100_000_000);
        assert!(c.follows(Timestamp(1_000)));
        assert_eq!(c.accept(Timestamp(1_000)), Ok(None));
        assert!(!c.follows(Timestamp(1_000)) && !c.follows(Timestamp(999)));
        assert!(c.follows(Timestamp(1_001)));
        assert_eq!(c.accept(Timestamp(1_000)), Err(Reject::Duplicate));
        assert_eq!(c.accept(Timestamp(999)), Err(Reject::OutOfOrder));
        assert_eq!(c.last(), Some(Timestamp(1_000)));
        let dt = c.accept(Timestamp(4_001_000));
        assert_eq!(dt, Ok(Some(0.004)));
        assert_eq!(c.accept(Timestamp(5_004_001_000)), Err(Reject::Gap));
        assert_eq!(c.accept(Timestamp(5_008_001_000)), Ok(Some(0.004)));
    }
}
