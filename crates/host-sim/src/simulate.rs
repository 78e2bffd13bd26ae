//! `host-sim simulate`: a scenario end to end. Generates the sensor log of a
//! simulated run as an ASL dataset in `OUT/dataset`, replays it through the
//! estimator exactly as a recorded log would be, and writes the estimates,
//! the report and the plot into `OUT`.
//!
//! With a fault list (`--faults`, [`crate::faults`]) the run is spoiled as
//! the list says, and `report.json` gets a `faults` section.

use crate::asl::{GroundTruth, read_dataset, write_dataset};
use crate::error::CliError;
use crate::faults::report::{FaultLog, FaultOutcome, Injected, faults_section, outcomes};
use crate::faults::{FailedRead, FaultPlan, Stage, Stream, inject};
use crate::plot::Scene;
use crate::progress::Progress;
use crate::replay::{
    Feed, FlowSource, ReplayOptions, ReplayOutput, replay_feed, run_replay_with, write_outputs,
};
use crate::sim::scenario::{SCENARIOS, Scenario, generate_with};
use std::collections::HashMap;
use std::path::Path;
use traction::reorder::Event;
use traction::vslam_core::Timestamp;

fn scenario(name: &str) -> Result<Scenario, CliError> {
    Scenario::by_name(name).ok_or_else(|| {
        CliError::Usage(format!(
            "unknown scenario `{name}`; known: {}",
            SCENARIOS.join(", ")
        ))
    })
}

fn clear(dataset: &Path) -> Result<(), CliError> {
    if dataset.exists() {
        std::fs::remove_dir_all(dataset)
            .map_err(|e| CliError::file(dataset, format!("cannot clear the old dataset: {e}")))?;
    }
    Ok(())
}

/// The scenario called `name`, run for `duration` seconds when given
/// ([`Scenario::with_duration`]).
pub fn scenario_for(name: &str, duration: Option<f64>) -> Result<Scenario, CliError> {
    let sc = scenario(name)?;
    match duration {
        None => Ok(sc),
        Some(d) if d.is_finite() && d > 0.0 && d <= 86_400.0 => Ok(sc.with_duration(d)),
        Some(d) => Err(CliError::Usage(format!(
            "duration {d} s: expected a number of seconds in (0, 86400]"
        ))),
    }
}

/// With `--flow-source frames`, the flow sensor's raw frames of the run
/// ([`crate::sim::flow_frames::record`]) join the log as `flowraw0`.
fn record_flow_frames(
    sc: &Scenario,
    truth: &[crate::sim::motion::TruthStep],
    seed: u64,
    dataset: &Path,
    options: &ReplayOptions,
    ds: &mut crate::asl::Dataset,
) -> Result<(), CliError> {
    if options.flow_source == Some(FlowSource::Frames) {
        ds.flowraw = Some(crate::sim::flow_frames::record(
            &sc.world, &sc.flow, truth, seed, dataset,
        )?);
    }
    Ok(())
}

/// Runs scenario `name` with `seed` into `out`.
pub fn run_simulate(
    name: &str,
    seed: u64,
    out: &Path,
    progress: bool,
) -> Result<ReplayOutput, CliError> {
    simulate_scenario(&scenario(name)?, seed, out, progress)
}

/// Runs scenario `sc` with `seed` into `out`.
pub fn simulate_scenario(
    scenario: &Scenario,
    seed: u64,
    out: &Path,
    progress: bool,
) -> Result<ReplayOutput, CliError> {
    simulate_scenario_with(scenario, seed, out, progress, ReplayOptions::default())
}

