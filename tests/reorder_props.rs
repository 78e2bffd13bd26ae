//! Properties of the time-ordering buffer: whatever the arrival order, what
//! comes out is in time order, and every sample is released exactly once or
//! handed back as too late, under the stream it went in with.

use proptest::prelude::*;
use traction::reorder::{Event, Pushed, Reorder};
use traction::vslam_core::sensors::{FlowSample, RawImuSample, WheelTicks};
use traction::vslam_core::{PerStream, Reject, Timestamp};

fn wheel(t: u64, id: i64) -> Event {
    Event::Wheel(WheelTicks {
        t: Timestamp(t),
        left: id,
        right: 0,
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

    #[test]
    fn ordered_and_nothing_lost(times in proptest::collection::vec(0u64..2_000, 0..200), window in 0u64..300) {
        let mut r: Reorder<16> = Reorder::new(window);
        let mut out: Vec<Event> = Vec::new();
        let mut late = 0usize;
        for (id, t) in times.iter().enumerate() {
            match r.push(wheel(*t, id as i64)) {
                Ok(Pushed::Held) => {}
                Ok(Pushed::HeldReleasing(e)) => out.push(e),
                Err((reason, _)) => {
                    prop_assert_eq!(reason, Reject::OutOfOrder);
                    late += 1;
                }
            }
            while let Some(e) = r.pop_ready() {
                out.push(e);
            }
        }
        while let Some(e) = r.pop_any() {
            out.push(e);
        }
        prop_assert_eq!(out.len() + late, times.len());
        prop_assert!(out.windows(2).all(|w| w[0].t() <= w[1].t()));
        let mut ids: Vec<i64> = out.iter().map(|e| match e { Event::Wheel(w) => w.left, _ => -1 }).collect();
        ids.sort_unstable();
        ids.dedup();
        prop_assert_eq!(ids.len(), out.len());
    }

    #[test]
    fn every_stream_keeps_its_samples(arrivals in proptest::collection::vec((0u64..2_000, 0usize..3), 0..200), window in 0u64..300) {
        let mut r: Reorder<8> = Reorder::new(window);
        let (mut pushed, mut out) = (PerStream::splat(0u32), PerStream::splat(0u32));
        for (t, k) in &arrivals {
            let t = Timestamp(*t);
            let e = match k {
                0 => Event::Imu(RawImuSample { t, gyro: [0.0; 3], accel: [0.0; 3] }),
                1 => Event::Wheel(WheelTicks { t, left: 0, right: 0 }),
                _ => Event::Flow(FlowSample { t, ..FlowSample::default() }),
            };
            pushed[e.stream()] += 1;
            match r.push(e) {
                Ok(Pushed::Held) => {}
                Ok(Pushed::HeldReleasing(e)) => out[e.stream()] += 1,
                Err((_, e)) => out[e.stream()] += 1,
            }
            while let Some(e) = r.pop_ready() {
                out[e.stream()] += 1;
            }
        }
        while let Some(e) = r.pop_any() {
            out[e.stream()] += 1;
        }
        prop_assert_eq!(pushed, out);
    }
}
