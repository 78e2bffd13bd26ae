//! `To` (the flow sensor's distance) from raw frames and from the chip's
//! motion counts, against the truth, on one floor at one speed: the robot
//! drives straight at a constant speed; every 10 ms the frame renderer
//! ([`super::flow_frames`]) shows the floor to a simulated chip, the real
//! driver grabs the frame, [`FrameFlow`] tracks it and
//! [`raw_flow_step`] makes metres of it; the counting model
//! ([`super::sensors::Flow`]) goes through another chip and the driver's
//! motion burst. Both are summed over 100 ms intervals (the camera's frame
//! interval) and compared with the true path of the body origin.

use super::drivers::{FrameGrabber, flow_through_driver};
use super::flow_frames::FlowFrameRenderer;
use super::motion::{TRUTH_STEP_NS, TruthStep};
use super::sensors::{Flow, FlowModel};
use super::world::{Room, Surface, World};
use crate::error::CliError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use traction::vslam_core::Timestamp;
use traction::vslam_core::flow_frames::{FrameFlow, FrameFlowConfig, raw_optics};
use traction::vslam_core::robot::FlowDescription;
use traction::vslam_core::scale::raw_flow::raw_flow_step;
use traction::vslam_core::sensors::FlowOptics;

/// Truth steps per flow report and per frame grab (10 ms).
const REPORT_STEPS: usize = 10;
/// Truth steps per compared interval (100 ms).
const INTERVAL_STEPS: u64 = 100;

/// One floor and speed: the errors of both paths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToAccuracy {
    /// The floor.
    pub surface: Surface,
    /// Speed, m/s.
    pub speed: f64,
    /// 100 ms intervals compared.
    pub intervals: usize,
    /// RMS relative error of `To` per interval from frames, percent.
    pub frames_rms_pct: f64,
    /// The same from the chip's counts, percent.
    pub counts_rms_pct: f64,
    /// Error of the whole run's distance from frames, percent.
    pub frames_total_pct: f64,
    /// The same from counts, percent.
    pub counts_total_pct: f64,
    /// Frame pairs refused (textureless, or too few features for the
    /// robust combination), percent; the frame figures above are over the
    /// intervals without a refused pair (NaN when there are none).
    pub frames_refused_pct: f64,
    /// Median distinctness of the frame pairs' block match
    /// (`vslam_core::flow_frames::ShiftMatch`).
    pub frames_distinctness: f64,
}

/// A world of one room of `surface`.
pub fn one_floor(surface: Surface) -> World {
    World {
        rooms: vec![Room {
            min: [-1.0, -2.5],
            max: [40.0, 2.5],
            surface,
        }],
        ..World::straight()
    }
}

fn straight(surface: Surface, speed: f64, seconds: f64) -> Vec<TruthStep> {
    let n = (seconds * 1e9 / TRUTH_STEP_NS as f64) as u64;
    let dt = TRUTH_STEP_NS as f64 * 1e-9;
    (0..=n)
        .map(|i| {
            let x = speed * i as f64 * dt;
            TruthStep {
                t_ns: i * TRUTH_STEP_NS,
                p: [x, 0.3, 0.0],
                yaw: 0.0,
                v: speed,
                w: 0.0,
                vel: [speed, 0.0, 0.0],
                acc: [0.0; 3],
                surface: Some(surface),
                wheel_angle: [0.0; 2],
                episode: None,
            }
        })
        .collect()
}

/// Measures both paths over `seconds` of driving at `speed` on `surface`.
pub fn measure(
    surface: Surface,
    speed: f64,
    seconds: f64,
    seed: u64,
) -> Result<ToAccuracy, CliError> {
    let world = one_floor(surface);
    let truth = straight(surface, speed, seconds);
    let model = FlowModel::paa5100();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let bad = |m: &str| CliError::Usage(m.to_string());
    let desc = FlowDescription::robot_vacuum();
    let count_optics = FlowOptics::new(desc.counts_per_radian, desc.height, desc.mount)
        .map_err(|e| bad(&format!("flow optics: {e}")))?;
    let optics = raw_optics(&count_optics).ok_or_else(|| bad("raw flow optics"))?;
    // Frames.
    let renderer = FlowFrameRenderer::new(&model);
    let mut grabber = FrameGrabber::new()?;
    let mut tracker = FrameFlow::new(FrameFlowConfig::default())
        .map_err(|e| bad(&format!("raw-frame tracker: {e}")))?;
    let intervals = (truth.len() as u64 - 1) / INTERVAL_STEPS;
    let mut frames = vec![0f64; intervals as usize];
    let mut refused_in = vec![false; intervals as usize];
    let mut distinctness = Vec::new();
    let (mut pairs, mut refused) = (0usize, 0usize);
    for s in truth.iter().step_by(REPORT_STEPS) {
        let frame = grabber.grab(&renderer.render(&world, s, &mut rng))?;
        let Ok(Some(pair)) = tracker.push(Timestamp(s.t_ns), &frame) else {
            continue;
        };
        pairs += 1;
        distinctness.push(f64::from(pair.distinctness));
        let k = ((pair.t0.0 / TRUTH_STEP_NS) / INTERVAL_STEPS) as usize;
        match raw_flow_step(pair.t0, pair.t1, pair.features(), &optics, 0.0) {
            Ok(step) if !pair.textureless => {
                if let Some(slot) = frames.get_mut(k) {
                    *slot += f64::from(step.d_body.x);
                }
            }
            _ => {
                refused += 1;
                if let Some(r) = refused_in.get_mut(k) {
                    *r = true;
                }
            }
        }
    }
    // Counts.
    let mut flow = Flow::new(&model);
    let reports: Vec<_> = truth
        .iter()
        .filter_map(|s| flow.step(s, &model, &mut rng))
        .collect();
    let mut counts = vec![0f64; intervals as usize];
    let mut t_prev = 0u64;
    for r in flow_through_driver(&reports)? {
        let d = count_optics.floor_displacement(&r);
        let k = ((t_prev / TRUTH_STEP_NS) / INTERVAL_STEPS) as usize;
        t_prev = r.t.0;
        if let Some(slot) = counts.get_mut(k) {
            *slot += f64::from(d.x);
        }
    }
    let truth_step = speed * INTERVAL_STEPS as f64 * TRUTH_STEP_NS as f64 * 1e-9;
    let rms = |v: &[f64]| {
        (v.iter()
            .map(|d| ((d - truth_step) / truth_step).powi(2))
            .sum::<f64>()
            / v.len().max(1) as f64)
            .sqrt()
            * 100.0
    };
    let total = |v: &[f64]| {
        let t = truth_step * v.len() as f64;
        (v.iter().sum::<f64>() - t) / t * 100.0
    };
    let frames: Vec<f64> = frames
        .iter()
        .zip(&refused_in)
        .filter(|(_, r)| !**r)
        .map(|(d, _)| *d)
        .collect();
    let none_if_empty = |v: &[f64], f: &dyn Fn(&[f64]) -> f64| {
        if v.is_empty() { f64::NAN } else { f(v) }
    };
    distinctness.sort_by(f64::total_cmp);
    Ok(ToAccuracy {
        surface,
        speed,
        intervals: intervals as usize,
        frames_rms_pct: none_if_empty(&frames, &rms),
        counts_rms_pct: rms(&counts),
        frames_total_pct: none_if_empty(&frames, &total),
        counts_total_pct: total(&counts),
        frames_refused_pct: refused as f64 / pairs.max(1) as f64 * 100.0,
        frames_distinctness: distinctness
            .get(distinctness.len() / 2)
            .copied()
            .unwrap_or(f64::NAN),
    })
}
