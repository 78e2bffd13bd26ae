//! Links traction's no_std crates into a bare-metal Cortex-M4F image: no std,
//! no allocator. Built by `.ci/run`; it proves the crates need nothing more.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use traction::vslam_core::geometry::Extrinsics;
use traction::vslam_core::{SampleClock, SampleCounts, Timestamp};

#[entry]
fn main() -> ! {
    let mut clock = SampleClock::new(black_box(10_000_000));
    let mut counts = SampleCounts::new();
    let mut t = 0u64;
    loop {
        t = t.wrapping_add(black_box(4_000_000));
        counts.record(clock.accept(Timestamp(t)).map(|_| ()));
        let e = Extrinsics::from_row_major(black_box(&[
            1.0, 0.0, 0.0, 0.1, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.03, 0.0, 0.0, 0.0, 1.0,
        ]));
        let _ = black_box((&counts, e.is_ok()));
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    loop {}
}
