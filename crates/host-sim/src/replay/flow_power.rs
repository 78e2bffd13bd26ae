//! The flow sensor's power during a replay: always on, or on demand
//! ([`traction::flow_demand::FlowDemand`]) with the policy stepped after
//! every processed sample. On demand, a flow report reaches the estimator
//! only while the sensor is on and its power-up has run: after a wake, the
//! reports before the wake time plus [`wake_ns`] are dropped (the chip was
//! resetting and loading its configuration table). Reports from while the
//! sensor was off are dropped too; neither is a read, so neither is counted
//! by the estimator. report.json `flow_power` says how long it was on.

use serde_json::{Value, json};
use traction::estimator::{Estimator, Processed};
use traction::flow_demand::{Command, Cue, FlowDemand, FlowDemandConfig};
use traction::flow_sensor::Variant;
use traction::flow_sensor::config::ConfigStep;
use traction::flow_sensor::registers::RESET_WAIT_MS;
use traction::vslam_core::Timestamp;

/// Time a wake takes before the first report, ns: the power-up reset wait
/// and the waits of `variant`'s configuration table (bus time not included).
pub fn wake_ns(variant: Variant) -> u64 {
    let table_ms: u64 = variant
        .configuration()
        .iter()
        .map(|s| match s {
            ConfigStep::DelayMs(ms) => u64::from(*ms),
            ConfigStep::Write { .. } => 0,
        })
        .sum();
    (u64::from(RESET_WAIT_MS) + table_ms) * 1_000_000
}

/// The flow sensor's power over one replay.
#[derive(Clone, Debug, Default)]
pub(super) struct FlowPower {
    demand: Option<FlowDemand>,
    wake_ns: u64,
    ready_at: Option<Timestamp>,
    /// Reports dropped while the sensor was off.
    off: u64,
    /// Reports dropped while a wake was under way.
    waking: u64,
    /// Reports passed to the estimator.
    passed: u64,
    first: Option<Timestamp>,
    last: Option<Timestamp>,
}

impl FlowPower {
    /// Always on (`None`) or on demand.
    pub fn new(config: Option<FlowDemandConfig>) -> Result<Self, String> {
        let demand = config
            .map(FlowDemand::new)
            .transpose()
            .map_err(|e| e.to_string())?;
        Ok(FlowPower {
            demand,
            wake_ns: wake_ns(Variant::Paa5100je),
            ..FlowPower::default()
        })
    }

    /// Whether the report taken at `t` reaches the estimator.
    pub fn pass(&mut self, t: Timestamp) -> bool {
        self.first.get_or_insert(t);
        self.last = Some(self.last.map_or(t, |l| l.max(t)));
        let pass = match &self.demand {
            None => true,
            Some(d) if !d.is_on() => {
                self.off += 1;
                false
            }
            Some(_) if self.ready_at.is_some_and(|r| t < r) => {
                self.waking += 1;
                false
            }
            Some(_) => true,
        };
        self.passed += u64::from(pass);
        pass
    }

    /// Steps the policy after `p` was processed.
    pub fn observe(&mut self, est: &Estimator<'_>, p: &Processed) {
        let Some(d) = self.demand.as_mut() else {
            return;
        };
        if let Some(Command::Wake(_)) = d.observe(est, p) {
            self.ready_at = Some(Timestamp(p.t().0.saturating_add(self.wake_ns)));
        }
    }

    /// The report section: mode, seconds on, wakes, reports dropped.
    pub fn to_json(&self) -> Value {
        let span = |a: Option<Timestamp>, b: Option<Timestamp>| {
            a.zip(b)
                .and_then(|(a, b)| b.nanos_since(a))
                .map_or(0.0, |ns| ns as f64 * 1e-9)
        };
        let flow_s = span(self.first, self.last);
        match &self.demand {
            None => json!({
                "mode": "always",
                "on_s": flow_s,
                "flow_s": flow_s,
                "wakes": 0,
                "reports_passed": self.passed,
                "reports_off": 0,
                "reports_waking": 0,
            }),
            Some(d) => {
                let on = d.on_seconds(self.last.unwrap_or(Timestamp(0)));
                let cues: serde_json::Map<String, Value> = Cue::ALL
                    .iter()
                    .map(|c| {
                        (
                            c.name().to_string(),
                            json!(d.cue_counts().get(*c as usize).copied().unwrap_or(0)),
                        )
                    })
                    .collect();
                let c = d.config();
                json!({
                    "mode": "on-demand",
                    "on_s": on,
                    "flow_s": flow_s,
                    "on_fraction": if flow_s > 0.0 { on / flow_s } else { 0.0 },
                    "wakes": d.wakes(),
                    "wake_ms": self.wake_ns as f64 * 1e-6,
                    "reports_passed": self.passed,
                    "reports_off": self.off,
                    "reports_waking": self.waking,
                    "cue_updates": cues,
                    "config": {
                        "low_grip": c.low_grip, "lookahead_s": c.lookahead_s,
                        "remembered_events": c.remembered_events,
                        "innovation_sigmas": c.innovation_sigmas, "quiet_s": c.quiet_s,
                    },
                })
            }
        }
    }
}
