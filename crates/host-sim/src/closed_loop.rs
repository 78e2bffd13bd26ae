//! `host-sim simulate --drive waypoints`: the simulated robot driven in
//! closed loop by the navigator ([`traction::navigate`]) on the estimator's
//! answers alone.
//!
//! Every truth step (1 kHz) moves the robot by the last wheel command
//! ([`Motion`]), with the scenario's slip and stuck episodes at their times
//! and the world's floors, strips and cable; the sensors read it as a
//! scripted run does (IMU with noise and bias walk, encoders through the
//! AS5047P driver, flow reports with their noise (the flow driver passes
//! reports unchanged, `sim::drivers` tests), ceiling frames and
//! segmentation maps rendered at their rates) and go straight into the
//! [`Estimator`]. Each IMU step's vertical deviation and jolt verdict go to
//! the navigator; at every wheel read (50 Hz) the navigator turns the
//! latest [`Estimate`](traction::Estimate) and the surface model's floor
//! into the next wheel command. The truth is only read to report: each
//! waypoint's distance from the true position when the navigator declared
//! it reached, each stop's cause (what lay under the robot when the jolt
//! peaked), and the path.

pub mod route;

use crate::asl::write_dataset;
use crate::error::CliError;
use crate::plot::Scene;
use crate::pngio::GrayImage;
use crate::replay::{FrontEndMemory, ReplayOptions, estimator_config, frontend_config};
use crate::sim::drivers::Encoders;
use crate::sim::motion::{Motion, TRUTH_STEP_NS, TruthStep, differentiate_at};
use crate::sim::render::{Texture, render_ceiling, render_labels};
use crate::sim::scenario::{Scenario, dataset_of};
use crate::sim::sensors::{Flow, Imu};
use crate::tum::{TumPose, write_tum};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde_json::{Value, json};
use std::path::Path;
use traction::estimator::{Estimator, Processed};
use traction::navigate::{Floor, NavConfig, NavEvent, Navigator, Policy};
use traction::vslam_core::Timestamp;
use traction::vslam_core::image::LabelView;

/// Most waypoints a route may have.
pub const MAX_WAYPOINTS: usize = 32;

/// How the closed loop runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopOptions {
    /// How the navigator judges jolts.
    pub policy: Policy,
    /// Longest run, seconds (the robot stops where it is then).
    pub max_s: f64,
    /// Whether the navigator gets the estimates; without them it never
    /// gets a command out and the robot stands (the link cut).
    pub estimates: bool,
}

impl Default for LoopOptions {
    fn default() -> Self {
        LoopOptions {
            policy: Policy::FloorAware,
            max_s: 180.0,
            estimates: true,
        }
    }
}

/// What the run gave, by the truth.
#[derive(Clone, Debug, Default)]
pub struct LoopRun {
    /// Per route waypoint: `Some((time s, distance of the true position from
    /// it when the navigator declared it reached, m))`, `None` if never.
    pub reached: Vec<Option<(f64, f64)>>,
    /// Stops: time of the jolt's peak (s), its peak (m/s^2) and what lay
    /// under the robot then (`cable`, `threshold strip` or the floor's name).
    pub stops: Vec<(f64, f32, String)>,
    /// The truth and the estimate at every control step: `t, x, y` and
    /// the estimate's `x, y` (NaN before the filter starts).
    pub path: Vec<[f64; 5]>,
    /// Suspected obstacles the navigator took for a boundary's strip by
    /// the distance driven since the floor changed (no stop).
    pub explained: u32,
    /// Seconds driven.
    pub duration_s: f64,
}

impl LoopRun {
    /// Whether every waypoint was reached within `tolerance` m by the truth.
    pub fn all_within(&self, tolerance: f64) -> bool {
        self.reached
            .iter()
            .all(|r| r.is_some_and(|(_, e)| e <= tolerance))
    }

    /// Stops whose cause is `cause`.
    pub fn stops_at(&self, cause: &str) -> usize {
        self.stops.iter().filter(|s| s.2 == cause).count()
    }

    /// The run as JSON (`OUT/nav.json`).
    pub fn to_json(&self, route: &[[f32; 2]], policy: Policy) -> Value {
        json!({
            "policy": policy_name(policy),
            "duration_s": self.duration_s,
            "explained_at_boundary": self.explained,
            "waypoints": route.iter().zip(&self.reached).map(|(w, r)| json!({
                "x": w[0], "y": w[1],
                "reached_s": r.map(|r| r.0),
                "error_m": r.map(|r| r.1),
            })).collect::<Vec<_>>(),
            "stops": self.stops.iter().map(|(t, m, c)| json!({
                "t_s": t, "magnitude": m, "cause": c,
            })).collect::<Vec<_>>(),
            "path": self.path.iter().step_by(25).map(|p| p.to_vec()).collect::<Vec<_>>(),
        })
    }

