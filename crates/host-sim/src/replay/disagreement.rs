//! The report's `disagreement` section and summary table: each sensor's
//! checks against the filter's motion per camera frame pair
//! (`traction::disagreement`), agreed, disagreed, skipped by reason, and
//! the disagreements recorded in the adverse-event memory.

use serde_json::{Value, json};
use traction::estimator::Estimator;
use traction::vslam_core::adverse::SensorKind;
use traction::vslam_core::disagree::{SkipReason, Verdict};

/// The report's `disagreement` section.
pub fn report(est: &Estimator<'_>) -> Value {
    let check = est.disagreement();
    let sensors: serde_json::Map<String, Value> = SensorKind::ALL
        .iter()
        .map(|s| {
            let c = check.counts().of(*s);
            let skipped: serde_json::Map<String, Value> = SkipReason::ALL
                .iter()
                .map(|r| (r.name().to_string(), json!(c.skipped_for(*r))))
                .collect();
            (
                s.name().to_string(),
                json!({"agree": c.agree, "disagree": c.disagree, "skipped": skipped,
                       "recorded": c.recorded}),
            )
        })
        .collect();
    json!({"gate_probability": check.gates().probability, "sensors": sensors})
}

/// The sensors that disagreed on the latest frame pair, for the frame's record.
pub fn last_frame(est: &Estimator<'_>) -> Value {
    let Some(v) = est.disagreement().last() else {
        return Value::Null;
    };
    let names: Vec<&str> = SensorKind::ALL
        .iter()
        .zip(v.iter())
        .filter(|(_, v)| matches!(v, Verdict::Disagree(_)))
        .map(|(s, _)| s.name())
        .collect();
    json!(names)
}

/// The summary's table of the checks; empty when none was made.
pub fn summary(report: &Value) -> String {
    let Some(sensors) = report["disagreement"]["sensors"].as_object() else {
        return String::new();
    };
    let mut out = String::from(
        "disagreement with the fused motion per frame pair (agree / disagree / skipped / recorded events)\n",
    );
    for (name, c) in sensors {
        let skipped: u64 = c["skipped"]
            .as_object()
            .map(|m| m.values().filter_map(Value::as_u64).sum())
            .unwrap_or(0);
        out += &format!(
            "  {name:<8} {:>6} {:>6} {:>6} {:>6}\n",
            c["agree"], c["disagree"], skipped, c["recorded"]
        );
    }
    out
}
