//! Failed encoder reads as breaks in the count stream (and, in a second
//! instance, missed reads, across which the odometry checks its step
//! instead of anchoring afresh: `DiffDriveOdometry::read_missed`).
//!
//! A read that failed may leave the cumulative counts discontinuous: a
//! counter extension that refused a jump (an aliased angle, a wheel that
//! spun free) re-anchors on the new raw value and holds its position, so the
//! motion across the failure is missing from the counts. A step whose ends
//! lie on either side of a failed read would turn that missing motion into a
//! wheel rate far too low; [`ReadBreaks`] remembers when reads failed so the
//! odometry anchors afresh on the first sample after one instead.
//!
//! Failed reads are reported as they happen, while the samples before them
//! may still wait in the caller's ordering window, so a break is kept until
//! a sample later than it arrives. Only the earliest and the latest pending
//! break are kept (fixed memory): a sample between two reported breaks
//! consumes the earlier, and breaks strictly between the earliest and the
//! latest are forgotten. With the ordering window shorter than a wheel
//! period (20 ms against 20 ms at 50 Hz by default) that needs three failed
//! reads interleaved with waiting samples inside one window.

use vslam_core::Timestamp;

/// The failed reads not yet behind the odometry's anchor.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReadBreaks {
    /// Earliest and latest pending break.
    pending: Option<(Timestamp, Timestamp)>,
}

impl ReadBreaks {
    /// No break pending.
    pub const fn new() -> Self {
        ReadBreaks { pending: None }
    }

    /// A read failed at `t`.
    pub fn mark(&mut self, t: Timestamp) {
        self.pending = Some(match self.pending {
            None => (t, t),
            Some((first, last)) => (first.min(t), last.max(t)),
        });
    }

    /// Whether a break lies in `(from, to)`, the span of a step; breaks up
    /// to `to` are consumed.
    pub fn take(&mut self, from: Timestamp, to: Timestamp) -> bool {
        let Some((first, last)) = self.pending else {
            return false;
        };
        let inside = |t: Timestamp| t > from && t < to;
        let spans = inside(first) || inside(last);
        self.consume(to);
        spans
    }

    /// Consumes the breaks up to `to` (the later one stays pending if it is
    /// at or after `to`).
    pub fn consume(&mut self, to: Timestamp) {
        if let Some((_, last)) = self.pending {
            self.pending = if last < to { None } else { Some((last, last)) };
        }
    }

    /// Whether a break lies in `(from, to)`, consuming nothing: for a step
    /// that may still be refused and tried again from the same anchor.
    pub fn spans(&self, from: Timestamp, to: Timestamp) -> bool {
        self.pending
            .is_some_and(|(first, last)| [first, last].iter().any(|&t| t > from && t < to))
    }

    /// Whether any break is pending.
    pub const fn is_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// Forgets every pending break.
    pub fn clear(&mut self) {
        self.pending = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Timestamp {
        Timestamp(v * 1_000_000)
    }

    #[test]
    fn a_break_inside_the_step_is_reported_once() {
        let mut b = ReadBreaks::new();
        b.mark(ms(30));
        assert!(b.take(ms(20), ms(40)));
        assert!(!b.is_pending());
        assert!(!b.take(ms(40), ms(60)));
    }

    #[test]
    fn a_break_after_the_step_waits_for_a_later_sample() {
        let mut b = ReadBreaks::new();
        b.mark(ms(50));
        // A sample still in the ordering window, older than the failure.
        assert!(!b.take(ms(20), ms(40)));
        assert!(b.is_pending());
        assert!(b.take(ms(40), ms(60)));
    }

    #[test]
    fn a_break_before_the_anchor_is_dropped() {
        let mut b = ReadBreaks::new();
        b.mark(ms(10));
        assert!(!b.take(ms(20), ms(40)));
        assert!(!b.is_pending());
    }

    #[test]
    fn breaks_on_either_side_of_a_waiting_sample_break_both_steps() {
        let mut b = ReadBreaks::new();
        b.mark(ms(30));
        b.mark(ms(50));
        assert!(b.take(ms(20), ms(40)));
        assert!(b.take(ms(40), ms(60)));
        assert!(!b.is_pending());
    }

    #[test]
    fn a_run_of_failed_reads_is_one_break() {
        let mut b = ReadBreaks::new();
        for t in [30, 50, 70, 90] {
            b.mark(ms(t));
        }
        assert!(b.take(ms(20), ms(110)));
        assert!(!b.take(ms(110), ms(130)));
    }
}
