//! Bus and chip faults: when to tell a register-level simulator to
//! misbehave, and the reads that failed because of it. The drivers see
//! the faults through their real protocols (`sim::drivers`).

use super::kind::{FaultKind, Stage};
use super::spec::{FaultPlan, FaultSpec};
use crate::asl::LoggedFailure;
use traction::vslam_core::{Reject, Stream, Timestamp};

/// A read that produced no sample: the driver's error turned into its reason.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FailedRead {
    /// When the read was made.
    pub t: Timestamp,
    /// Which stream lost the sample.
    pub stream: Stream,
    /// Why (bus, integrity).
    pub reason: Reject,
    /// Index of the fault in the plan.
    pub fault: usize,
}

impl FailedRead {
    /// The read as a log records it (`failed.csv`: no fault index).
    pub fn logged(&self) -> LoggedFailure {
        LoggedFailure {
            t: self.t,
            stream: self.stream,
            reason: self.reason,
        }
    }
}

/// The chip faults of one stream that fire on single reads, in read order:
/// each fires on `count` reads from its start on.
pub struct ChipSchedule {
    faults: Vec<(usize, FaultSpec, u32)>,
    current: Option<usize>,
}

impl ChipSchedule {
    /// The read-by-read chip faults of `plan` on `stream` (a wrap-around
    /// is a motion of the shaft, not a read fault: `sim::drivers` does it).
    pub fn new(plan: &FaultPlan, stream: Stream) -> Self {
        let faults = plan
            .select(|f| {
                f.kind.stage() == Stage::Chip
                    && f.kind.stream() == Some(stream)
                    && f.kind != FaultKind::WheelWrap
            })
            .map(|(i, f)| (i, *f, f.count))
            .collect();
        ChipSchedule {
            faults,
            current: None,
        }
    }

    /// The fault to inject before the read at `t`, if one is due: its plan
    /// index and kind.
    pub fn at(&mut self, t: Timestamp) -> Option<(usize, FaultKind)> {
        self.current = None;
        let (i, spec, left) = self
            .faults
            .iter_mut()
            .find(|(_, f, left)| *left > 0 && t.0 >= f.start_ns())?;
        *left -= 1;
        self.current = Some(*i);
        Some((*i, spec.kind))
    }

    /// The fault injected before the current read, if any.
    pub fn current(&self) -> Option<usize> {
        self.current
    }
}
