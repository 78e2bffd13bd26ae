//! Matching the spoiled samples with the outcomes the replay logged, and
//! the `faults` section of `report.json`.
//!
//! A spoiled sample is identified by its stream, its time stamp and its
//! place among the samples of that stream with that time stamp, in the
//! order the estimator processed them (0 unless a duplicate or a zero-dt
//! sample shares the stamp): the estimator's ordering buffer keeps arrival
//! order between equal stamps.

use super::spec::FaultPlan;
use serde_json::{Value, json};
use std::collections::{BTreeMap, HashMap};
use traction::vslam_core::{Stream, Timestamp};

/// One spoiled sample (or failed read, frame, map) of the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Injected {
    /// Index of the fault in the plan.
    pub fault: usize,
    /// The stream it belongs to.
    pub stream: Stream,
    /// Its time stamp.
    pub t: Timestamp,
    /// Its place among the samples of the stream with this time stamp.
    pub occurrence: u32,
}

/// Everything injected in one run.
#[derive(Clone, Debug, Default)]
pub struct FaultLog {
    /// The plan.
    pub plan: FaultPlan,
    /// The spoiled samples.
    pub injected: Vec<Injected>,
    /// Samples removed (gaps), by fault index.
    pub dropped: BTreeMap<usize, u32>,
}

/// One fault's result in the run.
#[derive(Clone, Debug, PartialEq)]
pub struct FaultOutcome {
    /// The fault as written.
    pub spec: String,
    /// Samples spoiled.
    pub injected: u32,
    /// Samples removed by a gap.
    pub dropped: u32,
    /// The expected outcome's name.
    pub expected: &'static str,
    /// Spoiled samples whose outcome met the expectation.
    pub as_expected: u32,
    /// Observed outcomes of the spoiled samples, by name (`missing`: the
    /// replay never logged the sample).
    pub observed: BTreeMap<String, u32>,
    /// Last time stamp of a spoiled sample, or the end of the window, ns.
    pub window_end_ns: u64,
    /// Seconds after the fault's start of the first [`UNEXPECTED_LISTED`]
    /// spoiled samples whose outcome did not meet the expectation.
    pub unexpected_at_s: Vec<f64>,
}

/// How many unexpected samples a [`FaultOutcome`] lists by time.
pub const UNEXPECTED_LISTED: usize = 8;

/// Matches `log` with the replay's `outcomes` (processing order).
pub fn outcomes(
    log: &FaultLog,
    outcomes: &[(Stream, Timestamp, &'static str)],
) -> Vec<FaultOutcome> {
    let mut seen: HashMap<(Stream, Timestamp), Vec<&'static str>> = HashMap::new();
    for (s, t, o) in outcomes {
        seen.entry((*s, *t)).or_default().push(o);
    }
    log.plan
        .faults
        .iter()
        .enumerate()
        .map(|(i, spec)| {
            let expected = spec.kind.expected();
            let mut observed: BTreeMap<String, u32> = BTreeMap::new();
            let mut injected = 0;
            let mut as_expected = 0;
            let mut end = spec.end_ns();
            let mut unexpected_at_s = Vec::new();
            for inj in log.injected.iter().filter(|x| x.fault == i) {
                injected += 1;
                end = end.max(inj.t.0);
                let o = seen
                    .get(&(inj.stream, inj.t))
                    .and_then(|v| v.get(inj.occurrence as usize))
                    .copied()
                    .unwrap_or("missing");
                if expected.accepts(o) {
                    as_expected += 1;
                } else if unexpected_at_s.len() < UNEXPECTED_LISTED {
                    unexpected_at_s.push(inj.t.0 as f64 * 1e-9 - spec.start);
                }
                *observed.entry(o.to_string()).or_default() += 1;
            }
            FaultOutcome {
                spec: spec.to_string(),
                injected,
                dropped: log.dropped.get(&i).copied().unwrap_or(0),
                expected: expected.name(),
                as_expected,
                observed,
                window_end_ns: end,
                unexpected_at_s,
            }
        })
        .collect()
}

/// The `faults` section of `report.json`: the plan, then per fault its
/// kind, stream, stage, window, the samples spoiled (`injected`) and
/// removed (`dropped`), the `expected` outcome, how many met it
/// (`as_expected`), every outcome `observed` and when the first unexpected
/// ones came (`unexpected_at_s`, seconds after the start); and the totals
/// per kind.
pub fn faults_section(log: &FaultLog, results: &[FaultOutcome]) -> Value {
    let faults: Vec<Value> = log
        .plan
        .faults
        .iter()
        .zip(results)
        .map(|(spec, r)| {
            json!({
                "fault": r.spec,
                "kind": spec.kind.name(),
                "stream": spec.kind.target().name(),
                "stage": spec.kind.stage().name(),
                "start_s": spec.start,
                "window_end_s": r.window_end_ns as f64 * 1e-9,
                "injected": r.injected,
                "dropped": r.dropped,
                "expected": r.expected,
                "as_expected": r.as_expected,
                "observed": r.observed,
                "unexpected_at_s": r.unexpected_at_s,
            })
        })
        .collect();
    let mut by_kind: BTreeMap<String, (u32, u32, &'static str)> = BTreeMap::new();
    for (spec, r) in log.plan.faults.iter().zip(results) {
        let e = by_kind
            .entry(spec.kind.name())
            .or_insert((0, 0, r.expected));
        e.0 += r.injected;
        e.1 += r.as_expected;
    }
    let by_kind: serde_json::Map<String, Value> = by_kind
        .into_iter()
        .map(|(k, (n, ok, expected))| {
            (
                k,
                json!({"injected": n, "expected": expected, "as_expected": ok}),
            )
        })
        .collect();
    json!({
        "plan": log.plan.to_string(),
        "faults": faults,
        "by_kind": by_kind,
    })
}
