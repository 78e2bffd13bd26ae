//! Splitting samples at interval ends: a sample that straddles a frame time
//! stamp contributes in proportion to the part of its own interval that lies
//! inside the query interval (linear interpolation in time, constant rate
//! within a sample).

use heapless::Deque;

use crate::time::Timestamp;

/// Nanoseconds of `[a0, a1]` that lie inside `[b0, b1]` (zero if disjoint).
pub fn overlap_nanos(a0: Timestamp, a1: Timestamp, b0: Timestamp, b1: Timestamp) -> u64 {
    let lo = a0.max(b0);
    let hi = a1.min(b1);
    hi.nanos_since(lo).unwrap_or(0)
}

/// The items of a window whose end times never decrease that end after
/// `t0`, oldest first. The others lie wholly before a query that starts at
/// `t0` ([`overlap_fraction`] is 0 for each), so a summary can leave them
/// out; found from the newest end, so a query over recent time looks at the
/// recent items only.
pub fn ending_after<T, const N: usize>(
    window: &Deque<T, N>,
    t0: Timestamp,
    end: impl Fn(&T) -> Timestamp,
) -> impl Iterator<Item = &T> {
    let recent = window.iter().rev().take_while(|s| end(s) > t0).count();
    let (older, newer) = window.as_slices();
    let skip = (older.len() + newer.len()).saturating_sub(recent);
    let from_newer = skip.saturating_sub(older.len());
    let older = older.get(skip.min(older.len())..).unwrap_or(&[]);
    let newer = newer.get(from_newer..).unwrap_or(&[]);
    older.iter().chain(newer)
}

/// The fraction of the sample `[s0, s1]` that lies inside `[q0, q1]`, `0..=1`.
/// A zero-length sample counts fully when it lies inside the query, else not.
pub fn overlap_fraction(s0: Timestamp, s1: Timestamp, q0: Timestamp, q1: Timestamp) -> f32 {
    let len = s1.nanos_since(s0).unwrap_or(0);
    if len == 0 {
        return if s1 > q0 && s1 <= q1 { 1.0 } else { 0.0 };
    }
    let ov = overlap_nanos(s0, s1, q0, q1);
    // Most samples lie wholly outside or inside the query: their fractions
    // are exact without the double-precision division, which a single-
    // precision FPU (Cortex-M4F) runs in software.
    if ov == 0 {
        return 0.0;
    }
    if ov == len {
        return 1.0;
    }
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

    #[test]
    fn ending_after_gives_the_items_that_end_after_the_query_start() {
        // A deque that has wrapped, so its items lie in two slices.
        let mut d: Deque<u64, 4> = Deque::new();
        for e in [0u64, 5, 10, 20, 30, 40] {
            if d.is_full() {
                d.pop_front();
            }
            let _ = d.push_back(e);
        }
        assert!(!d.as_slices().1.is_empty());
        let after = |t0| {
            let v: heapless::Vec<u64, 4> = ending_after(&d, Timestamp(t0), |&e| Timestamp(e))
                .copied()
                .collect();
            v
        };
        assert_eq!(after(5)[..], [10, 20, 30, 40]);
        assert_eq!(after(20)[..], [30, 40]);
        assert_eq!(after(25)[..], [30, 40]);
        assert_eq!(after(35)[..], [40]);
        assert!(after(40).is_empty());
        let empty: Deque<u64, 4> = Deque::new();
        assert_eq!(
            ending_after(&empty, Timestamp(7), |&e| Timestamp(e)).count(),
            0
        );
    }

    #[test]
    fn fraction_equals_the_double_precision_ratio_bit_for_bit() {
        // The shortcuts for disjoint and contained samples give the bits of
        // the division they skip (xorshift-drawn intervals, many of each).
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |m: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % m
        };
        for _ in 0..20_000 {
            let (s0, q0) = (next(1_000), next(1_000));
            let (s1, q1) = (s0 + 1 + next(300), q0 + next(300));
            let (s, q) = (
                (Timestamp(s0), Timestamp(s1)),
                (Timestamp(q0), Timestamp(q1)),
            );
            let ov = overlap_nanos(s.0, s.1, q.0, q.1);
            let reference = (ov as f64 / (s1 - s0) as f64) as f32;
            assert_eq!(
                overlap_fraction(s.0, s.1, q.0, q.1).to_bits(),
                reference.to_bits(),
                "{s:?} {q:?}"
            );
        }
    }
}