    /// A few lines for the terminal.
    pub fn summary(&self, route: &[[f32; 2]]) -> String {
        let mut s = String::new();
        for (i, (w, r)) in route.iter().zip(&self.reached).enumerate() {
            s += &match r {
                Some((t, e)) => format!(
                    "waypoint {i} ({:.2}, {:.2}): reached at {t:.1} s, {:.3} m from it by the truth\n",
                    w[0], w[1], e
                ),
                None => format!("waypoint {i} ({:.2}, {:.2}): not reached\n", w[0], w[1]),
            };
        }
        s += &format!("stops: {}", self.stops.len());
        for (t, m, c) in &self.stops {
            s += &format!("; {t:.1} s {c} ({m:.1} m/s^2)");
        }
        s += &format!(
            "\nsuspected obstacles taken for a boundary's strip: {}\ndrove {:.1} s\n",
            self.explained, self.duration_s
        );
        s
    }
}

/// The policy's name in reports.
pub fn policy_name(p: Policy) -> &'static str {
    match p {
        Policy::FloorAware => "floor_aware",
        Policy::FixedThreshold { .. } => "fixed_threshold",
    }
}

/// What lay under the robot at `s`: the cable or a threshold strip the wheels
/// were on (within 5 cm), else the floor.
fn cause(sc: &Scenario, s: &TruthStep) -> String {
    let (x, y) = (s.p[0], s.p[1]);
    let near = sc
        .world
        .strips
        .iter()
        .find(|st| (x - st.at).abs() <= 0.05 && y >= st.span[0] && y <= st.span[1]);
    match near {
        Some(st) if st.threshold => "threshold strip".into(),
        Some(_) => "cable".into(),
        None => s.surface.map_or("outside", |f| f.name()).into(),
    }
}

fn every(hz: f64) -> usize {
    ((1e9 / hz) as u64 / TRUTH_STEP_NS).max(1) as usize
}

