//! `ScalePipeline` end to end on small hand-made sequences: the typed reason
//! for no scale, rejections with reasons, raw-frame flow, spinning in place,
//! the adverse memory learning a slippery place, and the trajectory record.

mod scale_sim;

use vslam_core::Timestamp;
use vslam_core::adverse::{AdverseKind, SensorKind};
use vslam_core::geometry::{Extrinsics, Rot3, Vec3};
use vslam_core::reject::Reject;
use vslam_core::scale::raw_flow::{FeatureMotion, RawFlowOptics};
use vslam_core::scale::select::ScaleSource;
use vslam_core::scale::slip::SlipCause;
use vslam_core::scale::{
    CameraMotion, FrameDecision, NoScale, PipelineConfig, ScalePipeline, SelectionMethod,
};
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, OdometryDelta};

const D: f32 = 2.5;
const MS: u64 = 1_000_000;

fn config(method: SelectionMethod) -> PipelineConfig {
    PipelineConfig {
        method,
        flow_optics: Some(FlowOptics::new(500.0, 0.02, Extrinsics::identity()).unwrap()),
        ..PipelineConfig::default()
    }
}

/// Drives straight along body x at `v` m/s for `frames` camera frames of
/// 100 ms starting at `t_ms`: wheels report `wheel_factor` times the truth,
/// the flow reports the truth (or nothing when `flow` is false), the camera
/// sees `camera_factor` times the truth. Returns the decisions.
fn drive<const N: usize>(
    p: &mut ScalePipeline<N>,
    t_ms: u64,
    frames: u64,
    v: f32,
    wheel_factor: f32,
    camera_factor: f32,
    flow: bool,
) -> Vec<FrameDecision> {
    drive_with_wheel_yaw(p, t_ms, frames, v, wheel_factor, camera_factor, flow, 0.0)
}

/// As [`drive`], with the wheels also reporting a yaw rate (rad/s) the gyro does not see.
fn drive_with_wheel_yaw<const N: usize>(
    p: &mut ScalePipeline<N>,
    t_ms: u64,
    frames: u64,
    v: f32,
    wheel_factor: f32,
    camera_factor: f32,
    flow: bool,
    wheel_yaw_rate: f32,
) -> Vec<FrameDecision> {
    let mut out = Vec::new();
    for f in 0..frames {
        let t0 = t_ms + f * 100;
        for k in 0..10 {
            let a = (t0 + k * 10) * MS;
            let b = a + 10 * MS;
            for i in 0..5 {
                let s =
                    ImuSample::new(Timestamp(a + i * 2 * MS), [0.0; 3], [0.0, 0.0, 9.81]).unwrap();
                let _ = p.push_imu(&s);
            }
            let dx = v * 0.01;
            p.push_wheel(&OdometryDelta {
                t0: Timestamp(a),
                t1: Timestamp(b),
                translation: Vec3::new(dx * wheel_factor, 0.0, 0.0),
                dyaw: wheel_yaw_rate * 0.01,
                path_length: dx * wheel_factor,
            })
            .unwrap();
            if flow {
                let counts = (dx / 0.02 * 500.0).round() as i16;
                let _ = p.push_flow(&FlowSample {
                    t: Timestamp(b),
                    dx: counts,
                    squal: 100,
                    shutter: 0x200,
                    ..FlowSample::default()
                });
            }
        }
        let t = Vec3::new(v * 0.1 * camera_factor / D, 0.0, 0.0);
        let m = CameraMotion::new(
            Timestamp(t0 * MS),
            Timestamp((t0 + 100) * MS),
            Rot3::identity(),
            t,
            120,
            0.9,
            0.4,
        )
        .unwrap();
        out.push(p.push_camera(&m).unwrap());
    }
    out
}

#[test]
fn pure_rotation_gives_a_typed_reason_and_still_turns_the_pose() {
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    let d = drive(&mut p, 0, 10, 0.3, 1.0, 1.0, true);
    assert!(d.iter().all(|d| d.scale.is_ok()));
    let before = p.body_pose().translation.vector;
    let r = Rot3::from_euler_angles(0.0, 0.0, 0.2);
    let m = CameraMotion::new(
        Timestamp(1_000 * MS),
        Timestamp(1_100 * MS),
        r,
        Vec3::new(1e-4, 0.0, 0.0),
        120,
        0.9,
        0.4,
    )
    .unwrap();
    let d = p.push_camera(&m).unwrap();
    assert_eq!(d.scale, Err(NoScale::BaselineTooSmall));
    assert!(format!("{}", NoScale::BaselineTooSmall).contains("rotation"));
    // The running scale still moves the (tiny) translation, and the rotation is composed.
    assert!((d.applied_scale.unwrap() - D).abs() < 0.05);
    let yaw = p.body_pose().rotation.euler_angles().2;
    assert!((yaw - 0.2).abs() < 1e-5);
    assert!((p.body_pose().translation.vector - before).norm() < 1e-3);
    assert_eq!(p.counts(SensorKind::Camera).rejected(Reject::Degenerate), 1);
    assert_eq!(p.counts(SensorKind::Camera).fused(), 10);
}

