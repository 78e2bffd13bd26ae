//! `host-sim simulate --chaos SEED --duration S`: the long shuttle drive
//! with faults of every kind drawn at random ([`draw`]), several at once at
//! times, and every invariant checked ([`judge`]):
//!
//! - at every IMU step (the replay's [`Health`](crate::replay::Health)):
//!   the state finite, the covariance symmetric positive definite (the
//!   pose clone's rows included), each
//!   stream's count equal to the samples that reached the estimator (every
//!   sample in exactly one count: fused, gated or rejected with a reason),
//!   no count going backwards;
//! - per fault: every spoiled sample ended in the outcome its kind expects
//!   ([`crate::faults`]), and the time until its stream was back in use;
//! - per cluster of overlapping faults: the EKF's error over the cluster at
//!   its end + 2 s within 1.2x the fault-free run's (2 cm floor), and the
//!   wheels and flow sensor fused again within 2 s of its end.
//!
//! The fault-free run of the same drive and seed is written to `OUT/free`;
//! the chaos run to `OUT` with a `chaos` section in `report.json`.

pub mod draw;
pub mod judge;

pub use draw::{ChaosConfig, draw};

use crate::error::CliError;
use crate::faults::scenario::paused_before;
use crate::faults::{FaultKind, FaultPlan};
use crate::plot::Scene;
use crate::plot::markers::slips;
use crate::replay::Health;
use crate::simulate::{FaultRun, scenario_for, simulate_faults};
use judge::{ClusterJudgement, Runs, back_in_use, distribution, judge};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::Path;

/// What a chaos run found.
pub struct ChaosRun {
    /// The configuration.
    pub config: ChaosConfig,
    /// The simulator's seed.
    pub seed: u64,
    /// The faults drawn.
    pub plan: FaultPlan,
    /// The chaos run.
    pub run: FaultRun,
    /// Per cluster of faults, the judgement.
    pub clusters: Vec<ClusterJudgement>,
    /// Per fault, seconds until its stream was fused again.
    pub back_in_use: Vec<Option<f64>>,
    /// Most faults active at one time.
    pub most_at_once: usize,
}

impl ChaosRun {
    /// The filter's health over the run.
    pub fn health(&self) -> Health {
        self.run.output.health
    }

    /// Faults whose spoiled samples did not all end as expected.
    pub fn unexpected(&self) -> Vec<usize> {
        self.run
            .results
            .iter()
            .enumerate()
            .filter(|(_, r)| r.as_expected != r.injected)
            .map(|(i, _)| i)
            .collect()
    }

    /// Clusters that did not recover.
    pub fn not_recovered(&self) -> Vec<&ClusterJudgement> {
        self.clusters.iter().filter(|c| !c.recovered()).collect()
    }

    /// Clusters after which the wheels or the flow sensor stayed out longer
    /// than 2 s.
    pub fn lockouts(&self) -> Vec<&ClusterJudgement> {
        self.clusters.iter().filter(|c| !c.no_lockout()).collect()
    }

    /// Whether every check held (the whole covariance, the pose clone's
    /// rows included, positive definite at every step too).
    pub fn ok(&self) -> bool {
        self.health().ok()
            && self.health().clone_not_spd == 0
            && self.unexpected().is_empty()
            && self.not_recovered().is_empty()
            && self.lockouts().is_empty()
    }

    /// The cluster with the largest error against its bound.
    pub fn worst(&self) -> Option<&ClusterJudgement> {
        self.clusters
            .iter()
            .max_by(|a, b| (a.faulted / a.bound()).total_cmp(&(b.faulted / b.bound())))
    }

    /// The command that replays cluster `c`'s faults alone.
    pub fn command_for(&self, c: &ClusterJudgement) -> String {
        let faults: Vec<String> = c
            .cluster
            .faults
            .iter()
            .filter_map(|&i| self.plan.faults.get(i))
            .map(ToString::to_string)
            .collect();
        format!(
            "host-sim simulate --scenario shuttle --duration {} --seed {} --faults {}",
            self.config.duration_s,
            self.seed,
            faults.join(",")
        )
    }

