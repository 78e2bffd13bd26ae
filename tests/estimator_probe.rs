//! The estimator's probe ([`traction::estimator::Probe`]) sees every call
//! into a part, once, between `enter` and `leave`, with its outcome, and
//! changes nothing: an estimator with a recording probe ends in the state
//! of one with none.

use traction::estimator::{
    Estimator, EstimatorConfig, EstimatorWith, JOLT_LOG, NoProbe, Part, Probe, REORDER_CAPACITY,
    SCALE_WINDOW, TRAJECTORY_CAPACITY,
};
use traction::vslam_core::geometry::{Rot3, Vec3};
use traction::vslam_core::robot::RobotDescription;
use traction::vslam_core::scale::CameraMotion;
use traction::vslam_core::sensors::{FlowSample, RawImuSample, WheelTicks};
use traction::vslam_core::{Stream, Timestamp};

/// Records every `enter` and `leave`.
#[derive(Default)]
struct Recorder {
    /// `(part, None)` for an enter, `(part, Some(done))` for a leave.
    calls: Vec<(Part, Option<bool>)>,
}

impl Probe for Recorder {
    fn enter(&mut self, part: Part) {
        self.calls.push((part, None));
    }
    fn leave(&mut self, part: Part, done: bool) {
        self.calls.push((part, Some(done)));
    }
}

type Probed =
    EstimatorWith<'static, REORDER_CAPACITY, TRAJECTORY_CAPACITY, JOLT_LOG, SCALE_WINDOW, Recorder>;

const MS: u64 = 1_000_000;

/// 2 s: IMU at 250 Hz, wheels at 50 Hz (rolling after 1 s), flow at 100 Hz,
/// and one camera motion over [1.5 s, 1.6 s]; gives the samples offered per
/// stream.
fn drive<P: Probe>(est: &mut EstimatorWith<'static, 64, 32, 16, { SCALE_WINDOW }, P>) -> [u32; 4] {
    let mut n = [0u32; 4];
    for ms in (0..2000u64).step_by(4) {
        let t = Timestamp(ms * MS);
        est.offer_imu(RawImuSample {
            t,
            gyro: [0.001, -0.002, 0.003],
            accel: [0.05, -0.02, 9.81],
        });
        n[0] += 1;
        if ms % 20 == 0 {
            let k = ms.saturating_sub(1000) as i64 / 2;
            est.offer_wheel(WheelTicks {
                t,
                left: k,
                right: k,
            });
            n[1] += 1;
        }
        if ms % 10 == 0 {
            est.offer_flow(FlowSample {
                t,
                dx: if ms > 1000 { 3 } else { 0 },
                squal: 100,
                motion: ms > 1000,
                ..FlowSample::default()
            });
            n[2] += 1;
        }
        while est.poll().is_some() {}
        if ms == 1600 {
            let m = CameraMotion::new(
                Timestamp(1500 * MS),
                Timestamp(1600 * MS),
                Rot3::identity(),
                Vec3::new(0.01, 0.0, 0.0),
                50,
                0.9,
                0.2,
            )
            .unwrap();
            let _ = est.process_camera_motion(&m);
            n[3] += 1;
        }
    }
    est.finish();
    while est.poll().is_some() {}
    n
}

#[test]
fn probe_sees_every_part_once_and_changes_nothing() {
    let config = EstimatorConfig::from_robot(&RobotDescription::robot_vacuum()).unwrap();
    let mut plain: Box<Estimator<'static>> = Box::new(Estimator::unconfigured());
    plain.configure(&config).unwrap();
    let mut probed: Box<Probed> =
        Box::new(EstimatorWith::unconfigured_with_probe(Recorder::default()));
    probed.configure(&config).unwrap();
    let offered = drive(&mut *plain);
    assert_eq!(drive(&mut *probed), offered);

    // The probe changed nothing.
    let state = |ekf: &dyn core::fmt::Debug, c: &dyn core::fmt::Debug| format!("{ekf:?} {c:?}");
    assert_eq!(
        state(plain.ekf(), &plain.counts()),
        state(probed.ekf(), &probed.counts())
    );
    assert_eq!(
        format!("{:?}", plain.scale()),
        format!("{:?}", probed.scale())
    );
    assert_eq!(core::mem::size_of::<NoProbe>(), 0);

    // Every enter is followed by the leave of the same part: no nesting.
    let calls = &probed.probe().calls;
    assert!(calls.len() % 2 == 0);
    for pair in calls.chunks(2) {
        assert!(
            matches!(pair, [(a, None), (b, Some(_))] if a == b),
            "{pair:?}"
        );
    }
    let leaves = |part: Part| {
        let all = calls.iter().filter(|(p, d)| *p == part && d.is_some());
        let done = all.clone().filter(|(_, d)| *d == Some(true)).count();
        (all.count(), done)
    };
    let [imu, wheel, flow, camera] = offered.map(|n| n as usize);
    let counts = probed.counts();
    let ekf = probed.ekf();
    // Every IMU sample here is in range: each is propagated, and each
    // propagation that did its work goes to the scale pipeline.
    assert_eq!(
        leaves(Part::Propagate),
        (imu, ekf.imu_counts().fused() as usize)
    );
    assert_eq!(leaves(Part::ScaleImu).0, ekf.imu_counts().fused() as usize);
    assert!(ekf.imu_counts().fused() > 400);
    // Wheels: every sample through the odometry, all but the first (which
    // anchors the counts) into the pipeline and the filter.
    assert_eq!(leaves(Part::Odometry), (wheel, wheel));
    assert_eq!(leaves(Part::ScaleWheel).0, wheel - 1);
    assert_eq!(leaves(Part::FuseWheel).0, wheel - 1);
    // A wheel update that did its work is fused or gated (forward part).
    let w = &counts[Stream::Wheel];
    assert_eq!((w.fused() + w.gated()) as usize, leaves(Part::FuseWheel).1);
    assert!(w.fused() > 0);
    // Flow: each report into the pipeline and the filter.
    assert_eq!(leaves(Part::ScaleFlow).0, flow);
    assert_eq!(
        leaves(Part::FuseFlow),
        (flow, ekf.flow_counts().fused() as usize)
    );
    // The camera motion: the pipeline, the check against the filter, the
    // filter; no front end (the motion was measured outside).
    assert_eq!(camera, 1);
    assert_eq!(leaves(Part::ScaleCamera), (1, 1));
    assert_eq!(leaves(Part::Disagreement), (1, 1));
    assert_eq!(leaves(Part::FuseCamera).0, 1);
    assert_eq!(leaves(Part::FrontEnd), (0, 0));
    assert_eq!(counts[Stream::Camera].fused(), 1);
    let total: usize = Part::ALL.iter().map(|&p| leaves(p).0).sum();
    assert_eq!(total * 2, calls.len());
}