#[test]
fn sensor_and_camera_rejections_carry_reasons() {
    let mut p: ScalePipeline = ScalePipeline::new(PipelineConfig::default()).unwrap();
    // No flow optics configured.
    assert_eq!(p.push_flow(&FlowSample::default()), Err(Reject::NotReady));
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    drive(&mut p, 0, 2, 0.3, 1.0, 1.0, true);
    let m = CameraMotion::new(
        Timestamp(0),
        Timestamp(100 * MS),
        Rot3::identity(),
        Vec3::x() * 0.01,
        99,
        0.9,
        0.4,
    )
    .unwrap();
    assert_eq!(p.push_camera(&m), Err(Reject::OutOfOrder));
    let m = CameraMotion::new(
        Timestamp(100 * MS),
        Timestamp(200 * MS),
        Rot3::identity(),
        Vec3::x() * 0.01,
        99,
        0.9,
        0.4,
    )
    .unwrap();
    assert_eq!(p.push_camera(&m), Err(Reject::Duplicate));
    let stale = OdometryDelta {
        t0: Timestamp(0),
        t1: Timestamp(10 * MS),
        translation: Vec3::zeros(),
        dyaw: 0.0,
        path_length: 0.0,
    };
    assert_eq!(p.push_wheel(&stale), Err(Reject::OutOfOrder));
    let c = p.counts(SensorKind::Camera);
    assert_eq!(
        (
            c.fused(),
            c.rejected(Reject::OutOfOrder),
            c.rejected(Reject::Duplicate)
        ),
        (2, 1, 1)
    );
    assert_eq!(p.counts(SensorKind::Wheel).fused(), 20);
    assert_eq!(p.counts(SensorKind::Wheel).rejected(Reject::OutOfOrder), 1);
    // The first flow report anchors, the first IMU sample too.
    assert_eq!(p.counts(SensorKind::Flow).fused(), 19);
    assert_eq!(p.counts(SensorKind::Flow).rejected(Reject::NotReady), 1);
    assert_eq!(p.counts(SensorKind::Imu).rejected(Reject::NotReady), 1);
    // A camera with too few inliers gives a typed reason.
    let m = CameraMotion::new(
        Timestamp(200 * MS),
        Timestamp(300 * MS),
        Rot3::identity(),
        Vec3::x() * 0.01,
        5,
        0.9,
        0.4,
    )
    .unwrap();
    assert_eq!(
        p.push_camera(&m).unwrap().scale,
        Err(NoScale::CameraUnreliable)
    );
}

#[test]
fn raw_frame_flow_gives_the_scale() {
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::FlowOnly)).unwrap();
    // Raw 35x35 frames every 10 ms: 0.01 rad per pixel at 20 mm, 0.3 m/s.
    let optics = RawFlowOptics::new(0.01, 0.02, Extrinsics::identity(), 4).unwrap();
    let px = 0.3 * 0.01 / (0.01 * 0.02); // 15 px per frame pair
    let mut features = vec![FeatureMotion { dx: -px, dy: 0.0 }; 20];
    features[3] = FeatureMotion { dx: 40.0, dy: -3.0 }; // a bad track
    for k in 0..50u64 {
        p.push_raw_flow(
            Timestamp(k * 10 * MS),
            Timestamp((k + 1) * 10 * MS),
            &features,
            &optics,
        )
        .unwrap();
    }
    assert_eq!(
        p.push_raw_flow(
            Timestamp(500 * MS),
            Timestamp(510 * MS),
            &features[..2],
            &optics
        ),
        Err(Reject::LowQuality)
    );
    for f in 0..4u64 {
        let m = CameraMotion::new(
            Timestamp(f * 100 * MS),
            Timestamp((f + 1) * 100 * MS),
            Rot3::identity(),
            Vec3::new(0.03 / D, 0.0, 0.0),
            120,
            0.9,
            0.4,
        )
        .unwrap();
        let d = p.push_camera(&m).unwrap();
        let s = d.scale.unwrap();
        assert_eq!(s.source, ScaleSource::Flow);
        assert!((s.scale - D).abs() < 0.01 * D, "{s:?}");
    }
}