    /// Per kind: faults, faults with every sample as expected, and the
    /// back-in-use distribution `(median, p95, max)`.
    fn by_kind(&self) -> BTreeMap<String, (usize, usize, Vec<f64>)> {
        let mut m: BTreeMap<String, (usize, usize, Vec<f64>)> = BTreeMap::new();
        for (i, f) in self.plan.faults.iter().enumerate() {
            let e = m.entry(f.kind.name()).or_default();
            e.0 += 1;
            if self
                .run
                .results
                .get(i)
                .is_some_and(|r| r.as_expected == r.injected)
            {
                e.1 += 1;
            }
            if let Some(Some(s)) = self.back_in_use.get(i) {
                e.2.push(*s);
            }
        }
        m
    }

    /// The `chaos` section of `report.json`.
    pub fn section(&self) -> Value {
        let h = self.health();
        let kinds: serde_json::Map<String, Value> = self
            .by_kind()
            .into_iter()
            .map(|(k, (n, ok, t))| {
                let d = distribution(&t);
                (
                    k,
                    json!({"faults": n, "as_expected": ok,
                        "back_in_use_s": d.map(|(m, p, x)| json!({"median": m, "p95": p, "max": x}))}),
                )
            })
            .collect();
        let clusters: Vec<Value> = self
            .clusters
            .iter()
            .map(|c| {
                json!({"faults": c.cluster.faults, "start_s": c.cluster.start, "end_s": c.cluster.end,
                    "rpe_m": c.faulted, "rpe_free_m": c.free, "bound_m": c.bound(),
                    "recovered": c.recovered(), "lockout_s": c.lockout_s})
            })
            .collect();
        json!({
            "seed": self.config.seed,
            "duration_s": self.config.duration_s,
            "per_minute": self.config.per_minute,
            "faults": self.plan.faults.len(),
            "most_at_once": self.most_at_once,
            "health": {"imu_steps_checked": h.steps, "non_finite_steps": h.non_finite,
                "not_spd_steps": h.not_spd, "with_clone_not_spd_steps": h.clone_not_spd, "counts_unbalanced_steps": h.counts_unbalanced,
                "counts_backwards_steps": h.counts_backwards,
                "first_failed_s": h.first_failed_ns.map(|t| t as f64 * 1e-9)},
            "unexpected_outcomes": self.unexpected().iter().map(|&i| self.plan.faults[i].to_string()).collect::<Vec<_>>(),
            "by_kind": kinds,
            "clusters": clusters,
            "worst": self.worst().map(|c| json!({"rpe_m": c.faulted, "bound_m": c.bound(), "command": self.command_for(c)})),
            "ok": self.ok(),
        })
    }

