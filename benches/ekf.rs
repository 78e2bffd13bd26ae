//! Benchmarks of the ego-state EKF: one IMU propagation (nominal state and
//! the full 36x36 covariance, block-structured; the dense `F P F^T + Q`
//! reference for comparison) and one wheel update (full covariance; the
//! update maths alone: the wheel's fast path, the generic structured update
//! and the dense Joseph-form reference, for comparison). Setup (a filter
//! warmed up on seeded samples) is outside the timer. Instruction counts of
//! the same steps: `examples/ekf_steps.rs` of `ego-ekf` under callgrind.
//!
//! Each timed call gets its own copy of the filter (criterion's
//! `iter_batched_ref`), made just before its batch of [`BATCH`] calls: the
//! copies (6.3 KB each) are in the cache, as a filter that runs every 4 ms
//! is. With criterion's `SmallInput` a batch holds a tenth of a sample's
//! iterations (megabytes of copies), so every call would first fetch its
//! filter from memory beyond the core's caches (and by value, move it in and out): that
//! measures the memory, about 0.6 µs per call here, not the filter. The
//! `harness` bench times an empty routine on the same batches.
#![allow(missing_docs)]

use std::hint::black_box;

/// Calls per batch of fresh copies (see the module doc).
const BATCH: BatchSize = BatchSize::NumIterations(16);

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use ego_ekf::propagate::{
    Transition, process_noise, propagate_covariance, propagate_covariance_dense,
};
use ego_ekf::reference::gated_update_dense;
use ego_ekf::state::Vec3;
use ego_ekf::update::gated_update;
use ego_ekf::wheel::model::{wheel_measurement, wheel_rows};
use ego_ekf::wheel::update::update as wheel_update;
use ego_ekf::{EgoEkf, ExplicitStart, FilterConfig};
use vslam_core::Timestamp;
use vslam_core::sensors::{ImuSample, WheelRates};

const DT: u64 = 4_000_000;

/// A filter after 2 s of seeded driving, so the covariance is dense.
fn warmed_up() -> (EgoEkf, u64) {
    let mut f = EgoEkf::new(FilterConfig::default()).unwrap();
    f.start(&ExplicitStart::at_rest(Timestamp(0))).unwrap();
    let mut seed = 0x1234_5678u32;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        (seed as f32 / u32::MAX as f32 - 0.5) * 0.02
    };
    let mut k = 0;
    for i in 1..=500u64 {
        k = i;
        let s = ImuSample::new(
            Timestamp(i * DT),
            [noise(), noise(), 0.3 + noise()],
            [0.2 + noise(), 0.06 + noise(), 9.81 + noise()],
        )
        .unwrap();
        let _ = f.propagate(&s);
        if i % 5 == 0 {
            let _ = f.fuse_wheel(&WheelRates::new(Timestamp(i * DT), 4.0, 5.0).unwrap());
        }
    }
    (f, k)
}

fn benches(c: &mut Criterion) {
    let (filter, k) = warmed_up();
    let sample = ImuSample::new(
        Timestamp((k + 1) * DT),
        [0.01, -0.02, 0.3],
        [0.2, 0.06, 9.81],
    )
    .unwrap();
    c.bench_function("ekf/harness (a fresh filter copy, empty routine)", |b| {
        b.iter_batched_ref(|| filter.clone(), |f| black_box(f.state().p_wb.x), BATCH)
    });
    c.bench_function("ekf/propagate (nominal + 36x36 covariance + clone)", |b| {
        b.iter_batched_ref(
            || filter.clone(),
            |f| black_box(f.propagate(black_box(&sample))),
            BATCH,
        )
    });

    let x = *filter.state();
    let r = x.q_wb.to_rotation_matrix().into_inner();
    let tr = Transition::new(
        &r,
        &Vec3::new(0.2, 0.06, 9.81),
        &Vec3::new(0.01, -0.02, 0.3),
        0.004,
    );
    let q = process_noise(
        &FilterConfig::default().imu,
        &FilterConfig::default().robot,
        0.004,
    );
    let p0 = *filter.covariance();
    c.bench_function("ekf/covariance block F P F^T + Q", |b| {
        b.iter_batched_ref(
            || p0,
            |p| propagate_covariance(black_box(p), black_box(&tr), black_box(&q)),
            BATCH,
        )
    });
    c.bench_function("ekf/covariance dense F P F^T + Q (reference)", |b| {
        b.iter_batched_ref(
            || p0,
            |p| propagate_covariance_dense(black_box(p), black_box(&tr), black_box(&q)),
            BATCH,
        )
    });

    let rates = WheelRates::new(Timestamp((k + 1) * DT), 4.1, 4.9).unwrap();
    c.bench_function("ekf/wheel update (4 rows, full covariance)", |b| {
        b.iter_batched_ref(
            || filter.clone(),
            |f| black_box(f.fuse_wheel(black_box(&rates))),
            BATCH,
        )
    });

    let rows = wheel_rows(&x, &filter.angular_velocity(), &rates, &filter.grip());
    c.bench_function(
        "ekf/wheel update maths (4 rows, fast: sparse P H^T, gate, one pass)",
        |b| {
            b.iter_batched_ref(
                || (x, p0),
                |(x, p)| wheel_update(black_box(x), black_box(p), black_box(&rows), 100.0),
                BATCH,
            )
        },
    );
    let m = wheel_measurement(&x, &filter.angular_velocity(), &rates, &filter.grip());
    c.bench_function("ekf/update maths (4 rows, structured)", |b| {
        b.iter_batched_ref(
            || (x, p0),
            |(x, p)| gated_update(black_box(x), black_box(p), black_box(&m), None),
            BATCH,
        )
    });
    // The 3-D wheel-velocity update: the forward, lateral and
    // vertical rows without the differential (yaw-rate) row, NIS-gated.
    let m3 = m.select([0, 2, 3]).unwrap();
    c.bench_function(
        "ekf/update maths (3 rows: forward, lateral, vertical; structured, gated)",
        |b| {
            b.iter_batched_ref(
                || (x, p0),
                |(x, p)| gated_update(black_box(x), black_box(p), black_box(&m3), Some(100.0)),
                BATCH,
            )
        },
    );
    c.bench_function("ekf/update maths (4 rows, dense Joseph reference)", |b| {
        b.iter_batched_ref(
            || (x, p0),
            |(x, p)| gated_update_dense(black_box(x), black_box(p), black_box(&m), None),
            BATCH,
        )
    });
}

criterion_group!(ekf, benches);
criterion_main!(ekf);
