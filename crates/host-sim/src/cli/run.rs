//! `host-sim simulate` and `host-sim replay`.

use crate::chaos::{ChaosConfig, run_chaos};
use crate::closed_loop::{LoopOptions, policy_name, route, run_waypoints};
use crate::error::CliError;
use crate::faults::{FaultPlan, kinds_help};
use crate::replay::{FlowSource, ReplayOptions, ReplayOutput, run_replay_with, summary_table};
use crate::sim::scenario::SCENARIOS;
use crate::sim::scenario::SHUTTLE_DEFAULT_S;
use crate::simulate::{scenario_for, simulate_faults_with, simulate_scenario_with};
use clap::{Args, ValueEnum};
use std::io::IsTerminal;
use std::path::PathBuf;
use traction::ego_ekf::grip::GripParams;
use traction::navigate::Policy;
use traction::vslam_core::scale::{ComposeScale, Distance, SelectionMethod};

/// Arguments of `host-sim simulate`.
#[derive(Debug, Args)]
#[command(
    about = "Run a simulated scenario end to end",
    long_about = "Simulates a robot vacuum driving through rooms with different floors and slip \
                  episodes, writes the generated sensor log as an ASL dataset to OUT/dataset, \
                  replays it through the estimator and writes OUT/ekf.tum, OUT/vslam.tum, \
                  OUT/wheel_only.tum, OUT/report.json, OUT/trajectory.svg, OUT/errors.svg and OUT/report.html, then prints a \
                  summary table against the truth. Scenarios: office (default, 60 s: wood with a \
                  cable, carpet, tile, threshold strips, two wheel-spin episodes and a stuck \
                  episode), slip (the office with longer, stronger slip), short (first 12 s), \
                  straight (36 s: 10 m straight at 0.3 m/s on an even wood floor, no slip episodes), \
                  shuttle (the office's first leg out and back again and again, laps taking turns as \
                  office, slip and straight laps; 300 s unless --duration says otherwise), spin \
                  (66 s: ten turns in place at 1 rad/s on the even wood floor)."
)]
pub struct SimulateArgs {
    /// Scenario name.
    #[arg(long, default_value = "office")]
    pub scenario: String,
    /// Seed of every random number of the run.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Faults to inject, `KIND@START[+DUR][xCOUNT]`, comma-separated (seconds
    /// from the start), e.g. `imu-nan@4x3,wheel-gap@5+0.5,stuck@6+2`.
    /// report.json then has a `faults` section. Kinds (-> the outcome every
    /// spoiled sample must end in):
    #[arg(long, value_name = "LIST", long_help = faults_long_help())]
    pub faults: Option<FaultPlan>,
    /// Seconds to run the scenario for: the shuttle drives as many laps as
    /// fit (300 s unless given), any other scenario is cut or padded with
    /// standing still.
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// The upward camera's size, `WIDTHxHEIGHT` (default 320x240): the
    /// frames are rendered at this size with the intrinsics scaled to it
    /// (e.g. `160x120`, the firmware's frames).
    #[arg(long, value_name = "WxH", value_parser = parse_size, conflicts_with = "chaos")]
    pub camera_size: Option<[usize; 2]>,
    /// Chaos: the shuttle drive with faults of every kind drawn at random
    /// with this seed, several at once at times, every invariant checked;
    /// the fault-free run goes to OUT/free, report.json gets a `chaos`
    /// section, and the exit code is 1 when a check fails.
    #[arg(long, value_name = "SEED", conflicts_with = "faults")]
    pub chaos: Option<u64>,
    /// Chaos: mean faults per minute.
    #[arg(long, value_name = "N", default_value_t = 6.0, requires = "chaos")]
    pub chaos_rate: f64,
    /// How the robot is driven: by the scenario's script, or in closed loop
    /// by the navigator through waypoints on the estimator's answers alone
    /// (the scenario's world, robot, sensors and slip episodes; writes
    /// OUT/nav.json, OUT/ekf.tum, OUT/groundtruth.tum).
    #[arg(long, value_enum, default_value = "script")]
    pub drive: DriveArg,
    /// `--drive waypoints`: the route, one `x y` a line in metres (world
    /// frame: origin where the robot starts, x ahead); the office route
    /// (over the cable, both strips, carpet and tile) unless given.
    #[arg(long, value_name = "FILE")]
    pub waypoints: Option<PathBuf>,
    /// `--drive waypoints`: how the navigator judges jolts.
    #[arg(long, value_enum, default_value = "floor-aware")]
    pub policy: PolicyArg,
    /// `--policy fixed-threshold`: the peak vertical deviation that stops
    /// the robot, m/s^2 (default: the jolt a hard floor explains).
    #[arg(long, value_name = "M_S2", default_value_t = GripParams::default().jolt_threshold())]
    pub fixed_threshold: f32,
    /// Scale-factor error of the simulated gyro's z axis (0.01: it reads
    /// 1 % too much).
    #[arg(long, value_name = "K", default_value_t = 0.0)]
    pub gyro_scale_error: f64,
    /// The scale pipeline's settings.
    #[command(flatten)]
    pub scale: ScaleArgs,
}

