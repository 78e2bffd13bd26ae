//! Splitting samples at interval ends: a sample that straddles a frame time
//! stamp contributes in proportion to the part of its own interval that lies
//! inside the query interval (linear interpolation in time, constant rate
//! within a sample).

use crate::time::Timestamp;

/// Nanoseconds of `[a0, a1]` that lie inside `[b0, b1]` (zero if disjoint).
pub fn overlap_nanos(a0: Timestamp, a1: Timestamp, b0: Timestamp, b1: Timestamp) -> u64 {
    let lo = a0.max(b0);
    let hi = a1.min(b1);
    hi.nanos_since(lo).unwrap_or(0)
}

/// The fraction of the sample `[s0, s1]` that lies inside `[q0, q1]`, `0..=1`.
/// A zero-length sample counts fully when it lies inside the query, else not.
pub fn overlap_fraction(s0: Timestamp, s1: Timestamp, q0: Timestamp, q1: Timestamp) -> f32 {
    let len = s1.nanos_since(s0).unwrap_or(0);
    if len == 0 {
        return if s1 > q0 && s1 <= q1 { 1.0 } else { 0.0 };
    }
    let ov = overlap_nanos(s0, s1, q0, q1);
    (ov as f64 / len as f64) as f32
}

/// Accumulates how much of a query interval the samples covered.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Coverage {
    covered_ns: u64,
    total_ns: u64,
}

impl Coverage {
    /// Starts the tally for the query `[q0, q1]`.
    pub fn new(q0: Timestamp, q1: Timestamp) -> Self {
        Coverage {
            covered_ns: 0,
            total_ns: q1.nanos_since(q0).unwrap_or(0),
        }
    }

    /// Adds the part of the sample `[s0, s1]` inside `[q0, q1]`.
    pub fn add(&mut self, s0: Timestamp, s1: Timestamp, q0: Timestamp, q1: Timestamp) {
        self.covered_ns = self
            .covered_ns
            .saturating_add(overlap_nanos(s0, s1, q0, q1));
    }

    /// Covered fraction, `0..=1` (samples are assumed not to overlap).
    pub fn fraction(&self) -> f32 {
        if self.total_ns == 0 {
            return 0.0;
        }
        let f = (self.covered_ns as f64 / self.total_ns as f64) as f32;
        f.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straddling_sample_is_split_in_time() {
        let t = Timestamp;
        assert_eq!(overlap_fraction(t(0), t(100), t(25), t(1000)), 0.75);
        assert_eq!(overlap_fraction(t(0), t(100), t(0), t(100)), 1.0);
        assert_eq!(overlap_fraction(t(0), t(100), t(200), t(300)), 0.0);
        assert_eq!(overlap_fraction(t(50), t(50), t(0), t(100)), 1.0);
        let mut c = Coverage::new(t(0), t(200));
        c.add(t(0), t(50), t(0), t(200));
        c.add(t(150), t(250), t(0), t(200));
        assert_eq!(c.fraction(), 0.5);
    }
}
