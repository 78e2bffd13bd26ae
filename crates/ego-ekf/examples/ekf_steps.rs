//! Runs the filter for a fixed number of seeded IMU steps, each followed by
//! a wheel update, so that `valgrind --tool=callgrind` can count the
//! instructions of one propagation and one wheel update:
//!
//! ```text
//! cargo build --release -p ego-ekf --example ekf_steps
//! valgrind --tool=callgrind --callgrind-out-file=cg.out \
//!     target/release/examples/ekf_steps 1000
//! callgrind_annotate --inclusive=yes cg.out | grep -E 'propagate_step|wheel_step'
//! ```
//!
//! The inclusive counts of `propagate_step` and `wheel_step`
//! divided by the number of steps (printed) are the instructions per step.
#![allow(missing_docs, clippy::unwrap_used)]

use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

const DT: u64 = 4_000_000;

/// One propagation, not inlined, so callgrind reports its inclusive cost.
#[inline(never)]
fn propagate_step(f: &mut EgoEkf, s: &ImuSample) -> bool {
    f.propagate(s).is_ok()
}

/// One wheel update, not inlined, so callgrind reports its inclusive cost.
#[inline(never)]
fn wheel_step(
    f: &mut EgoEkf,
    r: &WheelRates,
) -> Result<ego_ekf::WheelInnovation, vslam_core::Reject> {
    f.fuse_wheel(r)
}

fn main() {
    let steps: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000);
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
    // The same seeded drive as `benches/ekf.rs`.
    let mut seed = 0x1234_5678u32;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        (seed as f32 / u32::MAX as f32 - 0.5) * 0.02
    };
    let (mut propagated, mut wheel_fused, mut wheel_gated) = (0u64, 0u64, 0u64);
    for i in 1..=500 + steps {
        let s = ImuSample::new(
            Timestamp(i * DT),
            [noise(), noise(), 0.3 + noise()],
            [0.2 + noise(), 0.06 + noise(), 9.81 + noise()],
        )
        .unwrap();
        if i <= 500 {
            let _ = f.propagate(&s);
            if i % 5 == 0 {
                let _ = f.fuse_wheel(&WheelRates::new(Timestamp(i * DT), 4.0, 5.0).unwrap());
            }
            continue;
        }
        propagated += u64::from(propagate_step(&mut f, &s));
        let w = 0.1 * noise();
        let rates = WheelRates::new(Timestamp(i * DT), 4.0 + w, 5.0 - w).unwrap();
        match wheel_step(&mut f, &rates) {
            Ok(inn) if inn.gated => wheel_gated += 1,
            Ok(_) => wheel_fused += 1,
            Err(_) => {}
        }
    }
    let p = f.covariance();
    println!(
        "steps {steps}: propagated {propagated}, wheel fused {wheel_fused}, gated {wheel_gated}; \
         trace(P) {:.6e}, position {:?}",
        p.trace(),
        f.position().as_slice()
    );
}
