//! The IMU over one interval, as the slip check needs it: heading change
//! from the gyro's body z rate and mean forward specific force.
//!
//! The forward specific force equals the forward acceleration on a level
//! floor; on a slope it carries `g sin(pitch)`, which the slip check's
//! acceleration tolerance must absorb (1.5 m/s^2 is about 9 degrees).
//!
//! Each sample's rate holds over the interval since the previous sample
//! (zero-order hold backwards, as the EKF integrates between accepted
//! readings; over readings it refused, the EKF holds the last accepted rate
//! instead, and the two differ by the refused readings' few milliseconds);
//! straddling samples are split in time.

use heapless::Deque;

use super::interval::{Coverage, ending_after, overlap_fraction};
use crate::geometry::Extrinsics;
use crate::reject::{Reject, SampleCounts};
use crate::sensors::ImuSample;
use crate::time::{SampleClock, Timestamp};

#[derive(Clone, Copy, Debug, PartialEq)]
struct ImuSpan {
    t0: Timestamp,
    t1: Timestamp,
    yaw_rate: f32,
    accel_fwd: f32,
}

/// The IMU over one interval.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImuSummary {
    /// Heading change, radians (uncovered time extrapolated).
    pub yaw: f32,
    /// Mean forward specific force (body x), m/s^2.
    pub accel_fwd: f32,
    /// Fraction of the interval covered.
    pub coverage: f32,
}

/// A window of recent IMU samples reduced to body yaw rate and forward accel.
#[derive(Clone, Debug)]
pub struct ImuWindow<const N: usize> {
    mount: Extrinsics,
    spans: Deque<ImuSpan, N>,
    clock: SampleClock,
    counts: SampleCounts,
}

impl<const N: usize> ImuWindow<N> {
    /// An empty window for an IMU mounted by `mount` (`T_BS`); steps longer
    /// than `max_step_ns` are gaps.
    pub const fn new(mount: Extrinsics, max_step_ns: u64) -> Self {
        ImuWindow {
            mount,
            spans: Deque::new(),
            clock: SampleClock::new(max_step_ns),
            counts: SampleCounts::new(),
        }
    }

    /// Empties the window in place, as [`ImuWindow::new`].
    pub fn reset(&mut self, mount: Extrinsics, max_step_ns: u64) {
        self.mount = mount;
        self.spans.clear();
        self.clock = SampleClock::new(max_step_ns);
        self.counts = SampleCounts::new();
    }

    /// Fused and rejected samples by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Adds one sample (already finite by type); the first only anchors.
    pub fn push(&mut self, s: &ImuSample) -> Result<(), Reject> {
        let t0 = self.clock.last();
        let r = match self.clock.accept(s.t()) {
            Ok(None) => Err(Reject::NotReady),
            Ok(Some(_)) => {
                let g = self.mount.vector_to_body(s.gyro());
                let a = self.mount.vector_to_body(s.accel());
                if self.spans.is_full() {
                    self.spans.pop_front();
                }
                let _ = self.spans.push_back(ImuSpan {
                    t0: t0.unwrap_or(s.t()),
                    t1: s.t(),
                    yaw_rate: g.z,
                    accel_fwd: a.x,
                });
                Ok(())
            }
            Err(e) => Err(e),
        };
        self.counts.record(r);
        r
    }

    /// Heading change over `[t0, t1]`, if any sample covers it.
    pub fn yaw_between(&self, t0: Timestamp, t1: Timestamp) -> Option<f32> {
        let s = self.summarize(t0, t1);
        (s.coverage > 0.0).then_some(s.yaw)
    }

    /// Yaw and mean forward specific force over `[t0, t1]`.
    pub fn summarize(&self, t0: Timestamp, t1: Timestamp) -> ImuSummary {
        let mut cov = Coverage::new(t0, t1);
        let mut yaw = 0.0f32;
        let mut acc = 0.0f32;
        let mut w = 0.0f32;
        // Spans are in time order; those ended by `t0` add nothing.
        for s in ending_after(&self.spans, t0, |s| s.t1) {
            let f = overlap_fraction(s.t0, s.t1, t0, t1);
            if f <= 0.0 {
                continue;
            }
            cov.add(s.t0, s.t1, t0, t1);
            let dt = f * s.t1.seconds_since(s.t0).unwrap_or(0.0);
            yaw += s.yaw_rate * dt;
            acc += s.accel_fwd * dt;
            w += dt;
        }
        let coverage = cov.fraction();
        ImuSummary {
            yaw: if coverage > 0.0 { yaw / coverage } else { 0.0 },
            accel_fwd: if w > 0.0 { acc / w } else { 0.0 },
            coverage,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_yaw_rate_and_splits_samples() {
        let mut w: ImuWindow<16> = ImuWindow::new(Extrinsics::identity(), 100_000_000);
        for i in 0..=10u64 {
            let s = ImuSample::new(Timestamp(i * 10_000_000), [0.0, 0.0, 0.5], [0.2, 0.0, 9.8])
                .unwrap();
            let _ = w.push(&s);
        }
        let s = w.summarize(Timestamp(5_000_000), Timestamp(85_000_000));
        assert!((s.yaw - 0.04).abs() < 1e-5, "{}", s.yaw);
        assert!((s.accel_fwd - 0.2).abs() < 1e-5);
        assert_eq!(s.coverage, 1.0);
        assert_eq!(w.counts().rejected(Reject::NotReady), 1);
    }
}
