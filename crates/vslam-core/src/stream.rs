//! The sensor registry: one [`Stream`] names every kind of sample traction
//! takes, and [`PerStream`] is an array indexed by it.
//!
//! Everything that keeps something per stream (the estimator's counts, the
//! reorder buffer's events, host-sim's fault injection and reports, the
//! firmware's record tallies) indexes by [`Stream`], the way [`SampleCounts`]
//! indexes its rejections by [`Reject`](crate::Reject) (per-sensor status as
//! PX4 EKF2 keeps it). A new stream is one variant here: [`PerStream`] grows
//! with it, every report that iterates [`Stream::ALL`] lists it, and every
//! exhaustive `match` over [`Stream`] fails to compile until the new stream
//! is handled.
//!
//! ```
//! use vslam_core::{Reject, Stream, StreamCounts};
//!
//! let mut counts = StreamCounts::zero();
//! counts[Stream::Imu].record(Ok(()));
//! counts[Stream::Flow].record(Err(Reject::Gated));
//! counts[Stream::Flow].record(Err(Reject::NonFinite));
//! assert_eq!(counts[Stream::Flow].seen(), 2);
//! // A report names every stream, in slot order.
//! let names: Vec<&str> = counts.iter().map(|(s, _)| s.name()).collect();
//! assert_eq!(names[..3], ["imu", "wheel", "flow"]);
//! // Printed: the streams that saw samples, with the reasons by name.
//! assert_eq!(
//!     counts.to_string(),
//!     "imu: fused 1, gated 0\nflow: fused 0, gated 1, rejected: non_finite 1"
//! );
//! ```

use core::fmt;
use core::ops::{Index, IndexMut};

use crate::reject::SampleCounts;

/// A kind of sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Stream {
    /// IMU samples (gyro and accelerometer).
    Imu = 0,
    /// Cumulative wheel encoder counts.
    Wheel = 1,
    /// Optical-flow reports: motion counts, SQUAL, shutter.
    Flow = 2,
    /// Raw frames of the optical-flow sensor (the chip's frame grab).
    FlowFrame = 3,
    /// Frames of the upward (ceiling) camera.
    Camera = 4,
    /// Frames of the forward camera (the images segmentation labels).
    ForwardCamera = 5,
    /// Segmentation label maps of the forward camera.
    Segmentation = 6,
}

impl Stream {
    /// How many streams there are.
    pub const COUNT: usize = 7;

    /// Every stream, in slot order.
    pub const ALL: [Stream; Stream::COUNT] = [
        Stream::Imu,
        Stream::Wheel,
        Stream::Flow,
        Stream::FlowFrame,
        Stream::Camera,
        Stream::ForwardCamera,
        Stream::Segmentation,
    ];

    /// A short snake_case name, stable for reports (the `counts` keys of
    /// host-sim's `report.json`).
    pub const fn name(self) -> &'static str {
        match self {
            Stream::Imu => "imu",
            Stream::Wheel => "wheel",
            Stream::Flow => "flow",
            Stream::FlowFrame => "flow_frame",
            Stream::Camera => "camera",
            Stream::ForwardCamera => "forward_camera",
            Stream::Segmentation => "segmentation",
        }
    }

    /// The slot of this stream in a [`PerStream`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The stream called `name` (see [`Stream::name`]).
    pub fn from_name(name: &str) -> Option<Stream> {
        Stream::ALL.iter().copied().find(|s| s.name() == name)
    }
}

// `ALL` lists the streams in slot order, each once: this is what keeps the
// indexing of `PerStream` in bounds. A new stream takes the next
// discriminant and is appended to `ALL` (and `COUNT` raised).
const _: () = {
    let mut rest: &[Stream] = &Stream::ALL;
    let mut i = 0;
    while let [s, tail @ ..] = rest {
        assert!(s.index() == i);
        i += 1;
        rest = tail;
    }
    assert!(i == Stream::COUNT);
};