#[test]
fn spinning_in_place_is_slip_and_the_memory_learns_the_place() {
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    drive(&mut p, 0, 10, 0.3, 1.0, 1.0, true);
    // Stuck: the wheels turn, the camera and the flow see nothing.
    let d = drive(&mut p, 1_000, 5, 0.3, 1.0, 0.0, false);
    for d in &d {
        assert!(d.slip.spinning, "{:?}", d.slip);
        assert!(d.slip.exceeded);
        assert_eq!(d.slip.cause, SlipCause::SpinInPlace);
        assert_eq!(d.scale, Err(NoScale::BaselineTooSmall));
    }
    assert_eq!(p.memory().tally(SensorKind::Wheel, AdverseKind::Slip), 5);
    let here = p.body_pose().translation.vector;
    let here = vslam_core::geometry::Vec2::new(here.x, here.y);
    let w = p
        .memory()
        .weight(SensorKind::Wheel, &here, Timestamp(1_500 * MS));
    assert!(w < 0.5, "{w}");
    // Driving on from the same place: the learned weight lowers the wheels'
    // confidence in the decision before any slip is seen again.
    let d = drive(&mut p, 1_500, 1, 0.3, 1.0, 1.0, true);
    assert!(d[0].wheel_weight < 0.5, "{:?}", d[0]);
    assert_eq!(d[0].flow_weight, 1.0);
    assert!(d[0].wheel.confidence <= d[0].wheel_weight);
    // The memory survives an export/restore into a fresh pipeline.
    let mut buf = vec![0u8; vslam_core::scale::pipeline::PipelineMemory::RECORD_LEN];
    p.memory().export(&mut buf).unwrap();
    let mut q: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    q.set_memory(vslam_core::scale::pipeline::PipelineMemory::restore(&buf).unwrap());
    assert_eq!(q.memory(), p.memory());
}

#[test]
fn a_restored_memory_must_be_sound_and_made_with_the_same_settings() {
    use vslam_core::adverse::{AdverseError, AdverseParams};
    use vslam_core::scale::pipeline::PipelineMemory;
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    drive(&mut p, 0, 10, 0.3, 1.0, 1.0, true);
    drive(&mut p, 1_000, 5, 0.3, 1.0, 0.0, false);
    let mut buf = vec![0u8; PipelineMemory::RECORD_LEN];
    p.memory().export(&mut buf).unwrap();
    assert!(p.memory().cells() > 0);

    let mut q: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    let empty = q.memory().clone();
    // Corrupt: refused, the memory kept as it was.
    let mut bad = buf.clone();
    bad[60] ^= 0x10;
    assert_eq!(q.restore_memory(&bad), Err(AdverseError::BadChecksum));
    assert_eq!(q.memory(), &empty);
    // Sound, but made with another cell size than this pipeline's.
    let mut other = config(SelectionMethod::Fusion);
    other.adverse = AdverseParams {
        cell_size: 0.25,
        ..other.adverse
    };
    let mut r: ScalePipeline = ScalePipeline::new(other).unwrap();
    assert_eq!(r.restore_memory(&buf), Err(AdverseError::SettingsMismatch));
    assert_eq!(r.memory().cells(), 0);
    // Sound and with the same settings: restored.
    assert_eq!(q.restore_memory(&buf), Ok(()));
    assert_eq!(q.memory(), p.memory());
}

#[test]
fn slip_episode_switches_to_flow_and_back_in_the_pipeline() {
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::SlipThreshold)).unwrap();
    let calm = drive(&mut p, 0, 10, 0.3, 1.0, 1.0, true);
    let slip = drive(&mut p, 1_000, 10, 0.3, 1.4, 1.0, true);
    let after = drive(&mut p, 2_000, 10, 0.3, 1.0, 1.0, true);
    let src = |d: &FrameDecision| d.scale.map(|s| s.source);
    assert!(calm.iter().all(|d| src(d) == Ok(ScaleSource::Wheel)));
    // The first frame of the episode may straddle its start.
    assert!(
        slip[1..]
            .iter()
            .all(|d| src(d) == Ok(ScaleSource::Flow) && d.slip.exceeded)
    );
    assert!(after[1..].iter().all(|d| src(d) == Ok(ScaleSource::Wheel)));
    for d in slip.iter().chain(after.iter()) {
        assert!((d.running.unwrap().scale - D).abs() < 0.02 * D);
    }
}

