//! Driver hot paths: the per-sample work an MCU does in an interrupt or at
//! the wheel/flow rate. Inputs seeded and built outside the timer.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use traction::flow_sensor::MotionBurst;
use traction::vslam_core::Timestamp;
use traction::vslam_core::sensors::WheelTicks;
use traction::wheel_odom::{
    CounterExtender, DiffDriveOdometry, DiffDriveParams, QuadratureDecoder,
};

/// xorshift64*, seeded: reproducible inputs without a dependency.
fn rng(seed: u64) -> impl FnMut() -> u64 {
    let mut s = seed;
    move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        s.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

fn quadrature(c: &mut Criterion) {
    let mut r = rng(1);
    let mut pos = 0i64;
    let levels: Vec<(bool, bool)> = (0..4096)
        .map(|_| {
            pos += (r() % 3) as i64 - 1;
            match pos.rem_euclid(4) {
                0 => (false, false),
                1 => (true, false),
                2 => (true, true),
                _ => (false, true),
            }
        })
        .collect();
    c.bench_function("quadrature_decode_4096_samples", |b| {
        b.iter(|| {
            let mut q = QuadratureDecoder::new();
            for &(a, bb) in &levels {
                q.update(a, bb);
            }
            black_box(q.count())
        })
    });
}

fn counter(c: &mut Criterion) {
    let mut r = rng(2);
    let mut pos = 0i64;
    let raws: Vec<u32> = (0..4096)
        .map(|_| {
            pos += (r() % 2001) as i64 - 1000;
            pos.rem_euclid(1 << 16) as u32
        })
        .collect();
    c.bench_function("counter16_extend_4096_samples", |b| {
        b.iter(|| {
            let mut e = CounterExtender::bits16();
            for &raw in &raws {
                let _ = e.update(raw);
            }
            black_box(e.position())
        })
    });
}

fn odometry(c: &mut Criterion) {
    let params = DiffDriveParams::new(16_384, 0.035, 0.035, 0.23, 2.0, 100_000_000).unwrap();
    let mut r = rng(3);
    let (mut l, mut rr) = (0i64, 0i64);
    let samples: Vec<WheelTicks> = (0..1000u64)
        .map(|i| {
            l += (r() % 400) as i64;
            rr += (r() % 400) as i64;
            WheelTicks {
                t: Timestamp(i * 4_000_000),
                left: l,
                right: rr,
            }
        })
        .collect();
    c.bench_function("diff_drive_odometry_1000_steps", |b| {
        b.iter(|| {
            let mut o = DiffDriveOdometry::new(params);
            for s in &samples {
                let _ = black_box(o.update(*s));
            }
            black_box(o.counts().fused())
        })
    });
}

fn burst(c: &mut Criterion) {
    let mut r = rng(4);
    let bursts: Vec<[u8; 12]> = (0..1000)
        .map(|_| core::array::from_fn(|_| r() as u8))
        .collect();
    c.bench_function("motion_burst_decode_1000", |b| {
        b.iter(|| {
            let mut valid = 0u32;
            for bytes in &bursts {
                let s = MotionBurst::from_bytes(bytes).to_sample(Timestamp(1));
                valid += u32::from(s.is_valid());
            }
            black_box(valid)
        })
    });
}

criterion_group!(benches, quadrature, counter, odometry, burst);
criterion_main!(benches);