    /// The summary printed after the run.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let h = self.health();
        let kinds = self.by_kind();
        s += &format!(
            "chaos seed {}: {} faults of {} kinds in {} s ({} a minute), {} clusters, up to {} at once\n",
            self.config.seed,
            self.plan.faults.len(),
            kinds.len(),
            self.config.duration_s,
            self.config.per_minute,
            self.clusters.len(),
            self.most_at_once
        );
        s += &format!(
            "every IMU step ({}): non-finite {}, covariance not SPD {} (with the pose clone's copy {}), counts unbalanced {}, counts backwards {}{}\n",
            h.steps,
            h.non_finite,
            h.not_spd,
            h.clone_not_spd,
            h.counts_unbalanced,
            h.counts_backwards,
            h.first_failed_ns
                .map(|t| format!(" (first at {:.3} s)", t as f64 * 1e-9))
                .unwrap_or_default()
        );
        let samples: u32 = self.run.results.iter().map(|r| r.injected).sum();
        s += &format!(
            "outcomes: {} of {} faults ended all their spoiled samples as expected ({samples} samples)\n",
            self.plan.faults.len() - self.unexpected().len(),
            self.plan.faults.len()
        );
        for &i in &self.unexpected() {
            let r = &self.run.results[i];
            let at: Vec<String> = r
                .unexpected_at_s
                .iter()
                .map(|t| format!("+{t:.3}"))
                .collect();
            s += &format!(
                "  UNEXPECTED {}: {} x {} observed {:?}, unexpected at {} s\n",
                r.spec,
                r.injected,
                r.expected,
                r.observed,
                at.join(" ")
            );
        }
        s += &format!(
            "recovered (error over the cluster at its end + 2 s within 1.2x fault-free, 2 cm floor): {} of {} clusters\n",
            self.clusters.len() - self.not_recovered().len(),
            self.clusters.len()
        );
        let longest = self
            .clusters
            .iter()
            .filter_map(|c| c.lockout_s)
            .fold(0.0f64, f64::max);
        s += &format!(
            "wheels and flow fused again after each cluster: longest {longest:.2} s (limit 2 s), {} over\n",
            self.lockouts().len()
        );
        s += "back in use after the fault, by kind: faults, as expected, median / p95 / max s\n";
        for (k, (n, ok, t)) in &kinds {
            let d = distribution(t)
                .map(|(m, p, x)| format!("{m:.2} / {p:.2} / {x:.2}"))
                .unwrap_or_else(|| "-".into());
            s += &format!("  {k:<18} {n:>4} {ok:>4}   {d}\n");
        }
        if let Some(w) = self.worst() {
            s += &format!(
                "worst cluster: error {:.3} m against a bound of {:.3} m ({:.0} %); alone:\n  {}\n",
                w.faulted,
                w.bound(),
                100.0 * w.faulted / w.bound(),
                self.command_for(w)
            );
        }
        s += if self.ok() {
            "chaos: every check held\n"
        } else {
            "chaos: CHECKS FAILED\n"
        };
        s
    }
}

/// Most faults of `plan` active at one time.
fn most_at_once(plan: &FaultPlan) -> usize {
    let mut edges: Vec<(f64, i32)> = plan
        .faults
        .iter()
        .flat_map(|f| [(f.start, 1), (f.start + draw::span(f), -1)])
        .collect();
    edges.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let (mut n, mut most) = (0i32, 0i32);
    for (_, d) in edges {
        n += d;
        most = most.max(n);
    }
    most as usize
}

/// Runs the fault-free shuttle into `out/free` and the chaos run into
/// `out`, and judges it.
pub fn run_chaos(
    config: ChaosConfig,
    seed: u64,
    out: &Path,
    progress: bool,
) -> Result<ChaosRun, CliError> {
    let sc = scenario_for("shuttle", Some(config.duration_s))?;
    let plan = draw(&config, &sc);
    let free = simulate_faults(&sc, seed, &out.join("free"), progress, &FaultPlan::none())?;
    let run = simulate_faults(&sc, seed, out, progress, &plan)?;
    let scene = Scene::read(&out.join("dataset"))?.unwrap_or_default();
    let slip_windows = slips(&scene);
    let clusters = judge(
        &plan,
        &Runs {
            faulted: &run.output.ekf,
            faulted_truth: &run.truth,
            outcomes: &run.output.outcomes,
            free: &free.output.ekf,
            free_truth: &free.truth,
            slips: &slip_windows,
        },
        |t| t - paused_before(&plan, &sc, t),
    );
    let back = plan
        .faults
        .iter()
        .map(|f| {
            if f.kind == FaultKind::Bump {
                Some(0.0)
            } else {
                back_in_use(f, &run.output.outcomes)
            }
        })
        .collect();
    let chaos = ChaosRun {
        config,
        seed,
        most_at_once: most_at_once(&plan),
        plan,
        run,
        clusters,
        back_in_use: back,
    };
    let p = out.join("report.json");
    let mut report: Value = serde_json::from_str(
        &std::fs::read_to_string(&p)
            .map_err(|e| CliError::file(&p, format!("cannot read: {e}")))?,
    )
    .map_err(|e| CliError::file(&p, e.to_string()))?;
    report["chaos"] = chaos.section();
    let text =
        serde_json::to_string_pretty(&report).map_err(|e| CliError::file(&p, e.to_string()))?;
    std::fs::write(&p, text).map_err(|e| CliError::file(&p, format!("cannot write: {e}")))?;
    Ok(chaos)
}