/// How `simulate` drives the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DriveArg {
    /// The scenario's scripted drive.
    Script,
    /// Closed loop through waypoints.
    Waypoints,
}

/// The navigator's jolt policy, by its command-line name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PolicyArg {
    /// Stop at suspected obstacles only; speed by the floor's grip.
    FloorAware,
    /// Stop at every jolt above `--fixed-threshold`; cruise speed everywhere.
    FixedThreshold,
}

/// `simulate --drive waypoints`.
fn run_waypoints_cmd(a: &SimulateArgs) -> Result<(), CliError> {
    let mut sc = scenario_for(&a.scenario, None)?;
    if let Some([w, h]) = a.camera_size {
        sc.camera = sc.camera.resized(w, h).ok_or_else(|| {
            CliError::Usage(format!("camera size {w}x{h}: expected a size above 0"))
        })?;
    }
    let route = match &a.waypoints {
        Some(p) => route::read(p)?,
        None => route::OFFICE_ROUTE.to_vec(),
    };
    let policy = match a.policy {
        PolicyArg::FloorAware => Policy::FloorAware,
        PolicyArg::FixedThreshold => Policy::FixedThreshold {
            threshold: a.fixed_threshold,
        },
    };
    let max_s = match a.duration {
        None => LoopOptions::default().max_s,
        Some(d) if d.is_finite() && d > 0.0 && d <= 86_400.0 => d,
        Some(d) => {
            return Err(CliError::Usage(format!(
                "duration {d} s: expected a number of seconds in (0, 86400]"
            )));
        }
    };
    let options = LoopOptions {
        policy,
        max_s,
        ..LoopOptions::default()
    };
    println!(
        "driving `{}` (seed {}) through {} waypoints, {}, into {}",
        a.scenario,
        a.seed,
        route.len(),
        policy_name(policy),
        a.out.display()
    );
    std::fs::create_dir_all(&a.out)
        .map_err(|e| CliError::file(&a.out, format!("cannot create: {e}")))?;
    let run = run_waypoints(&sc, a.seed, &route, options, &a.out)?;
    print!("{}", run.summary(&route));
    println!(
        "wrote {}/{{nav.json,ekf.tum,groundtruth.tum}}",
        a.out.display()
    );
    Ok(())
}

/// `WIDTHxHEIGHT`, both above 0.
fn parse_size(s: &str) -> Result<[usize; 2], String> {
    let bad = || format!("`{s}`: expected WIDTHxHEIGHT, e.g. 160x120");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h) = (w.trim().parse::<usize>(), h.trim().parse::<usize>());
    match (w, h) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 && w <= 4096 && h <= 4096 => Ok([w, h]),
        _ => Err(bad()),
    }
}

/// The scale pipeline's selection method, by its command-line name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScaleMethodArg {
    /// 1. Flow when the slip exceeds the threshold, the wheels otherwise.
    SlipThreshold,
    /// 2. Flow when the wheel data are erroneous or an outlier.
    WheelOutlier,
    /// 3. The source with the higher confidence (ties: flow).
    SourceConfidence,
    /// 4. The scale value with the higher confidence (ties: flow).
    ScaleConfidence,
    /// 5. Inverse-variance fusion of the sources that pass the slip and outlier gates.
    Fusion,
    /// The flow sensor only.
    FlowOnly,
    /// The wheels only.
    WheelOnly,
}

