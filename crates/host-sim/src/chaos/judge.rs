//! Judging a chaos run against the fault-free run of the same drive.
//!
//! **Clusters.** Faults whose windows, each extended by
//! [`RECOVERY_S`], overlap form one cluster: the time its last fault ends
//! plus [`RECOVERY_S`] is then free of faults, and that is when the cluster
//! is judged.
//!
//! **Error.** The relative pose error (RPE) of the EKF over the cluster:
//! the estimate's planar motion from the cluster's start to its judgement
//! time, rotated by the heading error at the start, against the truth's
//! motion (the estimate anchored to the truth at the cluster's start, as
//! `evo_rpe` does). An hour of faults leaves an absolute error the
//! fault-free run does not have (position and heading are not observable
//! without the camera in the filter), so the absolute error at a fault's
//! end would judge every earlier fault again; the RPE judges this one. The
//! fault-free run is measured over the same part of the drive (its times
//! moved by the pauses the stuck and lifted faults inserted before,
//! [`crate::faults::scenario::paused_before`]). A cluster recovered when
//! `rpe_fault <= RATIO * max(rpe_free, FLOOR_M)` (the single-fault
//! criterion of [`crate::faults::recovery`], 1.2 and 2 cm).
//!
//! **Back in use.** For each fault, the time from the end of its window to
//! the first sample of its stream fused again (a motion fault's stream is
//! the wheels'); the distribution of these per kind is the recovery-time
//! report. **Lock-out:** after each cluster's judgement time is fault-free,
//! the wheels and the flow sensor must each be fused again within
//! [`RECOVERY_S`] of the cluster's end, unless the drive's own slip
//! episode gates the wheels then (measured from the episode's end).

use crate::asl::GroundTruth;
use crate::faults::recovery::{FLOOR_M, RATIO, RECOVERY_S};
use crate::faults::{FaultKind, FaultPlan, FaultSpec, Stream};
use crate::plot::track::{self, Planar};
use crate::replay::Outcomes;
use crate::tum::TumPose;

use super::draw::span;

/// A cluster of faults judged together.
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    /// Indices of its faults in the plan.
    pub faults: Vec<usize>,
    /// Start of the first, seconds.
    pub start: f64,
    /// End of the last, seconds.
    pub end: f64,
}

/// The clusters of `plan` (faults sorted by start time).
pub fn clusters(plan: &FaultPlan) -> Vec<Cluster> {
    let mut order: Vec<usize> = (0..plan.faults.len()).collect();
    order.sort_by(|&a, &b| plan.faults[a].start.total_cmp(&plan.faults[b].start));
    let mut out: Vec<Cluster> = Vec::new();
    for i in order {
        let f = &plan.faults[i];
        let end = f.start + span(f);
        match out.last_mut() {
            Some(c) if f.start < c.end + RECOVERY_S => {
                c.faults.push(i);
                c.end = c.end.max(end);
            }
            _ => out.push(Cluster {
                faults: vec![i],
                start: f.start,
                end,
            }),
        }
    }
    out
}

/// The relative pose error of `est` against `truth` over `[t0, t1]`
/// seconds (module docs); `None` without poses there.
pub fn rpe(est: &[Planar], truth: &[Planar], t0: f64, t1: f64) -> Option<f64> {
    let last_at = |t: f64| {
        let i = est.partition_point(|p| p.t <= t);
        est.get(i.checked_sub(1)?).copied()
    };
    let (e0, e1) = (last_at(t0)?, last_at(t1)?);
    let (g0, g1) = (track::at(truth, e0.t)?, track::at(truth, e1.t)?);
    let rot = g0.yaw - e0.yaw;
    let (dx, dy) = (e1.x - e0.x, e1.y - e0.y);
    let (ex, ey) = (
        rot.cos() * dx - rot.sin() * dy,
        rot.sin() * dx + rot.cos() * dy,
    );
    Some((ex - (g1.x - g0.x)).hypot(ey - (g1.y - g0.y)))
}

/// One cluster's judgement.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterJudgement {
    /// The cluster.
    pub cluster: Cluster,
    /// RPE of the chaos run over the cluster, metres.
    pub faulted: f64,
    /// RPE of the fault-free run over the same part of the drive, metres.
    pub free: f64,
    /// Longest time after the cluster's end until the wheels and the flow
    /// sensor were both fused again, seconds (`None`: not within the run).
    pub lockout_s: Option<f64>,
}

impl ClusterJudgement {
    /// `RATIO * max(free, FLOOR_M)`.
    pub fn bound(&self) -> f64 {
        RATIO * self.free.max(FLOOR_M)
    }

    /// Whether the error stayed within the bound.
    pub fn recovered(&self) -> bool {
        self.faulted <= self.bound()
    }

    /// Whether the wheels and flow were back within [`RECOVERY_S`].
    pub fn no_lockout(&self) -> bool {
        self.lockout_s.is_some_and(|s| s <= RECOVERY_S)
    }
}

/// First time (s) at or after `t` a sample of `stream` was fused.
fn first_fused(outcomes: &Outcomes, stream: Stream, t: f64) -> Option<f64> {
    outcomes
        .iter()
        .filter(|(s, ts, o)| *s == stream && *o == "fused" && ts.0 as f64 * 1e-9 >= t)
        .map(|(_, ts, _)| ts.0 as f64 * 1e-9)
        .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.min(x))))
}

