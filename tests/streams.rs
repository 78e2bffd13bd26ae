//! The sensor registry is total: every [`Stream`] has a way into the
//! estimator (or is declared not taken yet), every sample of every stream
//! ends in exactly one count of that stream (that `report.json` lists every
//! stream by its name is checked in `crates/host-sim/tests/report_streams.rs`).
//!
//! Adding a stream to `vslam_core::Stream` does not compile until
//! [`entry`] below places it: the table says how its samples reach
//! `traction::Estimator`. Its counts, its `report.json` entry and its line
//! in the printed counts come from the registry without another edit.

use traction::estimator::Estimator;
use traction::reorder::Event;
use traction::vslam_core::image::{ImageView, LabelView};
use traction::vslam_core::sensors::{FlowSample, RawImuSample, WheelTicks};
use traction::vslam_core::{PerStream, Reject, Stream, Timestamp};

mod common;
use common::estimator;

/// How the samples of a stream reach the estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Entry {
    /// [`Estimator::offer`], through the ordering buffer.
    Offer,
    /// [`Estimator::process_camera`].
    Camera,
    /// [`Estimator::process_segmentation`].
    Segmentation,
    /// [`Estimator::process_flow_frame`].
    FlowFrame,
    /// Not taken by the estimator yet: only refused reads are counted
    /// ([`Estimator::reject_read`]).
    NotTaken,
}

/// The one table a new stream must be entered in (exhaustive on purpose).
fn entry(s: Stream) -> Entry {
    match s {
        Stream::Imu | Stream::Wheel | Stream::Flow => Entry::Offer,
        Stream::Camera => Entry::Camera,
        Stream::Segmentation => Entry::Segmentation,
        Stream::FlowFrame => Entry::FlowFrame,
        Stream::ForwardCamera => Entry::NotTaken,
    }
}

/// A buffered sample of stream `s` at `t_ns` (`k`: the sample's number).
fn event(s: Stream, t_ns: u64, k: i16) -> Event {
    let t = Timestamp(t_ns);
    let e = match s {
        Stream::Imu => Event::Imu(RawImuSample {
            t,
            gyro: [0.0; 3],
            accel: [0.0, 0.0, 9.81],
        }),
        Stream::Wheel => Event::Wheel(WheelTicks {
            t,
            left: i64::from(k),
            right: i64::from(k),
        }),
        Stream::Flow => Event::Flow(FlowSample {
            t,
            dx: k,
            squal: 100,
            motion: true,
            ..FlowSample::default()
        }),
        other => panic!("{other} is not a buffered stream"),
    };
    assert_eq!(e.stream(), s);
    e
}

#[test]
fn every_sample_of_every_stream_ends_in_one_count_of_its_stream() {
    let mut est = estimator();
    let pixels = [0u8; 16 * 16];
    let image = ImageView::new(&pixels, 16, 16, 16).unwrap();
    let labels = LabelView::new(&pixels, 16, 16, 16).unwrap();
    let mut fed: PerStream<u32> = PerStream::splat(0);
    let mut polled: PerStream<u32> = PerStream::splat(0);
    let drain = |est: &mut Estimator<'_>, polled: &mut PerStream<u32>| {
        while let Some(p) = est.poll() {
            polled[p.stream()] += 1;
        }
    };
    for k in 0..20i16 {
        for (i, s) in Stream::ALL.into_iter().enumerate() {
            let t = 10_000_000 * (u64::from(k.unsigned_abs()) + 1) + i as u64;
            // Frames and maps are processed after every buffered sample up
            // to their time: take those records first, as a replay does.
            while let Some(p) = est.poll_until(Timestamp(t)) {
                polled[p.stream()] += 1;
            }
            match entry(s) {
                Entry::Offer => est.offer(event(s, t, k)),
                Entry::Camera => {
                    // No camera path fitted: refused, and counted.
                    assert_eq!(
                        est.process_camera(Timestamp(t), &image),
                        Err(Reject::NotReady)
                    );
                }
                Entry::Segmentation => {
                    // No surface model: refused, and counted.
                    assert_eq!(
                        est.process_segmentation(Timestamp(t), &labels),
                        Err(Reject::NotReady)
                    );
                }
                Entry::FlowFrame => {
                    // A first frame: nothing to track against; refused, and counted.
                    assert!(matches!(
                        est.process_flow_frame(Timestamp(t), None),
                        Err(Reject::NotReady)
                    ));
                }
                Entry::NotTaken => est.reject_read(s, Timestamp(t), Reject::Bus),
            }
            fed[s] += 1;
            drain(&mut est, &mut polled);
        }
    }
    // A failed read of every stream lands in that stream's counts too.
    for s in Stream::ALL {
        est.reject_read(s, Timestamp(500_000_000), Reject::Integrity);
        fed[s] += 1;
    }
    est.finish();
    drain(&mut est, &mut polled);

    let counts = est.counts();
    for (s, c) in counts.iter() {
        assert_eq!(c.seen(), fed[s], "{s}: {c}");
        assert_eq!(c.rejected(Reject::Integrity), 1, "{s}: {c}");
        if entry(s) == Entry::Offer {
            // Every buffered sample came back out of `poll` under its stream.
            assert_eq!(polled[s] + 1, fed[s], "{s}");
        } else {
            assert_eq!(polled[s], 0, "{s}");
        }
    }
    assert_eq!(counts.seen(), fed.iter().map(|(_, n)| n).sum::<u32>());
    // The printed counts name every stream that saw samples, and the reasons.
    let text = counts.to_string();
    for s in Stream::ALL {
        assert!(
            text.contains(&format!("{s}: fused ")),
            "{s} missing:\n{text}"
        );
    }
    assert!(text.contains("integrity 1"), "{text}");
}