/// [`simulate_scenario`], the replay run as `options` say.
pub fn simulate_scenario_with(
    scenario: &Scenario,
    seed: u64,
    out: &Path,
    progress: bool,
    options: ReplayOptions,
) -> Result<ReplayOutput, CliError> {
    let dataset = out.join("dataset");
    clear(&dataset)?;
    let (mut ds, truth, _) = generate_with(
        scenario,
        seed,
        &dataset,
        &FaultPlan::none(),
        &Progress::new(progress),
    )?;
    record_flow_frames(scenario, &truth, seed, &dataset, &options, &mut ds)?;
    write_dataset(&dataset, &ds)?;
    Scene::of(scenario).write(&dataset)?;
    run_replay_with(&dataset, out, progress, options)
}

/// A run with faults: the replay, what was injected and what became of it.
pub struct FaultRun {
    /// The replay (its report has the `faults` section).
    pub output: ReplayOutput,
    /// What was injected.
    pub log: FaultLog,
    /// Per fault of the plan, what became of its samples.
    pub results: Vec<FaultOutcome>,
    /// The ground truth of the run.
    pub truth: Vec<GroundTruth>,
}

/// Runs scenario `name` with `seed` and the faults of `plan` into `out`
/// (an empty plan is [`run_simulate`]).
pub fn run_simulate_faults(
    name: &str,
    seed: u64,
    out: &Path,
    progress: bool,
    plan: &FaultPlan,
) -> Result<FaultRun, CliError> {
    simulate_faults(&scenario(name)?, seed, out, progress, plan)
}

/// Runs scenario `sc` with `seed` and the faults of `plan` into `out`: the
/// motion faults change the drive, chip and vision faults spoil the
/// generation, value and gap faults the samples before the log is written;
/// the log is read back and the stream faults spoil what reaches the
/// estimator (module docs of [`crate::faults`]).
pub fn simulate_faults(
    sc: &Scenario,
    seed: u64,
    out: &Path,
    progress: bool,
    plan: &FaultPlan,
) -> Result<FaultRun, CliError> {
    simulate_faults_with(sc, seed, out, progress, plan, ReplayOptions::default())
}

