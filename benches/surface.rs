//! Cost of the surface model: one segmentation map (2-5 Hz) and the per-IMU
//! step work (250 Hz): the jolt context, the grip parameters and one jolt
//! detector step. Inputs are seeded and built outside the timer.

use criterion::{Criterion, criterion_group, criterion_main};
use ego_ekf::events::{JoltConfig, JoltMonitor};
use ego_ekf::surface::{ClassConfig, SurfaceConfig, SurfaceKind, SurfaceModel, WheelType};
use std::hint::black_box;
use vslam_core::Timestamp;
use vslam_core::image::LabelView;

fn classes() -> ClassConfig {
    ClassConfig::from_lists(
        &[
            (10, SurfaceKind::Wood),
            (11, SurfaceKind::Carpet),
            (14, SurfaceKind::Threshold),
        ],
        &[1],
    )
}

/// A 160 x 120 map: walls above 40 %, wood near, carpet further, a diagonal
/// edge, and a sprinkle of unknown pixels from a fixed linear congruence.
fn label_map() -> Vec<u8> {
    let (w, h) = (160usize, 120usize);
    let mut state = 0x2545_f491u32;
    let mut v = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let id = if y < 48 {
                1
            } else if state >> 28 == 0 {
                0
            } else if y + x / 8 > 90 {
                10
            } else {
                11
            };
            v.push(id);
        }
    }
    v
}

fn bench(c: &mut Criterion) {
    let data = label_map();
    let labels = LabelView::new(&data, 160, 120, 160).unwrap();
    let model = SurfaceModel::new(SurfaceConfig::new(WheelType::HardRubber, classes()));

    c.bench_function("surface/segmentation_160x120", |b| {
        let mut t = 0u64;
        let mut m = model;
        b.iter(|| {
            t += 250_000_000;
            black_box(
                m.on_segmentation(Timestamp(t), black_box(&labels), 0.2)
                    .ok(),
            )
        })
    });

    let mut fed = model;
    fed.on_segmentation(Timestamp(1), &labels, 0.2).unwrap();
    c.bench_function("surface/imu_step_context_params_jolt", |b| {
        let mut jolts = JoltMonitor::<32>::new(JoltConfig::default());
        let mut k = 0u64;
        b.iter(|| {
            k += 1;
            let t = Timestamp(1 + k * 4_000_000);
            let ctx = fed.jolt_context(t, 0.2);
            let p = fed.grip_params(t);
            let dev = if k.is_multiple_of(97) { 6.0 } else { 0.3 };
            black_box((jolts.push(t, dev, &ctx).ok(), p))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