impl From<ScaleMethodArg> for SelectionMethod {
    fn from(m: ScaleMethodArg) -> Self {
        match m {
            ScaleMethodArg::SlipThreshold => SelectionMethod::SlipThreshold,
            ScaleMethodArg::WheelOutlier => SelectionMethod::Outlier,
            ScaleMethodArg::SourceConfidence => SelectionMethod::SourceConfidence,
            ScaleMethodArg::ScaleConfidence => SelectionMethod::ScaleConfidence,
            ScaleMethodArg::Fusion => SelectionMethod::Fusion,
            ScaleMethodArg::FlowOnly => SelectionMethod::FlowOnly,
            ScaleMethodArg::WheelOnly => SelectionMethod::WheelOnly,
        }
    }
}

/// Which scale composes the camera path, by its command-line name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ComposeArg {
    /// Each frame pair with its own selected scale (seed 000), default.
    Pair,
    /// The running robust scale (median of the last 15 pairs' scales).
    Running,
}

impl From<ComposeArg> for ComposeScale {
    fn from(c: ComposeArg) -> Self {
        match c {
            ComposeArg::Pair => ComposeScale::Pair,
            ComposeArg::Running => ComposeScale::Running,
        }
    }
}

/// Which length of the wheel and flow motion is compared with `|T|`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DistanceArg {
    /// The path length over the frame interval.
    Path,
    /// The chord: start-to-end displacement over the frame interval, default.
    Chord,
}

impl From<DistanceArg> for Distance {
    fn from(d: DistanceArg) -> Self {
        match d {
            DistanceArg::Path => Distance::Path,
            DistanceArg::Chord => Distance::Chord,
        }
    }
}

/// The scale pipeline's settings shared by `simulate` and `replay`.
#[derive(Debug, Clone, Args)]
pub struct ScaleArgs {
    /// How each camera frame pair's metric scale is chosen from the wheels
    /// and the flow sensor (report.json `frames[].method`); default fusion.
    #[arg(long, value_enum, value_name = "METHOD")]
    pub scale_method: Option<ScaleMethodArg>,
    /// Which scale composes the camera path (vslam.tum): each pair's own
    /// (`pair`, default) or the running robust scale (`running`).
    #[arg(long, value_enum, value_name = "MODE")]
    pub compose: Option<ComposeArg>,
    /// Which length of the wheel and flow motion over a frame pair is
    /// compared with the camera's |T|: the path or the chord (default).
    #[arg(long, value_enum, value_name = "LENGTH")]
    pub distance: Option<DistanceArg>,
    /// The adverse-event memory (where and when each sensor misbehaved)
    /// across runs: restored from FILE at the start when it exists, written
    /// to FILE at the end. A corrupt FILE is refused (stderr), moved to
    /// FILE.refused, and the run starts with an empty memory.
    #[arg(long, value_name = "FILE")]
    pub memory: Option<PathBuf>,
    /// Estimate the gyro's z scale factor as part of the model (the
    /// filter's `ImuConfig::estimate_gyro_scale`; off by default: the rate is
    /// only bias-corrected). report.json `final.gyro_scale` is the estimate.
    #[arg(long)]
    pub gyro_scale: bool,
    /// The flow sensor's power: `always` on (default) or `on-demand`, woken
    /// when slip is detected or predicted and released after a quiet period
    /// (`traction::flow_demand`, default settings); report.json `flow_power`
    /// says how long it was on.
    #[arg(long, value_enum, value_name = "MODE", default_value = "always")]
    pub flow: FlowArg,
    /// Where the flow sensor's distance To comes from: its motion `counts`
    /// (flow0) or its raw `frames` (flowraw0: corners and Lucas-Kanade on
    /// the 35x35 frames). `simulate` records the frames only with `frames`
    /// and defaults to counts; `replay` defaults to frames when the log has
    /// them and no counts.
    #[arg(long, value_enum, value_name = "SOURCE")]
    pub flow_source: Option<FlowSourceArg>,
    /// Without the floor's expected slip in the wheel measurement's mean
    /// (no slip prior or learning, the wheel radii learning on every floor):
    /// for comparison with the default.
    #[arg(long)]
    pub no_expected_slip: bool,
}

/// The flow sensor's power, by its command-line name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FlowArg {
    /// Always on.
    Always,
    /// On when slip is detected or predicted.
    OnDemand,
}

/// The flow sensor's stream, by its command-line name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FlowSourceArg {
    /// Motion counts (flow0).
    Counts,
    /// Raw frames (flowraw0).
    Frames,
}