#[test]
fn the_current_pose_does_not_depend_on_the_buffer_and_records_are_kept() {
    let sc = scale_sim::scenario(3);
    let config = PipelineConfig {
        camera: sc.camera,
        flow_optics: Some(sc.flow_optics),
        ..PipelineConfig::default()
    };
    let mut small: ScalePipeline<2> = ScalePipeline::new(config).unwrap();
    let mut big: ScalePipeline<128> = ScalePipeline::new(config).unwrap();
    for (_, e) in &sc.events {
        for_both(&mut small, &mut big, e);
    }
    assert_eq!(small.camera_pose(), big.camera_pose());
    assert_eq!(small.trajectory().recent().count(), 2);
    assert_eq!(big.trajectory().recent().count(), 128);
    assert_eq!(small.trajectory().frames(), big.trajectory().frames());
    let last = small.last_decision().unwrap();
    assert_eq!(Some(last), big.last_decision());
    assert_eq!(last.method, SelectionMethod::Fusion);
}

fn for_both<const A: usize, const B: usize>(
    a: &mut ScalePipeline<A>,
    b: &mut ScalePipeline<B>,
    e: &scale_sim::Event,
) {
    use scale_sim::Event;
    match e {
        Event::Imu(s) => {
            let _ = (a.push_imu(s), b.push_imu(s));
        }
        Event::Wheel(d) => {
            let _ = (a.push_wheel(d), b.push_wheel(d));
        }
        Event::Flow(s) => {
            let _ = (a.push_flow(s), b.push_flow(s));
        }
        Event::Camera(m) => {
            let _ = (a.push_camera(m), b.push_camera(m));
        }
    }
}

#[test]
fn bad_settings_are_refused_by_name() {
    use vslam_core::adverse::{AdverseError, AdverseParams};
    use vslam_core::scale::PipelineConfigError;
    let mut c = PipelineConfig::default();
    c.slip.threshold = f32::NAN;
    assert_eq!(
        ScalePipeline::<4>::new(c).err(),
        Some(PipelineConfigError::OutOfRange("slip.threshold"))
    );
    let mut c = PipelineConfig::default();
    c.select.min_baseline = 0.0;
    assert_eq!(
        ScalePipeline::<4>::new(c).err(),
        Some(PipelineConfigError::OutOfRange("select.min_baseline"))
    );
    let c = PipelineConfig {
        adverse: AdverseParams {
            cell_size: -1.0,
            ..AdverseParams::default()
        },
        ..PipelineConfig::default()
    };
    assert_eq!(
        ScalePipeline::<4>::new(c).err(),
        Some(PipelineConfigError::Adverse(AdverseError::BadParams))
    );
    assert!(PipelineConfig::default().validate().is_ok());
}

#[test]
fn wheel_yaw_the_gyro_does_not_see_is_slip() {
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::SlipThreshold)).unwrap();
    let calm = drive(&mut p, 0, 10, 0.3, 1.0, 1.0, true);
    assert!(calm.iter().all(|d| d.slip.yaw_rate_error.unwrap() < 1e-3));
    // One wheel spins: the wheels report 1 rad/s of yaw, the gyro none.
    let d = drive_with_wheel_yaw(&mut p, 1_000, 3, 0.3, 1.0, 1.0, true, 1.0);
    for d in &d[1..] {
        assert!(
            (d.slip.yaw_rate_error.unwrap() - 1.0).abs() < 0.01,
            "{:?}",
            d.slip
        );
        assert_eq!(d.slip.cause, SlipCause::WheelVsGyro);
        assert_eq!(d.scale.map(|s| s.source), Ok(ScaleSource::Flow));
    }
}

