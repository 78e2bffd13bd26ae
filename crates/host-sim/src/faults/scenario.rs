//! Motion faults: the drive itself changes. `stuck` and `lifted` add an
//! episode to the script; `bump` lays a cable across the floor where the
//! robot is at the start time (the office's legs run along x, so a cable is
//! a strip `x = const`). In a scenario whose pauses keep the path
//! ([`Scenario::pauses_keep_path`], the long shuttle drive) a stuck or
//! lifted window pauses the drive, which goes on afterwards; elsewhere the
//! window cuts its distance out of the path.

use super::kind::FaultKind;
use super::report::Injected;
use super::spec::FaultPlan;
use crate::sim::motion::integrate;
use crate::sim::scenario::Scenario;
use crate::sim::script::{Episode, EpisodeKind, LIFT_RAMP};
use crate::sim::world::Strip;
use traction::vslam_core::Stream;
use traction::vslam_core::Timestamp;

/// The cable a `bump` lays: 8 mm wide, 12 mm high (the office's cable).
pub const BUMP_CABLE: Strip = Strip {
    at: 0.0,
    width: 0.008,
    height: 0.012,
    threshold: false,
    span: crate::sim::world::ACROSS,
};

/// `sc` with the motion faults of `plan` applied.
pub fn apply(plan: &FaultPlan, sc: &Scenario) -> Scenario {
    let mut out = sc.clone();
    let mut motion: Vec<_> = plan
        .faults
        .iter()
        .filter(|f| {
            matches!(
                f.kind,
                FaultKind::Stuck | FaultKind::Lifted | FaultKind::Bump
            )
        })
        .collect();
    motion.sort_by(|a, b| a.start.total_cmp(&b.start));
    // Pauses first, in time order (each one's time is in the script with the
    // earlier pauses), then the cables where the robot is at their times.
    for f in motion.iter().filter(|f| f.kind != FaultKind::Bump) {
        let kind = if f.kind == FaultKind::Stuck {
            EpisodeKind::Stuck
        } else {
            EpisodeKind::Lifted
        };
        if sc.pauses_keep_path
            && let Some(paused) = out.script.with_pause(f.start, f.duration)
        {
            out.script = paused;
        }
        out.script.episodes.push(Episode {
            start: f.start,
            end: f.start + f.duration,
            kind,
        });
    }
    if motion.iter().any(|f| f.kind == FaultKind::Bump) {
        let path = if sc.pauses_keep_path {
            integrate(&out.world, &out.script, &out.robot)
        } else {
            integrate(&sc.world, &sc.script, &sc.robot)
        };
        for f in motion.iter().filter(|f| f.kind == FaultKind::Bump) {
            if let Some(step) = path.iter().find(|s| s.t_ns >= f.start_ns()) {
                // Just ahead of the wheels: the wheels meet it at the start time.
                let ahead = 0.03 * step.yaw.cos().signum();
                out.world.strips.push(Strip {
                    at: step.p[0] + ahead,
                    ..BUMP_CABLE
                });
            }
        }
    }
    out
}

/// Seconds of pause that `plan`'s stuck and lifted faults insert before `t`
/// (the shuttle's time `t` with faults is the fault-free run's time
/// `t - paused_before(t)`): zero unless the scenario's pauses keep the path.
pub fn paused_before(plan: &FaultPlan, sc: &Scenario, t: f64) -> f64 {
    if !sc.pauses_keep_path {
        return 0.0;
    }
    plan.faults
        .iter()
        .filter(|f| matches!(f.kind, FaultKind::Stuck | FaultKind::Lifted))
        .map(|f| (t - f.start).clamp(0.0, f.duration))
        .sum()
}

/// The samples a motion fault spoils, from the generated streams' time
/// stamps: the wheel samples of a `stuck` window, and of a `lifted` one
/// from half way up to half way down (the wheels turn, the robot does not:
/// they must be gated). The flow reports of a lifted robot are not judged:
/// out of focus they are either invalid (low quality) or valid zero motion,
/// which is true.
pub fn spoiled(plan: &FaultPlan, wheel: &[Timestamp]) -> Vec<Injected> {
    let mut out = Vec::new();
    for (i, f) in plan.faults.iter().enumerate() {
        let margin = match f.kind {
            FaultKind::Stuck => 0,
            FaultKind::Lifted => (0.5 * LIFT_RAMP * 1e9) as u64,
            _ => continue,
        };
        let (from, to) = (f.start_ns() + margin, f.end_ns().saturating_sub(margin));
        out.extend(
            wheel
                .iter()
                .filter(|t| t.0 >= from && t.0 < to)
                .map(|t| Injected {
                    fault: i,
                    stream: Stream::Wheel,
                    t: *t,
                    occurrence: 0,
                }),
        );
    }
    out
}
