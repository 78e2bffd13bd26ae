//! Puts samples of every stream into one time order.
//!
//! Sensors deliver with different latencies (an IMU over SPI at once, wheel
//! counts from a timer interrupt, a flow report over a slower bus), so the
//! samples of different streams reach the estimator slightly out of order.
//! [`Reorder`] holds them in a fixed-capacity min-heap and releases a sample
//! once the newest time stamp seen is `window` past it, so everything that
//! arrives within the window is processed in time order. A sample older than
//! what was already released is too late: it is handed back with
//! [`Reject::OutOfOrder`]. A full buffer releases its oldest sample first (the
//! caller processes it), so nothing is dropped silently.

use core::cmp::Ordering;
use heapless::binary_heap::{BinaryHeap, Min};
use vslam_core::sensors::{FlowSample, RawImuSample, RawWheelRates, WheelTicks};
use vslam_core::{Reject, Stream, Timestamp};

/// A sample of one of the buffered streams (see [`Event::stream`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// An IMU reading.
    Imu(RawImuSample),
    /// Cumulative wheel encoder counts.
    Wheel(WheelTicks),
    /// Wheel angular rates, from a robot that reports rates instead of
    /// counts (the wheel stream all the same).
    WheelRates(RawWheelRates),
    /// An optical-flow report.
    Flow(FlowSample),
}

impl Event {
    /// The sample's time stamp.
    pub fn t(&self) -> Timestamp {
        match self {
            Event::Imu(s) => s.t,
            Event::Wheel(s) => s.t,
            Event::WheelRates(s) => s.t,
            Event::Flow(s) => s.t,
        }
    }