/// [`simulate_faults`], the replay run as `options` say.
pub fn simulate_faults_with(
    sc: &Scenario,
    seed: u64,
    out: &Path,
    progress: bool,
    plan: &FaultPlan,
    options: ReplayOptions,
) -> Result<FaultRun, CliError> {
    let dataset = out.join("dataset");
    clear(&dataset)?;
    let sc = crate::faults::scenario::apply(plan, sc);
    let (mut ds, truth, generated) =
        generate_with(&sc, seed, &dataset, plan, &Progress::new(progress))?;
    record_flow_frames(&sc, &truth, seed, &dataset, &options, &mut ds)?;
    let mut log = FaultLog {
        plan: plan.clone(),
        injected: generated.injected,
        dropped: Default::default(),
    };

    // Values and gaps, into the log.
    let mut log_stage = |injected: &mut Vec<Injected>,
                         stream,
                         spoiled: &[crate::faults::SpoiledSample],
                         dropped: Vec<(usize, u32)>| {
        injected.extend(spoiled.iter().map(|s| Injected {
            fault: s.fault,
            stream,
            t: s.t,
            occurrence: 0,
        }));
        for (i, n) in dropped {
            *log.dropped.entry(i).or_default() += n;
        }
    };
    let mut injected = Vec::new();
    if let Some((_, v)) = ds.imu.as_mut() {
        let (d, s, x) = inject(v, plan, Stage::Log);
        *v = d.into_iter().map(|d| d.sample).collect();
        log_stage(&mut injected, Stream::Imu, &s, x);
    }
    if let Some((_, v)) = ds.wheel.as_mut() {
        let (d, s, x) = inject(v, plan, Stage::Log);
        *v = d.into_iter().map(|d| d.sample).collect();
        log_stage(&mut injected, Stream::Wheel, &s, x);
    }
    if let Some((_, v)) = ds.flow.as_mut() {
        let (d, s, x) = inject(v, plan, Stage::Log);
        *v = d.into_iter().map(|d| d.sample).collect();
        log_stage(&mut injected, Stream::Flow, &s, x);
    }
    log.injected.extend(injected);
    let wheel_times: Vec<Timestamp> = ds
        .wheel
        .as_ref()
        .map(|(_, v)| v.iter().map(|s| s.t).collect())
        .unwrap_or_default();
    log.injected
        .extend(crate::faults::scenario::spoiled(plan, &wheel_times));
    // The drivers' failed reads, as a robot's recorder logs them.
    ds.failed = generated.failed.iter().map(FailedRead::logged).collect();
    write_dataset(&dataset, &ds)?;
    let scene = Scene::of(&sc);
    scene.write(&dataset)?;

    // The log as recorded, then the stream faults on its way to the estimator.
    let ds = read_dataset(&dataset)?;
    let mut feed = Feed {
        samples: Vec::new(),
        failed: generated.failed,
    };
    for f in &feed.failed {
        log.injected.push(Injected {
            fault: f.fault,
            stream: f.stream,
            t: f.t,
            occurrence: 0,
        });
    }
    let mut stream_stage = |stream: Stream,
                            deliveries: Vec<(Timestamp, Timestamp, Event)>,
                            spoiled: &[crate::faults::SpoiledSample]| {
        // Processing order: by arrival, stably; a sample's occurrence is its
        // place among the deliveries with the same time stamp.
        let mut order: Vec<usize> = (0..deliveries.len()).collect();
        order.sort_by_key(|&i| deliveries[i].0);
        let mut occurrence = vec![0u32; deliveries.len()];
        let mut per_t: HashMap<Timestamp, u32> = HashMap::new();
        for &i in &order {
            let n = per_t.entry(deliveries[i].1).or_default();
            occurrence[i] = *n;
            *n += 1;
        }
        for s in spoiled {
            log.injected.push(Injected {
                fault: s.fault,
                stream,
                t: s.t,
                occurrence: occurrence[s.delivery],
            });
        }
        feed.samples
            .extend(deliveries.into_iter().map(|(a, _, e)| (a, e)));
    };
    if let Some((_, v)) = &ds.imu {
        let (d, s, _) = inject(v, plan, Stage::Stream);
        let d = d
            .into_iter()
            .map(|d| (d.arrival, d.sample.t, Event::Imu(d.sample)))
            .collect();
        stream_stage(Stream::Imu, d, &s);
    }
    if let Some((_, v)) = &ds.wheel {
        let (d, s, _) = inject(v, plan, Stage::Stream);
        let d = d
            .into_iter()
            .map(|d| (d.arrival, d.sample.t, Event::Wheel(d.sample)))
            .collect();
        stream_stage(Stream::Wheel, d, &s);
    }
    if let Some((_, v)) = &ds.flow {
        let (d, s, _) = inject(v, plan, Stage::Stream);
        let d = d
            .into_iter()
            .map(|d| (d.arrival, d.sample.t, Event::Flow(d.sample)))
            .collect();
        stream_stage(Stream::Flow, d, &s);
    }

    let mut output = replay_feed(&ds, &dataset, progress, options, Some(&feed))?;
    let results = outcomes(&log, &output.outcomes);
    output.report["faults"] = faults_section(&log, &results);
    let h = output.health;
    output.report["faults"]["health"] = serde_json::json!({
        "imu_steps_checked": h.steps, "non_finite_steps": h.non_finite, "not_spd_steps": h.not_spd,
        "with_clone_not_spd_steps": h.clone_not_spd,
        "counts_unbalanced_steps": h.counts_unbalanced, "counts_backwards_steps": h.counts_backwards,
        "first_failed_s": h.first_failed_ns.map(|t| t as f64 * 1e-9),
    });
    let truth = ds.groundtruth.clone().unwrap_or_default();
    write_outputs(out, &output, Some(&truth), Some(&scene))?;
    Ok(FaultRun {
        output,
        log,
        results,
        truth,
    })
}