/// Drives `sc`'s robot through `route` in closed loop with `seed`; writes
/// the sensors' metadata to `OUT/dataset`, and `OUT/ekf.tum`,
/// `OUT/groundtruth.tum` and `OUT/nav.json`.
pub fn run_waypoints(
    sc: &Scenario,
    seed: u64,
    route: &[[f32; 2]],
    options: LoopOptions,
    out: &Path,
) -> Result<LoopRun, CliError> {
    let root = out.join("dataset");
    if root.exists() {
        std::fs::remove_dir_all(&root)
            .map_err(|e| CliError::file(&root, format!("cannot clear the old dataset: {e}")))?;
    }
    let ds = dataset_of(sc);
    write_dataset(&root, &ds)?;
    Scene::of(sc).write(&root)?;
    let replay = ReplayOptions::default();
    let config = estimator_config(&ds, &root, &replay)?;
    let fe_config = frontend_config(&ds, &root, config.scale.camera, &replay)?;
    let mut memory = FrontEndMemory::new(fe_config.as_ref());
    let frontend = memory.frontend(fe_config, &root)?;
    let mut est = Box::new(
        Estimator::new(&config, frontend)
            .map_err(|e| CliError::file(&root, format!("configuration: {e}")))?,
    );
    let mut nav = Navigator::<MAX_WAYPOINTS>::new(NavConfig::default(), options.policy, route)
        .map_err(|e| CliError::Usage(format!("route: {e}")))?;

    let mut imu_rng = ChaCha8Rng::seed_from_u64(seed);
    let mut flow_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5DEE_CE66_D1CE_F10E);
    let mut motion = Motion::default();
    let mut imu = Imu::new(&sc.imu);
    let mut flow = Flow::new(&sc.flow);
    let mut encoders = Encoders::new()?;
    let tex = Texture::ceiling();
    let (wheel_every, cam_every, seg_every) = (
        every(sc.wheel_rate_hz),
        every(sc.camera.rate_hz),
        every(sc.segmentation.rate_hz),
    );

    let mut truth: Vec<TruthStep> = Vec::new();
    let mut run = LoopRun {
        reached: vec![None; route.len()],
        ..LoopRun::default()
    };
    let (mut ekf, mut gt) = (Vec::new(), Vec::new());
    let mut command = (0.0f64, 0.0f64);
    let steps = (options.max_s / (TRUTH_STEP_NS as f64 * 1e-9)).round() as usize;
    for i in 0..=steps {
        let t = motion.t();
        let lift = sc.script.lift(t);
        truth.push(motion.step(&sc.world, &sc.robot, command, sc.script.episode(t), lift));
        // Step k = i - 1 now has both neighbours: its accelerations are known.
        let Some(k) = i.checked_sub(1) else { continue };
        differentiate_at(&mut truth, k);
        let Some(s) = truth.get(k).copied() else {
            continue;
        };
        let ts = Timestamp(s.t_ns);
        let mut processed = Vec::new();
        if k.is_multiple_of(imu.every) {
            let period = truth
                .get(k.saturating_sub(imu.every - 1)..=k)
                .unwrap_or(&[]);
            est.offer_imu(imu.sample(period, &s, &mut imu_rng).0);
        }
        if k.is_multiple_of(wheel_every) {
            est.offer_wheel(encoders.read(ts, s.wheel_angle[0], s.wheel_angle[1])?);
        }
        if let Some(f) = flow.step(&s, &sc.flow, &mut flow_rng) {
            est.offer_flow(f);
        }
        while let Some(p) = est.poll() {
            processed.push(p);
        }
        if k.is_multiple_of(seg_every) {
            let img = render_labels(&sc.world, &sc.segmentation, &s);
            while let Some(p) = est.poll_until(ts) {
                processed.push(p);
            }
            if let Ok(labels) = LabelView::new(&img.data, img.width, img.height, img.width) {
                let _ = est.process_segmentation(ts, &labels);
            }
        }
        if k.is_multiple_of(cam_every) {
            let img: GrayImage = render_ceiling(&sc.world, &sc.camera, &tex, &s);
            if let Ok(view) = img.view() {
                let _ = est.process_camera(ts, &view);
            }
        }
        for p in processed {
            if let Processed::Imu {
                outcome: Ok(step),
                jolt,
                ..
            } = p
                && let Some(stop) = nav.on_imu(step.t, step.vertical_deviation, jolt.as_ref())
            {
                let at = truth
                    .iter()
                    .rev()
                    .find(|x| x.t_ns <= stop.t.0)
                    .unwrap_or(&s);
                run.stops
                    .push((stop.t.0 as f64 * 1e-9, stop.magnitude, cause(sc, at)));
            }
        }
        if !k.is_multiple_of(wheel_every) {
            continue;
        }
        let e = est.estimate().filter(|_| options.estimates);
        run.path.push([
            t,
            s.p[0],
            s.p[1],
            e.map_or(f64::NAN, |e| f64::from(e.p_wb.x)),
            e.map_or(f64::NAN, |e| f64::from(e.p_wb.y)),
        ]);
        let (sn, cs) = (0.5 * s.yaw).sin_cos();
        gt.push(TumPose {
            t: ts,
            p: s.p,
            q_xyzw: [0.0, 0.0, sn, cs],
        });
        let Some(e) = e else { continue };
        let q = e.q_wb;
        ekf.push(TumPose {
            t: e.t,
            p: [e.p_wb.x, e.p_wb.y, e.p_wb.z].map(f64::from),
            q_xyzw: [q.i, q.j, q.k, q.w].map(f64::from),
        });
        let floor = est.surface().map(|m| Floor::of(m, e.t, e.v_b.x));
        let (c, event) = nav.command(&e, floor.as_ref());
        command = (f64::from(c.v), f64::from(c.w));
        let reached = match event {
            Some(NavEvent::Reached(w)) => Some(w),
            Some(NavEvent::Done) => Some(route.len().saturating_sub(1)),
            None => None,
        };
        if let (Some(w), Some(r)) = (reached, reached.and_then(|w| route.get(w))) {
            let err = (s.p[0] - f64::from(r[0])).hypot(s.p[1] - f64::from(r[1]));
            if let Some(slot) = run.reached.get_mut(w) {
                *slot = Some((t, err));
            }
        }
        if nav.is_done() {
            break;
        }
    }
    run.duration_s = motion.t();
    run.explained = nav.explained();
    write_tum(&out.join("ekf.tum"), &ekf)?;
    write_tum(&out.join("groundtruth.tum"), &gt)?;
    let path = out.join("nav.json");
    let text = serde_json::to_string_pretty(&run.to_json(route, options.policy))
        .map_err(|e| CliError::file(&path, e.to_string()))?;
    std::fs::write(&path, text).map_err(|e| CliError::file(&path, format!("cannot write: {e}")))?;
    Ok(run)
}
