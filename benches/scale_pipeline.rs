//! Cost of the scale pipeline's camera-rate work: one `push_camera` with full
//! sensor windows (transactions, slip, selection, running median, adverse
//! memory, composition), and the adverse-memory export. Inputs are made once,
//! outside the timer, from a fixed seed.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use vslam_core::Timestamp;
use vslam_core::geometry::{Extrinsics, Rot3, Vec3};
use vslam_core::scale::{CameraMotion, PipelineConfig, ScalePipeline, SelectionMethod};
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, OdometryDelta};

const MS: u64 = 1_000_000;

/// A pipeline that has seen one second of straight driving at 0.3 m/s with
/// small seeded jitter, and the camera motion of its last 100 ms.
fn primed(method: SelectionMethod) -> (ScalePipeline<32>, CameraMotion) {
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut jitter = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let config = PipelineConfig {
        method,
        camera: Extrinsics::new(Rot3::identity(), Vec3::new(0.1, 0.0, 0.1)).unwrap(),
        flow_optics: Some(FlowOptics::new(500.0, 0.02, Extrinsics::identity()).unwrap()),
        ..PipelineConfig::default()
    };
    let mut p: ScalePipeline<32> = ScalePipeline::new(config).unwrap();
    let mut camera = None;
    for f in 0..10u64 {
        for k in 0..10u64 {
            let a = (f * 100 + k * 10) * MS;
            for i in 0..5 {
                let s = ImuSample::new(
                    Timestamp(a + i * 2 * MS),
                    [0.0, 0.0, 0.01 * jitter()],
                    [0.1 * jitter(), 0.0, 9.81],
                )
                .unwrap();
                let _ = p.push_imu(&s);
            }
            let dx = 0.003 * (1.0 + 0.01 * jitter());
            let _ = p.push_wheel(&OdometryDelta {
                t0: Timestamp(a),
                t1: Timestamp(a + 10 * MS),
                translation: Vec3::new(dx, 0.0, 0.0),
                dyaw: 0.0,
                path_length: dx,
            });
            let _ = p.push_flow(&FlowSample {
                t: Timestamp(a + 10 * MS),
                dx: 75 + (4.0 * jitter()) as i16,
                squal: 100,
                shutter: 0x200,
                ..FlowSample::default()
            });
        }
        let m = CameraMotion::new(
            Timestamp(f * 100 * MS),
            Timestamp((f + 1) * 100 * MS),
            Rot3::identity(),
            Vec3::new(0.03 / 2.5, 0.0, 0.0),
            120,
            0.9,
            0.4,
        )
        .unwrap();
        if f < 9 {
            let _ = p.push_camera(&m);
        } else {
            camera = Some(m);
        }
    }
    (p, camera.unwrap())
}

fn bench(c: &mut Criterion) {
    for method in [SelectionMethod::Fusion, SelectionMethod::ScaleConfidence] {
        let (p, m) = primed(method);
        c.bench_function(&format!("scale/push_camera/{method:?}"), |b| {
            b.iter_batched_ref(
                || p.clone(),
                |p| black_box(p.push_camera(black_box(&m))),
                BatchSize::SmallInput,
            )
        });
    }
    let (p, _) = primed(SelectionMethod::Fusion);
    let mut buf = vec![0u8; vslam_core::scale::pipeline::PipelineMemory::RECORD_LEN];
    c.bench_function("scale/adverse_export", |b| {
        b.iter(|| black_box(p.memory().export(black_box(&mut buf))))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