/// The floor's grip feeds the wheel confidence: on a floor of grip 0.6 the
/// wheels (5 % long, not yet slipping) get 0.6 / 0.9 of the confidence they
/// get on a firm floor, and the fused scale leans towards the flow's.
#[test]
fn low_grip_lowers_the_wheel_confidence_before_slip_shows() {
    let mut firm: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    let mut slippery: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    assert_eq!(slippery.set_wheel_grip(0.0), Err(Reject::OutOfRange));
    assert_eq!(slippery.set_wheel_grip(f32::NAN), Err(Reject::OutOfRange));
    slippery.set_wheel_grip(0.6).unwrap();
    firm.set_wheel_grip(0.95).unwrap();
    let a = drive(&mut firm, 0, 10, 0.3, 1.05, 1.0, true);
    let b = drive(&mut slippery, 0, 10, 0.3, 1.05, 1.0, true);
    for (a, b) in a.iter().zip(&b).skip(2) {
        assert!(!a.slip.exceeded && !b.slip.exceeded);
        let ratio = b.wheel.confidence / a.wheel.confidence;
        assert!((ratio - 0.6 / 0.9).abs() < 1e-3, "{ratio}");
        let (sa, sb) = (a.scale.unwrap().scale, b.scale.unwrap().scale);
        assert!((sb - D).abs() < (sa - D).abs(), "{sb} vs {sa}");
    }
}

#[test]
fn events_from_elsewhere_are_recorded_once_per_episode_where_the_robot_is() {
    use vslam_core::scale::pipeline::EPISODE_GAP_NS;
    let mut p: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    drive(&mut p, 0, 10, 0.3, 1.0, 1.0, true);
    let here = p.body_pose().translation.vector;
    let here = vslam_core::geometry::Vec2::new(here.x, here.y);
    assert!(here.x > 0.2, "the robot moved: {here:?}");
    let (imu, sat) = (SensorKind::Imu, AdverseKind::Saturated);
    let t0 = 2_000 * MS;
    // Samples of one knock: one event.
    for k in 0..10 {
        let recorded = p
            .record_event(imu, sat, Timestamp(t0 + k * 4 * MS))
            .unwrap();
        assert_eq!(recorded, k == 0, "sample {k}");
    }
    // Another kind or sensor is its own episode.
    assert!(
        p.record_event(SensorKind::Wheel, AdverseKind::Collision, Timestamp(t0))
            .unwrap()
    );
    // A gap of EPISODE_GAP_NS after the last sample of the knock: a new one.
    let later = t0 + 36 * MS + EPISODE_GAP_NS;
    assert!(!p.record_event(imu, sat, Timestamp(later - 1)).unwrap());
    assert!(
        p.record_event(imu, sat, Timestamp(later - 1 + EPISODE_GAP_NS))
            .unwrap()
    );
    assert_eq!(p.memory().tally(imu, sat), 2);
    assert_eq!(
        p.memory().tally(SensorKind::Wheel, AdverseKind::Collision),
        1
    );
    // Recorded where the robot is: two knocks there lower the IMU's weight.
    let t = Timestamp(later + 2 * EPISODE_GAP_NS);
    assert!(p.memory().weight(imu, &here, t) < 1.0);
    let elsewhere = vslam_core::geometry::Vec2::new(here.x - 1.0, here.y);
    assert_eq!(p.memory().events(imu, &elsewhere, t), 0.0);
}

#[test]
fn repeated_camera_events_lower_the_camera_confidence_there() {
    use vslam_core::scale::pipeline::EPISODE_GAP_NS;
    let mut plain: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    let mut learned: ScalePipeline = ScalePipeline::new(config(SelectionMethod::Fusion)).unwrap();
    drive(&mut plain, 0, 10, 0.3, 1.0, 1.0, true);
    drive(&mut learned, 0, 10, 0.3, 1.0, 1.0, true);
    // Three camera disagreements where the robot is (three episodes):
    // weight 1 / (1 + 0.5 * 2) = 0.5.
    for k in 0..3u64 {
        let t = Timestamp(1_000 * MS + k * EPISODE_GAP_NS);
        assert!(
            learned
                .record_event(SensorKind::Camera, AdverseKind::Disagreement, t)
                .unwrap()
        );
    }
    let t_ms = 1_000 + 3 * EPISODE_GAP_NS / MS;
    let a = drive(&mut plain, t_ms, 1, 0.3, 1.0, 1.0, true);
    let b = drive(&mut learned, t_ms, 1, 0.3, 1.0, 1.0, true);
    assert_eq!(a[0].camera_weight, 1.0);
    assert!((b[0].camera_weight - 0.5).abs() < 1e-3, "{:?}", b[0]);
    assert!(a[0].camera_confidence > 0.0);
    let ratio = b[0].camera_confidence / a[0].camera_confidence;
    assert!((ratio - 0.5).abs() < 1e-3, "{ratio}");
}
