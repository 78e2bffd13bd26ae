//! Named scenarios and the generation of a whole ASL dataset from one.

use super::drivers::{flow_through_driver_with, wheels_through_driver_with};
use super::floors::FloorLook;
use super::forward::{Scene, render_forward};
use super::motion::{Robot, TruthStep, integrate};
use super::render::{Camera, Texture, render_ceiling, render_labels};
use super::script::{Episode, EpisodeKind, Script};
use super::sensors::{FlowModel, ImuModel, flow, imu, wheel_angles};
use super::world::{SEG_CLASSES, SEG_GROUND, World};
use crate::asl::{
    CameraMeta, Dataset, FlowMeta, GroundTruth, ImageEntry, ImuMeta, SegMeta, WheelMeta,
};
use crate::error::CliError;
use crate::faults::image::{spoil_frame, spoil_labels};
use crate::faults::report::Injected;
use crate::faults::{Expected, FailedRead, FaultKind, FaultPlan, FaultSpec, Stage, Stream};
use crate::pngio::save_gray;
use crate::progress::Progress;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use traction::frontend::MAX_BRIDGED_FRAMES;
use vslam_core::Timestamp;

/// Everything that defines a simulated run.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// Name on the command line.
    pub name: &'static str,
    /// The world.
    pub world: World,
    /// The drive.
    pub script: Script,
    /// The robot.
    pub robot: Robot,
    /// IMU model.
    pub imu: ImuModel,
    /// Flow sensor model.
    pub flow: FlowModel,
    /// Upward camera.
    pub camera: Camera,
    /// Forward segmentation camera.
    pub segmentation: Camera,
    /// Forward image camera (`cam1`): the segmentation camera's view at
    /// twice its resolution, at its rate.
    pub forward: Camera,
    /// Wheel encoder rate, Hz.
    pub wheel_rate_hz: f64,
    /// Stuck and lifted faults pause the drive where they start and it goes
    /// on afterwards ([`Script::with_pause`]), instead of cutting the
    /// distance they last out of the path: the long shuttle drive keeps to
    /// its rooms however many faults it meets.
    pub pauses_keep_path: bool,
}

/// Names of the scenarios `simulate --scenario` knows.
pub const SCENARIOS: [&str; 6] = ["office", "slip", "short", "straight", "shuttle", "spin"];

/// Duration of the `shuttle` scenario unless `--duration` says otherwise, s.
pub const SHUTTLE_DEFAULT_S: f64 = 300.0;

impl Scenario {
    /// The scenario called `name`.
    pub fn by_name(name: &str) -> Option<Self> {
        let base = Scenario {
            name: "office",
            world: World::office(),
            script: Script::office(),
            robot: Robot::vacuum(),
            imu: ImuModel::mems(),
            flow: FlowModel::paa5100(),
            camera: Camera::ceiling(),
            segmentation: Camera::forward_segmentation(),
            forward: Camera::forward_image(),
            wheel_rate_hz: 50.0,
            pauses_keep_path: false,
        };
        match name {
            "office" => Some(base),
            // Harder slip: longer and stronger episodes of spinning wheels.
            "slip" => {
                let mut s = base;
                s.name = "slip";
                s.script.episodes = vec![
                    Episode {
                        start: 8.0,
                        end: 11.0,
                        kind: EpisodeKind::Spin(1.8),
                    },
                    Episode {
                        start: 22.0,
                        end: 26.0,
                        kind: EpisodeKind::Spin(1.6),
                    },
                    Episode {
                        start: 33.0,
                        end: 36.0,
                        kind: EpisodeKind::Spin(2.0),
                    },
                    Episode {
                        start: 48.0,
                        end: 51.0,
                        kind: EpisodeKind::Stuck,
                    },
                ];
                Some(s)
            }
            // The first 12 s of the office: quick tests.
            "short" => {
                let mut s = base;
                s.name = "short";
                s.script.duration = 12.0;
                Some(s)
            }
            // An even wood floor, constant speed, 10 m straight, no slip
            // episodes, no strips or cables.
            "straight" => {
                let mut s = base;
                s.name = "straight";
                s.world = World::straight();
                s.script = Script::straight();
                Some(s)
            }
            // Ten turns in place on the even wood floor ([`Script::spin`]).
            "spin" => {
                let mut s = base;
                s.name = "spin";
                s.world = World::straight();
                s.script = Script::spin();
                Some(s)
            }
            // The long drive: the office's first leg out and back again and
            // again, laps taking turns as office, slip and straight laps.
            "shuttle" => {
                let mut s = base;
                s.name = "shuttle";
                s.script = Script::shuttle(SHUTTLE_DEFAULT_S);
                s.pauses_keep_path = true;
                Some(s)
            }
            _ => None,
        }
    }