impl fmt::Display for Stream {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One `T` per [`Stream`], indexed by it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PerStream<T>([T; Stream::COUNT]);

impl<T> PerStream<T> {
    /// The value `f(stream)` for every stream.
    pub fn from_fn(mut f: impl FnMut(Stream) -> T) -> Self {
        PerStream(Stream::ALL.map(&mut f))
    }

    /// `(stream, value)` for every stream, in slot order.
    pub fn iter(&self) -> impl Iterator<Item = (Stream, &T)> + '_ {
        Stream::ALL.iter().copied().zip(self.0.iter())
    }

    /// `(stream, value)` for every stream, mutable, in slot order.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (Stream, &mut T)> + '_ {
        Stream::ALL.iter().copied().zip(self.0.iter_mut())
    }

    /// The values in slot order.
    pub fn as_array(&self) -> &[T; Stream::COUNT] {
        &self.0
    }
}

impl<T: Copy> PerStream<T> {
    /// `value` for every stream.
    pub const fn splat(value: T) -> Self {
        PerStream([value; Stream::COUNT])
    }
}

// `Stream::index` is below `Stream::COUNT` for every variant (checked above),
// so these indexings cannot fail.
#[allow(clippy::indexing_slicing)]
impl<T> Index<Stream> for PerStream<T> {
    type Output = T;
    fn index(&self, s: Stream) -> &T {
        &self.0[s.index()]
    }
}

#[allow(clippy::indexing_slicing)]
impl<T> IndexMut<Stream> for PerStream<T> {
    fn index_mut(&mut self, s: Stream) -> &mut T {
        &mut self.0[s.index()]
    }
}

/// Per-stream tallies: fused, and rejected by reason, for every stream.
pub type StreamCounts = PerStream<SampleCounts>;

impl StreamCounts {
    /// All counts zero.
    pub const fn zero() -> Self {
        PerStream::splat(SampleCounts::new())
    }

    /// Samples seen over every stream.
    pub fn seen(&self) -> u32 {
        self.0.iter().fold(0u32, |a, c| a.saturating_add(c.seen()))
    }
}

/// One line per stream that saw a sample: `imu: fused 12, gated 0`, ...
impl fmt::Display for StreamCounts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut first = true;
        for (s, c) in self.iter().filter(|(_, c)| c.seen() > 0) {
            if !first {
                f.write_str("\n")?;
            }
            first = false;
            write!(f, "{s}: {c}")?;
        }
        if first {
            f.write_str("no samples")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::Reject;
    use std::string::ToString;

    #[test]
    fn every_stream_has_its_own_slot_and_name() {
        for (i, s) in Stream::ALL.iter().enumerate() {
            assert_eq!(s.index(), i);
            assert_eq!(Stream::from_name(s.name()), Some(*s));
            assert_eq!(s.to_string(), s.name());
            for other in &Stream::ALL[i + 1..] {
                assert_ne!(s.name(), other.name());
            }
        }
        assert_eq!(Stream::from_name("lidar"), None);
    }

    #[test]
    fn per_stream_is_indexed_by_stream() {
        let mut n: PerStream<u32> = PerStream::from_fn(|s| s.index() as u32 * 10);
        n[Stream::Flow] += 1;
        assert_eq!(n[Stream::Flow], 21);
        assert_eq!(n[Stream::Segmentation], 60);
        for (s, v) in n.iter_mut() {
            *v = s.index() as u32;
        }
        assert!(n.iter().all(|(s, v)| *v as usize == s.index()));
    }

    #[test]
    fn stream_counts_print_the_streams_that_saw_samples() {
        let mut c = StreamCounts::zero();
        assert_eq!(c.to_string(), "no samples");
        c[Stream::Imu].record(Ok(()));
        c[Stream::Wheel].record(Err(Reject::Gated));
        c[Stream::Wheel].record(Err(Reject::Gap));
        assert_eq!(c.seen(), 3);
        assert_eq!(
            c.to_string(),
            "imu: fused 1, gated 0\nwheel: fused 0, gated 1, rejected: gap 1"
        );
    }
}