impl ScaleArgs {
    /// `base` with these settings applied.
    fn options(self, base: ReplayOptions) -> ReplayOptions {
        ReplayOptions {
            flow_source: self.flow_source.map(|f| match f {
                FlowSourceArg::Counts => FlowSource::Counts,
                FlowSourceArg::Frames => FlowSource::Frames,
            }),
            scale_method: self.scale_method.map(Into::into),
            compose: self.compose.map(Into::into),
            distance: self.distance.map(Into::into),
            memory: self.memory,
            gyro_scale: self.gyro_scale,
            flow_demand: match self.flow {
                FlowArg::Always => None,
                FlowArg::OnDemand => Some(traction::flow_demand::FlowDemandConfig::default()),
            },
            expected_slip: base.expected_slip && !self.no_expected_slip,
            ..base
        }
    }
}

fn faults_long_help() -> String {
    kinds_help()
}

/// Arguments of `host-sim replay`.
#[derive(Debug, Args)]
#[command(
    about = "Replay a recorded ASL dataset through the estimator",
    long_about = "Reads an ASL/EuRoC dataset folder (mav0/imu0, wheel0, flow0, flowraw0, cam0, seg0, \
                  state_groundtruth_estimate0; any may be absent, the report names what is missing), runs it \
                  through the estimator and writes DIR/ekf.tum, DIR/vslam.tum, \
                  DIR/wheel_only.tum, DIR/report.json, DIR/trajectory.svg, DIR/errors.svg and DIR/report.html. With ground truth \
                  present it prints the error table; the summary (scale decisions, counts, \
                  rejections by reason, events) always. Sample values that parse but are bad \
                  (NaN, infinite, duplicated or out-of-order time stamps) reach the estimator, \
                  which rejects and counts them (--strict refuses them). Exit codes: 2 for bad \
                  input (syntax: the file and line are named); nothing is written then."
)]
pub struct ReplayArgs {
    /// The dataset folder (the one that contains `mav0/`).
    pub dataset: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Fewest inliers of a frame pair carried into the next frame before
    /// corners are detected afresh (default 100; 0: only when a pair fails;
    /// above 200: on every frame).
    #[arg(long, value_name = "N")]
    pub redetect_below: Option<usize>,
    /// Refuse (exit 2, naming file and line) sample values that parse but
    /// are bad: NaN, infinite, duplicated or out-of-order time stamps.
    /// Without it they reach the estimator, which rejects and counts them
    /// (report.json `counts`, the summary's `rejected by reason`).
    #[arg(long)]
    pub strict: bool,
    /// Wheel radii and track from FILE (`host-sim calibrate --out FILE`)
    /// in place of the dataset's `wheel0/sensor.yaml` geometry.
    #[arg(long, value_name = "FILE")]
    pub wheels: Option<PathBuf>,
    /// The scale pipeline's settings.
    #[command(flatten)]
    pub scale: ScaleArgs,
}

fn print_summary(r: &ReplayOutput, out: &std::path::Path) {
    print!("{}", summary_table(r));
    let missing = r.report["missing_sensors"]
        .as_array()
        .map(Vec::len)
        .unwrap_or(0);
    if missing > 0 {
        println!("missing sensors: {}", r.report["missing_sensors"]);
    }
    if r.ekf.is_empty() && !r.wheel_only.is_empty() {
        let why = if r.report["missing_sensors"]
            .as_array()
            .is_some_and(|m| m.iter().any(|s| s == "imu0"))
        {
            "no IMU: the EKF does not run"
        } else {
            "the EKF never started (it starts on 0.2 s of still IMU samples, or after 0.5 s \
             of driving at a near-constant speed)"
        };
        println!("note: {why}; the wheel-only trajectory is the estimate");
    }
    if let Some(labels) = r.report.get("labels") {
        for (k, v) in labels.as_object().into_iter().flatten() {
            match v {
                serde_json::Value::String(v) => println!("{k}: {v}"),
                serde_json::Value::Array(notes) => {
                    for n in notes.iter().filter_map(|n| n.as_str()) {
                        println!("note: {n}");
                    }
                }
                _ => {}
            }
        }
    }
    // Trajectories are written only when they have poses.
    let mut files: Vec<&str> = ["ekf.tum", "vslam.tum", "wheel_only.tum", "groundtruth.tum"]
        .into_iter()
        .filter(|f| out.join(f).is_file())
        .collect();
    files.extend(["report.json", "trajectory.svg", "errors.svg", "report.html"]);
    println!("wrote {}/{{{}}}", out.display(), files.join(","));
}