    /// The scenario run for `seconds`: the shuttle drives as many laps as
    /// fit, any other scenario is cut or padded with standing still.
    pub fn with_duration(mut self, seconds: f64) -> Self {
        if self.name == "shuttle" {
            self.script = Script::shuttle(seconds);
        } else {
            self.script.duration = seconds;
        }
        self
    }
}

/// Every truth step's pose as EuRoC ground truth, at the IMU rate.
fn groundtruth(truth: &[TruthStep], biases: &[[[f64; 3]; 2]], every: usize) -> Vec<GroundTruth> {
    truth
        .iter()
        .step_by(every)
        .zip(biases)
        .map(|(s, b)| {
            let (sn, cs) = (0.5 * s.yaw).sin_cos();
            GroundTruth {
                t: Timestamp(s.t_ns),
                p: s.p,
                q_wxyz: [cs, 0.0, 0.0, sn],
                v: s.vel,
                bias_gyro: b[0],
                bias_accel: b[1],
            }
        })
        .collect()
}

/// The dataset of scenario `sc` without samples: every sensor's metadata
/// (what `sensor.yaml` says), empty streams and no ground truth.
pub fn dataset_of(sc: &Scenario) -> Dataset {
    let identity = [
        1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
    ];
    let m = &sc.imu;
    let to_u32 = |r: [usize; 2]| [r[0] as u32, r[1] as u32];
    Dataset {
        imu: Some((
            ImuMeta {
                t_bs: identity,
                rate_hz: m.rate_hz,
                gyroscope_noise_density: m.gyro_noise_density,
                gyroscope_random_walk: m.gyro_random_walk,
                accelerometer_noise_density: m.accel_noise_density,
                accelerometer_random_walk: m.accel_random_walk,
            },
            Vec::new(),
        )),
        wheel: Some((
            WheelMeta {
                rate_hz: sc.wheel_rate_hz,
                ticks_per_revolution: Some(sc.robot.ticks_per_revolution),
                wheel_radius_left: sc.robot.nominal_radius,
                wheel_radius_right: sc.robot.nominal_radius,
                wheel_base: sc.robot.wheel_base,
                track_factor: 1.0,
                steering: vslam_core::robot::Steering::Differential,
                wheel_type: "soft_rubber".into(),
            },
            Vec::new(),
        )),
        flow: Some((
            FlowMeta {
                rate_hz: sc.flow.rate_hz,
                t_bs: sc.flow.t_bs_matrix(),
                height: sc.flow.t_bs[2],
                counts_per_radian: sc.flow.counts_per_radian,
            },
            Vec::new(),
        )),
        cam: Some((
            CameraMeta {
                rate_hz: sc.camera.rate_hz,
                t_bs: sc.camera.t_bs_matrix(),
                resolution: to_u32(sc.camera.resolution),
                intrinsics: sc.camera.intrinsics,
                distortion_model: "radtan".into(),
                distortion_coefficients: vec![0.0; 4],
            },
            Vec::new(),
        )),
        seg: Some((
            SegMeta {
                rate_hz: sc.segmentation.rate_hz,
                t_bs: sc.segmentation.t_bs_matrix(),
                resolution: to_u32(sc.segmentation.resolution),
                intrinsics: sc.segmentation.intrinsics,
                classes: SEG_CLASSES
                    .iter()
                    .map(|(k, v)| (*k, (*v).to_string()))
                    .collect(),
                ground_classes: SEG_GROUND.to_vec(),
            },
            Vec::new(),
        )),
        cam1: Some((
            CameraMeta {
                rate_hz: sc.forward.rate_hz,
                t_bs: sc.forward.t_bs_matrix(),
                resolution: to_u32(sc.forward.resolution),
                intrinsics: sc.forward.intrinsics,
                distortion_model: "radtan".into(),
                distortion_coefficients: vec![0.0; 4],
            },
            Vec::new(),
        )),
        flowraw: None,
        groundtruth: None,
        wheel_rates: None,
        labels: None,
        failed: Vec::new(),
    }
}