/// The stream whose use tells that a fault of `kind` is over.
pub fn stream_of(kind: FaultKind) -> Stream {
    kind.stream().unwrap_or(Stream::Wheel)
}

/// Inputs of a judgement: both runs' EKF trajectories and truths.
pub struct Runs<'a> {
    /// The chaos run's EKF.
    pub faulted: &'a [TumPose],
    /// Its truth.
    pub faulted_truth: &'a [GroundTruth],
    /// Its outcomes in processing order.
    pub outcomes: &'a Outcomes,
    /// The fault-free run's EKF.
    pub free: &'a [TumPose],
    /// Its truth.
    pub free_truth: &'a [GroundTruth],
    /// Slip episodes of the chaos run's drive, `(start, end)` seconds.
    pub slips: &'a [(f64, f64)],
}

/// Judges every cluster; `to_free(t)` maps a chaos-run time to the
/// fault-free run's.
pub fn judge(
    plan: &FaultPlan,
    runs: &Runs<'_>,
    to_free: impl Fn(f64) -> f64,
) -> Vec<ClusterJudgement> {
    let (ef, tf) = (
        track::from_tum(runs.faulted),
        track::from_truth(runs.faulted_truth),
    );
    let (e0, t0) = (
        track::from_tum(runs.free),
        track::from_truth(runs.free_truth),
    );
    clusters(plan)
        .into_iter()
        .filter_map(|c| {
            let at = c.end + RECOVERY_S;
            let faulted = rpe(&ef, &tf, c.start, at)?;
            let free = rpe(&e0, &t0, to_free(c.start), to_free(at))?;
            // The drive's own slip gates the wheels: lock-out counts from its end.
            let from = runs
                .slips
                .iter()
                .filter(|(a, b)| *a < c.end + RECOVERY_S && *b > c.end)
                .map(|(_, b)| *b)
                .fold(c.end, f64::max);
            let lockout_s = [Stream::Wheel, Stream::Flow]
                .iter()
                .map(|s| first_fused(runs.outcomes, *s, from).map(|t| t - from))
                .try_fold(0.0f64, |m, x| x.map(|x| m.max(x)));
            Some(ClusterJudgement {
                cluster: c,
                faulted,
                free,
                lockout_s,
            })
        })
        .collect()
}

/// Seconds from the end of fault `f`'s window until its stream was fused
/// again (zero when it was fused right away; `None` when never again).
pub fn back_in_use(f: &FaultSpec, outcomes: &Outcomes) -> Option<f64> {
    let end = f.start + span(f);
    first_fused(outcomes, stream_of(f.kind), end).map(|t| (t - end).max(0.0))
}

/// `(median, p95, max)` of `v` (nearest rank).
pub fn distribution(v: &[f64]) -> Option<(f64, f64, f64)> {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return None;
    }
    s.sort_by(f64::total_cmp);
    let rank = |q: f64| s[((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1];
    Some((rank(0.5), rank(0.95), s[s.len() - 1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::faults::Sensor;

    fn p(t: f64, x: f64, y: f64, yaw: f64) -> Planar {
        Planar { t, x, y, yaw }
    }

    #[test]
    fn rpe_forgets_the_error_before_the_interval() {
        let truth: Vec<Planar> = (0..=100)
            .map(|i| p(i as f64 * 0.1, i as f64 * 0.1, 0.0, 0.0))
            .collect();
        // Off by 1 m and 90 degrees from the start, but moving right.
        let est: Vec<Planar> = (0..=100)
            .map(|i| {
                p(
                    i as f64 * 0.1,
                    1.0,
                    2.0 + i as f64 * 0.1,
                    std::f64::consts::FRAC_PI_2,
                )
            })
            .collect();
        assert!(rpe(&est, &truth, 2.0, 8.0).unwrap() < 1e-9);
        // Stretched by 10 %: the error grows with the interval only.
        let long: Vec<Planar> = truth.iter().map(|g| p(g.t, 1.1 * g.x, 0.0, 0.0)).collect();
        let r = rpe(&long, &truth, 2.0, 8.0).unwrap();
        assert!((r - 0.6).abs() < 1e-9, "{r}");
        assert!(
            rpe(&long, &truth, -5.0, 1.0).is_none(),
            "no pose before the start"
        );
    }

    #[test]
    fn clusters_join_faults_within_the_recovery_time() {
        let plan = FaultPlan {
            faults: vec![
                FaultSpec::new(FaultKind::CamBlur, 10.0).times(1),
                FaultSpec::new(FaultKind::Gap(Sensor::Wheel), 11.0).lasting(0.5),
                FaultSpec::new(FaultKind::FlowSpi, 30.0),
            ],
        };
        let c = clusters(&plan);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].faults, vec![0, 1]);
        assert!((c[0].end - 11.5).abs() < 1e-9);
        assert_eq!(c[1].faults, vec![2]);
    }

    #[test]
    fn distributions_by_nearest_rank() {
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        assert_eq!(distribution(&v), Some((10.0, 19.0, 20.0)));
        assert_eq!(distribution(&[]), None);
        assert_eq!(distribution(&[f64::NAN, 2.0]), Some((2.0, 2.0, 2.0)));
    }
}
