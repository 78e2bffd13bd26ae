//! Properties of the time-ordering buffer: whatever the arrival order, what
//! comes out is in time order, and every sample is released exactly once or
//! handed back as too late.

use proptest::prelude::*;
use traction::reorder::{Event, Pushed, Reorder};
use traction::vslam_core::sensors::WheelTicks;
use traction::vslam_core::{Reject, Timestamp};

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
}