/// Runs `simulate`.
pub fn run_simulate_cmd(a: SimulateArgs) -> Result<(), CliError> {
    if !SCENARIOS.contains(&a.scenario.as_str()) {
        return Err(CliError::Usage(format!(
            "unknown scenario `{}`; known: {}",
            a.scenario,
            SCENARIOS.join(", ")
        )));
    }
    if a.drive == DriveArg::Waypoints {
        if a.chaos.is_some() || a.faults.is_some() {
            return Err(CliError::Usage(
                "--drive waypoints runs without --faults or --chaos".into(),
            ));
        }
        return run_waypoints_cmd(&a);
    }
    let progress = std::io::stderr().is_terminal();
    if let Some(chaos_seed) = a.chaos {
        if a.scenario != "office" && a.scenario != "shuttle" {
            return Err(CliError::Usage(
                "--chaos drives the shuttle scenario; leave --scenario out".into(),
            ));
        }
        if a.scale.memory.is_some() {
            return Err(CliError::Usage(
                "--chaos runs without an adverse-event memory; leave --memory out".into(),
            ));
        }
        if !(a.chaos_rate.is_finite() && a.chaos_rate > 0.0) {
            return Err(CliError::Usage(format!(
                "--chaos-rate {}: expected a positive number of faults a minute",
                a.chaos_rate
            )));
        }
        let config = ChaosConfig {
            seed: chaos_seed,
            duration_s: a.duration.unwrap_or(SHUTTLE_DEFAULT_S),
            per_minute: a.chaos_rate,
        };
        println!(
            "chaos {} on `shuttle` for {} s (seed {}) into {}",
            chaos_seed,
            config.duration_s,
            a.seed,
            a.out.display()
        );
        let run = run_chaos(config, a.seed, &a.out, progress)?;
        print_summary(&run.run.output, &a.out);
        print!("{}", run.summary());
        return if run.ok() {
            Ok(())
        } else {
            Err(CliError::NoResult(
                "a chaos check failed (report.json `chaos`)".into(),
            ))
        };
    }
    let mut scenario = scenario_for(&a.scenario, a.duration)?;
    if let Some([w, h]) = a.camera_size {
        scenario.camera = scenario.camera.resized(w, h).ok_or_else(|| {
            CliError::Usage(format!("camera size {w}x{h}: expected a size above 0"))
        })?;
    }
    if !(a.gyro_scale_error.is_finite() && a.gyro_scale_error.abs() < 0.5) {
        return Err(CliError::Usage(format!(
            "--gyro-scale-error {}: expected a fraction in (-0.5, 0.5)",
            a.gyro_scale_error
        )));
    }
    scenario.imu.gyro_scale_error = a.gyro_scale_error;
    let options = a.scale.options(ReplayOptions::default());
    println!(
        "simulating `{}` (seed {}) into {}",
        a.scenario,
        a.seed,
        a.out.display()
    );
    match a.faults.filter(|p| !p.is_empty()) {
        None => {
            let r = simulate_scenario_with(&scenario, a.seed, &a.out, progress, options)?;
            print_summary(&r, &a.out);
        }
        Some(plan) => {
            let run = simulate_faults_with(&scenario, a.seed, &a.out, progress, &plan, options)?;
            print_summary(&run.output, &a.out);
            println!("faults (injected, expected outcome, as expected, observed):");
            for r in &run.results {
                println!(
                    "  {:<24} {:>5}  {:<15} {:>5}  {:?}",
                    r.spec, r.injected, r.expected, r.as_expected, r.observed
                );
            }
        }
    }
    Ok(())
}

/// Runs `replay`.
pub fn run_replay_cmd(a: ReplayArgs) -> Result<(), CliError> {
    let options = a.scale.options(ReplayOptions {
        redetect_below: a.redetect_below,
        strict: a.strict,
        wheels: a
            .wheels
            .as_deref()
            .map(crate::calibrate::WheelGeometry::read)
            .transpose()?,
        ..ReplayOptions::default()
    });
    let r = run_replay_with(&a.dataset, &a.out, std::io::stderr().is_terminal(), options)?;
    print_summary(&r, &a.out);
    Ok(())
}