/// Simulates `sc` with `seed`, writing images under `root/mav0/{cam0,seg0,cam1}/data/`;
/// returns the dataset (also to be written with `asl::write_dataset`) and the truth.
/// Shows no progress.
pub fn generate(
    sc: &Scenario,
    seed: u64,
    root: &Path,
) -> Result<(Dataset, Vec<TruthStep>), CliError> {
    generate_with(sc, seed, root, &FaultPlan::none(), &Progress::hidden())
        .map(|(ds, truth, _)| (ds, truth))
}

/// What the chip and image faults of a generation spoiled.
#[derive(Clone, Debug, Default)]
pub struct GeneratedFaults {
    /// Samples read but spoiled (encoder wrap-around), frames and maps spoiled.
    pub injected: Vec<Injected>,
    /// Reads that failed.
    pub failed: Vec<FailedRead>,
}

/// [`generate`] with the chip faults of `plan` injected into the chip
/// simulators and its vision faults into the rendered images (motion faults
/// are applied to the scenario beforehand: `faults::scenario::apply`).
/// `progress` gets a `simulating` bar over the sensor streams (truth, IMU,
/// wheels, flow) and a `rendering` bar over the camera and segmentation
/// images.
pub fn generate_with(
    sc: &Scenario,
    seed: u64,
    root: &Path,
    plan: &FaultPlan,
    progress: &Progress,
) -> Result<(Dataset, Vec<TruthStep>, GeneratedFaults), CliError> {
    let sensors = progress.bar("simulating", 4, "streams");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = integrate(&sc.world, &sc.script, &sc.robot);
    sensors.inc(1);
    let (imu_samples, biases) = imu(&truth, &sc.imu, &mut rng);
    sensors.inc(1);
    // Encoders and the flow sensor are read through the real drivers from
    // register-level chip simulators.
    let wheel_reads = wheels_through_driver_with(&wheel_angles(&truth, sc.wheel_rate_hz), plan)?;
    sensors.inc(1);
    let flow_reads = flow_through_driver_with(&flow(&truth, &sc.flow, &mut rng), plan)?;
    sensors.inc(1);
    sensors.finish_and_clear();
    let mut faults = GeneratedFaults::default();
    for (stream, spoiled) in [
        (Stream::Wheel, &wheel_reads.spoiled),
        (Stream::Flow, &flow_reads.spoiled),
    ] {
        faults.injected.extend(spoiled.iter().map(|s| Injected {
            fault: s.fault,
            stream,
            t: s.t,
            occurrence: 0,
        }));
    }
    faults.failed.extend(wheel_reads.failed);
    faults.failed.extend(flow_reads.failed);
    let (wheel_samples, flow_samples) = (wheel_reads.samples, flow_reads.samples);
    let image_faults: Vec<(usize, FaultSpec)> = plan
        .select(|f| f.kind.stage() == Stage::Image)
        .map(|(i, f)| (i, *f))
        .collect();
    // Frames and maps each fault spoils: `count` of them from its start.
    let mut left: Vec<u32> = image_faults.iter().map(|(_, f)| f.count).collect();
    let mut image_fault = |stream: Stream, t: u64| -> Option<(usize, FaultKind)> {
        image_faults
            .iter()
            .zip(left.iter_mut())
            .find(|((_, f), n)| **n > 0 && f.kind.stream() == Some(stream) && t >= f.start_ns())
            .map(|((i, f), n)| {
                *n -= 1;
                (*i, f.kind)
            })
    };
    let mut previous_frame: Option<crate::pngio::GrayImage> = None;
    // The last unusable frame's fault and how many came in a row.
    let mut bad_run: (Option<usize>, usize) = (None, 0);

    let cam_dir = root.join("mav0/cam0/data");
    let seg_dir = root.join("mav0/seg0/data");
    let fwd_dir = root.join("mav0/cam1/data");
    for d in [&cam_dir, &seg_dir, &fwd_dir] {
        std::fs::create_dir_all(d).map_err(|e| CliError::file(d, format!("cannot create: {e}")))?;
    }
    let tex = Texture::ceiling();
    let mut frames = Vec::new();
    let mut labels = Vec::new();
    let every = |hz: f64| ((1e9 / hz) as u64 / super::motion::TRUTH_STEP_NS).max(1) as usize;
    let images = truth.len().div_ceil(every(sc.camera.rate_hz))
        + truth.len().div_ceil(every(sc.segmentation.rate_hz))
        + truth.len().div_ceil(every(sc.forward.rate_hz));
    let rendering = progress.bar("rendering", images as u64, "images");
    for s in truth.iter().step_by(every(sc.camera.rate_hz)) {
        let path = cam_dir.join(format!("{}.png", s.t_ns));
        let mut img = render_ceiling(&sc.world, &sc.camera, &tex, s);
        let mut spoiled = None;
        if let Some((i, kind)) = image_fault(Stream::Camera, s.t_ns)
            && spoil_frame(kind, &mut img, previous_frame.as_ref())
        {
            spoiled = Some(i);
        }
        // A frame's outcome is its pair's (previous, this). The front end
        // keeps the last good frame as its reference across up to
        // `MAX_BRIDGED_FRAMES` bad ones, so the pair after them is measured
        // against it and fused; after a longer run the last bad frame became
        // the reference and the pair after it is unusable too.
        let pair_after = match spoiled {
            None if bad_run.1 > usize::from(MAX_BRIDGED_FRAMES) => bad_run.0,
            _ => None,
        };
        if let Some(i) = spoiled.or(pair_after) {
            faults.injected.push(Injected {
                fault: i,
                stream: Stream::Camera,
                t: Timestamp(s.t_ns),
                occurrence: 0,
            });
        }
        let unusable = spoiled.filter(|i| {
            plan.faults
                .get(*i)
                .is_some_and(|f| f.kind.expected() != Expected::Fused)
        });
        bad_run = match unusable {
            Some(i) => (Some(i), bad_run.1 + 1),
            None => (None, 0),
        };
        save_gray(&path, &img)?;
        rendering.inc(1);
        previous_frame = Some(img);
        frames.push(ImageEntry {
            t: Timestamp(s.t_ns),
            path,
        });
    }
    for s in truth.iter().step_by(every(sc.segmentation.rate_hz)) {
        let path = seg_dir.join(format!("{}.png", s.t_ns));
        let mut img = render_labels(&sc.world, &sc.segmentation, s);
        if let Some((i, kind)) = image_fault(Stream::Segmentation, s.t_ns)
            && spoil_labels(kind, &mut img)
        {
            faults.injected.push(Injected {
                fault: i,
                stream: Stream::Segmentation,
                t: Timestamp(s.t_ns),
                occurrence: 0,
            });
        }
        save_gray(&path, &img)?;
        rendering.inc(1);
        labels.push(ImageEntry {
            t: Timestamp(s.t_ns),
            path,
        });
    }
    let look = FloorLook::world();
    let scene = Scene {
        world: &sc.world,
        look: &look,
        wall: &tex,
    };
    let mut forward_frames = Vec::new();
    for s in truth.iter().step_by(every(sc.forward.rate_hz)) {
        let path = fwd_dir.join(format!("{}.png", s.t_ns));
        save_gray(&path, &render_forward(&scene, &sc.forward, s))?;
        rendering.inc(1);
        forward_frames.push(ImageEntry {
            t: Timestamp(s.t_ns),
            path,
        });
    }
    rendering.finish_and_clear();

    let mut ds = dataset_of(sc);
    if let Some((_, v)) = ds.imu.as_mut() {
        *v = imu_samples;
    }
    if let Some((_, v)) = ds.wheel.as_mut() {
        *v = wheel_samples;
    }
    if let Some((_, v)) = ds.flow.as_mut() {
        *v = flow_samples;
    }
    if let Some((_, v)) = ds.cam.as_mut() {
        *v = frames;
    }
    if let Some((_, v)) = ds.seg.as_mut() {
        *v = labels;
    }
    if let Some((_, v)) = ds.cam1.as_mut() {
        *v = forward_frames;
    }
    ds.groundtruth = Some(groundtruth(&truth, &biases, every(sc.imu.rate_hz)));
    Ok((ds, truth, faults))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::asl::{read_dataset, write_dataset};

    #[test]
    fn short_scenario_round_trips_through_asl() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let mut sc = Scenario::by_name("short").unwrap();
        sc.script.duration = 2.0;
        let (ds, truth) = generate(&sc, 7, dir).unwrap();
        write_dataset(dir, &ds).unwrap();
        let back = read_dataset(dir).unwrap();
        assert_eq!(back.imu.as_ref().map(|x| x.1.len()), Some(501));
        assert_eq!(back.wheel.as_ref().map(|x| x.1.len()), Some(101));
        assert_eq!(back.cam.as_ref().map(|x| x.1.len()), Some(21));
        assert_eq!(back.seg.as_ref().map(|x| x.1.len()), Some(5));
        assert_eq!(back.cam1.as_ref().map(|x| x.1.len()), Some(5));
        assert!(
            back.flow == ds.flow,
            "flow stream differs after the round trip"
        );
        assert!(back.missing().is_empty());
        assert_eq!(truth.len(), 2001);
        // Same seed, same data.
        let (again, _) = generate(&sc, 7, dir).unwrap();
        assert!(again.imu == ds.imu, "same seed gave different IMU data");
    }

    #[test]
    fn generation_counts_streams_and_images_on_its_bars() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let mut sc = Scenario::by_name("short").unwrap();
        sc.script.duration = 2.0;
        let progress = Progress::hidden();
        let (ds, _, _) = generate_with(&sc, 7, dir, &FaultPlan::none(), &progress).unwrap();
        let images = ds.cam.as_ref().map_or(0, |x| x.1.len())
            + ds.seg.as_ref().map_or(0, |x| x.1.len())
            + ds.cam1.as_ref().map_or(0, |x| x.1.len());
        assert_eq!(images, 31);
        let bars: Vec<_> = progress
            .bars()
            .iter()
            .map(|b| (b.prefix(), b.message(), b.position(), b.length()))
            .collect();
        assert_eq!(
            bars,
            [
                ("simulating".into(), "streams".into(), 4, Some(4)),
                (
                    "rendering".into(),
                    "images".into(),
                    images as u64,
                    Some(images as u64)
                ),
            ]
        );
        assert!(
            progress
                .bars()
                .iter()
                .all(|b| b.is_hidden() && b.is_finished())
        );
    }
}
