//! Motion faults: the drive itself changes. `stuck` and `lifted` add an
//! episode to the script; `bump` lays a cable across the floor where the
//! fault-free robot is at the start time (the office's first leg runs
//! along x, so a cable is a strip `x = const`).

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
};

/// `sc` with the motion faults of `plan` applied.
pub fn apply(plan: &FaultPlan, sc: &Scenario) -> Scenario {
    let mut out = sc.clone();
    let free = plan
        .faults
        .iter()
        .any(|f| f.kind == FaultKind::Bump)
        .then(|| integrate(&sc.world, &sc.script, &sc.robot));
    for f in &plan.faults {
        let kind = match f.kind {
            FaultKind::Stuck => EpisodeKind::Stuck,
            FaultKind::Lifted => EpisodeKind::Lifted,
            FaultKind::Bump => {
                if let Some(step) = free
                    .as_ref()
                    .and_then(|t| t.iter().find(|s| s.t_ns >= f.start_ns()))
                {
                    // Just ahead of the wheels: the wheels meet it at the start time.
                    out.world.strips.push(Strip {
                        at: step.p[0] + 0.03,
                        ..BUMP_CABLE
                    });
                }
                continue;
            }
            _ => continue,
        };
        out.script.episodes.push(Episode {
            start: f.start,
            end: f.start + f.duration,
            kind,
        });
    }
    out
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