    /// The stream the sample belongs to.
    pub const fn stream(&self) -> Stream {
        match self {
            Event::Imu(_) => Stream::Imu,
            Event::Wheel(_) | Event::WheelRates(_) => Stream::Wheel,
            Event::Flow(_) => Stream::Flow,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Keyed {
    t: Timestamp,
    seq: u32,
    event: Event,
}

impl PartialEq for Keyed {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Keyed {}
impl PartialOrd for Keyed {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Keyed {
    fn cmp(&self, other: &Self) -> Ordering {
        // Arrival order breaks ties, with wrap-around of the sequence number.
        self.t
            .cmp(&other.t)
            .then_with(|| (self.seq.wrapping_sub(other.seq) as i32).cmp(&0))
    }
}

/// What [`Reorder::push`] did with a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pushed {
    /// Buffered.
    Held,
    /// Buffered, after the buffer had to release its oldest sample, returned here.
    HeldReleasing(Event),
}

/// The time-ordering buffer; `N` samples of capacity.
pub struct Reorder<const N: usize> {
    heap: BinaryHeap<Keyed, Min, N>,
    window_ns: u64,
    newest: Option<Timestamp>,
    released: Option<Timestamp>,
    seq: u32,
}

impl<const N: usize> Reorder<N> {
    /// A buffer that waits `window_ns` nanoseconds for late samples.
    pub const fn new(window_ns: u64) -> Self {
        Reorder {
            heap: BinaryHeap::new(),
            window_ns,
            newest: None,
            released: None,
            seq: 0,
        }
    }

    /// Samples held.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }

    /// The time stamp of the last released sample.
    pub fn released_up_to(&self) -> Option<Timestamp> {
        self.released
    }

    /// Empties the buffer in place and waits `window_ns` from now on, as
    /// [`Reorder::new`].
    pub fn reset(&mut self, window_ns: u64) {
        self.heap.clear();
        self.window_ns = window_ns;
        self.newest = None;
        self.released = None;
        self.seq = 0;
    }

    /// Offers a sample. Too late (older than a released one): `Err((OutOfOrder, event))`.
    pub fn push(&mut self, event: Event) -> Result<Pushed, (Reject, Event)> {
        let t = event.t();
        if self.released.is_some_and(|r| t < r) {
            return Err((Reject::OutOfOrder, event));
        }
        if self.newest.is_none_or(|n| t > n) {
            self.newest = Some(t);
        }
        let keyed = Keyed {
            t,
            seq: self.seq,
            event,
        };
        self.seq = self.seq.wrapping_add(1);
        let Err(keyed) = self.heap.push(keyed) else {
            return Ok(Pushed::Held);
        };
        // Full: whichever is oldest, the held head or the newcomer, goes out now.
        if self.heap.peek().is_some_and(|head| head.t <= t)
            && let Some(oldest) = self.heap.pop()
        {
            self.released = Some(oldest.t);
            // A place is free now, so this push succeeds.
            let _ = self.heap.push(keyed);
            return Ok(Pushed::HeldReleasing(oldest.event));
        }
        self.released = Some(t);
        Ok(Pushed::HeldReleasing(event))
    }

    /// The next sample that has waited its window, in time order.
    pub fn pop_ready(&mut self) -> Option<Event> {
        let newest = self.newest?;
        let head = self.heap.peek()?;
        if newest
            .nanos_since(head.t)
            .is_some_and(|d| d >= self.window_ns)
        {
            self.pop_any()
        } else {
            None
        }
    }

    /// The next sample with time stamp at or before `t`, waiting or not
    /// (used before a camera frame at `t` is processed).
    pub fn pop_until(&mut self, t: Timestamp) -> Option<Event> {
        if self.heap.peek().is_some_and(|h| h.t <= t) {
            self.pop_any()
        } else {
            None
        }
    }

    /// The oldest sample, whatever its age (used at the end of a log).
    pub fn pop_any(&mut self) -> Option<Event> {
        let k = self.heap.pop()?;
        self.released = Some(k.t);
        Some(k.event)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wheel(t: u64) -> Event {
        Event::Wheel(WheelTicks {
            t: Timestamp(t),
            left: t as i64,
            right: 0,
        })
    }

    fn imu(t: u64) -> Event {
        Event::Imu(RawImuSample {
            t: Timestamp(t),
            gyro: [0.0; 3],
            accel: [0.0; 3],
        })
    }

    #[test]
    fn releases_in_time_order_after_the_window() {
        let mut r: Reorder<8> = Reorder::new(10);
        r.push(imu(100)).unwrap();
        r.push(wheel(95)).unwrap();
        assert_eq!(r.pop_ready(), None, "window not yet passed");
        r.push(imu(104)).unwrap();
        r.push(imu(108)).unwrap();
        assert_eq!(r.pop_ready().map(|e| e.t()), Some(Timestamp(95)));
        assert_eq!(r.pop_ready(), None, "100 is only 8 ns behind 108");
        r.push(imu(112)).unwrap();
        assert_eq!(r.pop_ready().map(|e| e.t()), Some(Timestamp(100)));
        // Too late now: 99 < 100 released.
        assert_eq!(r.push(wheel(99)), Err((Reject::OutOfOrder, wheel(99))));
        // Same time stamp keeps arrival order.
        r.push(wheel(104)).unwrap();
        assert_eq!(r.pop_until(Timestamp(104)), Some(imu(104)));
        assert_eq!(r.pop_until(Timestamp(104)), Some(wheel(104)));
        assert_eq!(r.pop_until(Timestamp(104)), None);
        assert_eq!(r.pop_any().map(|e| e.t()), Some(Timestamp(108)));
    }

    #[test]
    fn events_name_their_streams() {
        assert_eq!(imu(1).stream(), Stream::Imu);
        assert_eq!(wheel(1).stream(), Stream::Wheel);
        let flow = Event::Flow(FlowSample {
            t: Timestamp(1),
            ..FlowSample::default()
        });
        assert_eq!(flow.stream(), Stream::Flow);
    }

    #[test]
    fn full_buffer_releases_oldest_and_loses_nothing() {
        let mut r: Reorder<2> = Reorder::new(1_000);
        r.push(imu(10)).unwrap();
        r.push(imu(20)).unwrap();
        assert_eq!(r.push(imu(30)), Ok(Pushed::HeldReleasing(imu(10))));
        // Older than everything held while full: it is itself released at once.
        assert_eq!(r.push(imu(15)), Ok(Pushed::HeldReleasing(imu(15))));
        assert_eq!(r.pop_any(), Some(imu(20)));
        assert_eq!(r.pop_any(), Some(imu(30)));
        assert!(r.is_empty());
    }
}
