//! Replay of a recorded ASL dataset through `traction::Estimator`, and the
//! files it writes: `ekf.tum`, `vslam.tum`, `wheel_only.tum`,
//! `groundtruth.tum` (poses of the body frame B, mid-axle on the floor),
//! `report.json`,
//! `trajectory.svg`, `errors.svg`, `report.html` ([`crate::plot`]). All
//! estimation happens in the no_std crates; this module only reads, feeds, collects and writes: `config.rs` builds the
//! configuration from the dataset's metadata, `run.rs` is the loop through
//! the estimator, `flow_power.rs` the flow sensor's power in it, `report.rs` writes the report and
//! the summary, `memory.rs` keeps the adverse-event memory across runs (`--memory FILE`).

mod aids;
mod config;
pub mod disagreement;
pub mod flow_power;
pub mod memory;
mod report;
mod run;

pub(crate) use config::{estimator_config, frontend_config};
pub use config::{imu_rate_hz, robot_description, robot_description_with};
pub use report::{summary_table, write_outputs};
pub(crate) use run::FrontEndMemory;

use crate::asl::Dataset;
use crate::error::CliError;
use crate::faults::{FailedRead, Stream};
use crate::metrics::TrajectoryError;
use crate::tum::TumPose;
use serde_json::Value;
use std::path::{Path, PathBuf};
use traction::reorder::Event;
use traction::vslam_core::scale::{ComposeScale, Distance, SelectionMethod};
use traction::vslam_core::{Reject, Timestamp};

/// What a replay produced.
pub struct ReplayOutput {
    /// The estimator's trajectory of B ([`traction::Estimator::estimate`]).
    pub ekf: Vec<TumPose>,
    /// The estimate's yaw rate, robot frame, rad/s, with each pose of
    /// [`ReplayOutput::ekf`]: the gyro's rate corrected by the filter's
    /// bias and scale factor.
    pub yaw_rate: Vec<f32>,
    /// Camera poses composed with the metric scale, moved to B.
    pub vslam: Vec<TumPose>,
    /// Wheel odometry alone (B's origin, mid-axle on the floor).
    pub wheel_only: Vec<TumPose>,
    /// The report.
    pub report: Value,
    /// Errors against ground truth, when present: `(name, error)`.
    pub errors: Vec<(&'static str, TrajectoryError)>,
    /// The outcome of every sample, frame, map and failed read, in
    /// processing order: stream, time stamp, `fused` (`first` for a first
    /// camera frame) or the reason name.
    pub outcomes: Outcomes,
    /// The filter's health after every IMU step.
    pub health: Health,
    /// The IMU's rate the filter was set for ([`imu_rate_hz`]), Hz, and
    /// its first sample's time stamp; `None` without an IMU.
    pub imu: Option<(f32, Timestamp)>,
    /// The wheels' status record after every wheel sample the filter took
    /// (innovations and their variances; report.json `aids` sums them).
    pub wheel_records: Vec<traction::ego_ekf::aid_status::WheelStatus>,
}

/// The filter's health, checked after every processed IMU sample once the
/// filter runs: every nominal state value finite, the covariance finite,
/// symmetric and positive definite without the pose clone's rows and
/// columns (Cholesky of the correlation matrix). The whole matrix is
/// checked too and its failures counted apart ([`Health::clone_not_spd`]):
/// while the robot stands the clone is a copy of the pose, and the
/// unobservable height's variance (tenths of a metre after long runs)
/// against its tiny difference from the clone's is beyond `f32` at times,
/// as the soak test describes. And the estimator's counts
/// after every IMU sample: per stream, as many samples seen as the replay
/// has logged outcomes for (every sample in exactly one count), and no
/// count smaller than at the step before.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Health {
    /// Steps checked.
    pub steps: u32,
    /// Steps with a non-finite state value.
    pub non_finite: u32,
    /// Steps whose covariance without the pose clone was not symmetric
    /// positive definite.
    pub not_spd: u32,
    /// Steps whose whole covariance, the pose clone included, failed the
    /// Cholesky test (reported, not a failure: see the type's docs).
    pub clone_not_spd: u32,
    /// Steps at which a stream's `seen` differed from the outcomes logged.
    pub counts_unbalanced: u32,
    /// Steps at which a count was smaller than at the step before.
    pub counts_backwards: u32,
    /// Time stamp of the first step that failed a check, ns.
    pub first_failed_ns: Option<u64>,
}

impl Health {
    fn check(&mut self, ekf: &traction::ego_ekf::EgoEkf, t: Timestamp) {
        self.noting_first_failure(t, |h| h.check_filter(ekf));
    }

    /// Runs `check` and keeps `t` as the first failing step if it is one.
    fn noting_first_failure(&mut self, t: Timestamp, check: impl FnOnce(&mut Health)) {
        let before = *self;
        check(self);
        if self.first_failed_ns.is_none() && !self.same_failures(&before) {
            self.first_failed_ns = Some(t.0);
        }
    }

    fn same_failures(&self, o: &Health) -> bool {
        (
            self.non_finite,
            self.not_spd,
            self.counts_unbalanced,
            self.counts_backwards,
        ) == (
            o.non_finite,
            o.not_spd,
            o.counts_unbalanced,
            o.counts_backwards,
        )
    }

    fn check_filter(&mut self, ekf: &traction::ego_ekf::EgoEkf) {
        if !ekf.is_initialised() {
            return;
        }
        let x = ekf.state();
        let finite = [
            x.p_wb,
            x.v_wb,
            x.accel_bias,
            x.gyro_bias,
            x.gravity,
            x.clone_p_wb,
            x.p_bl,
            x.p_br,
        ]
        .iter()
        .all(|v| v.iter().all(|c| c.is_finite()))
            && [x.q_wb, x.clone_q_wb, x.q_rb]
                .iter()
                .all(|q| q.coords.iter().all(|c| c.is_finite()))
            && x.radius_left.is_finite()
            && x.radius_right.is_finite();
        self.steps += 1;
        if !finite {
            self.non_finite += 1;
        }
        let p = ekf.covariance();
        if !definite_without_clone(p) {
            self.not_spd += 1;
        }
        if !traction::ego_ekf::covariance::is_positive_definite(p) {
            self.clone_not_spd += 1;
        }
    }

    /// Checks the estimator's counts `now` against the outcomes logged per
    /// stream (`logged`) and against the counts of the step before (`last`).
    fn check_counts(
        &mut self,
        now: &traction::vslam_core::StreamCounts,
        last: &traction::vslam_core::StreamCounts,
        logged: &traction::vslam_core::PerStream<u32>,
        t: Timestamp,
    ) {
        self.noting_first_failure(t, |h| h.count_checks(now, last, logged));
    }

    fn count_checks(
        &mut self,
        now: &traction::vslam_core::StreamCounts,
        last: &traction::vslam_core::StreamCounts,
        logged: &traction::vslam_core::PerStream<u32>,
    ) {
        if now.iter().any(|(s, c)| c.seen() != logged[s]) {
            self.counts_unbalanced += 1;
        }
        let backwards = now.iter().any(|(s, c)| {
            let l = &last[s];
            c.fused() < l.fused()
                || c.by_reason()
                    .zip(l.by_reason())
                    .any(|((_, a), (_, b))| a < b)
        });
        if backwards {
            self.counts_backwards += 1;
        }
    }

    /// Whether every checked step was healthy.
    pub fn ok(&self) -> bool {
        self.non_finite == 0
            && self.not_spd == 0
            && self.counts_unbalanced == 0
            && self.counts_backwards == 0
    }
}

/// Whether `p` without the pose clone's rows and columns is symmetric
/// positive definite (the Cholesky factorisation of its correlations).
pub fn definite_without_clone(p: &traction::ego_ekf::state::Covariance) -> bool {
    use traction::ego_ekf::state::{CLONE, DIM};
    const KEEP: usize = DIM - (CLONE.end - CLONE.start);
    if !traction::ego_ekf::covariance::looks_valid(p) {
        return false;
    }
    let mut keep = [0usize; KEEP];
    for (slot, i) in keep.iter_mut().zip((0..DIM).filter(|i| !CLONE.contains(i))) {
        *slot = i;
    }
    let corr = nalgebra::SMatrix::<f64, KEEP, KEEP>::from_fn(|r, c| {
        let (i, j) = (keep[r], keep[c]);
        f64::from(p[(i, j)]) / (f64::from(p[(i, i)]) * f64::from(p[(j, j)])).sqrt()
    });
    corr.cholesky().is_some()
}

/// Outcomes of samples in processing order: stream, time stamp, name.
pub type Outcomes = Vec<(Stream, Timestamp, &'static str)>;

/// What reaches the estimator instead of the dataset's own sample streams
/// (`simulate --faults`): samples in arrival order, and reads that failed.
#[derive(Clone, Debug, Default)]
pub struct Feed {
    /// `(arrival, sample)`: the estimator gets them sorted by arrival (stably).
    pub samples: Vec<(Timestamp, Event)>,
    /// Reads that produced no sample.
    pub failed: Vec<FailedRead>,
}

/// How a replay is run.
#[derive(Clone, Debug, PartialEq)]
pub struct ReplayOptions {
    /// Where the flow sensor's distance `To` comes from: its motion counts
    /// (`flow0`) or its raw frames (`flowraw0`, tracked by
    /// [`traction::vslam_core::flow_frames`]); `None` chooses: frames when
    /// the log has frames and no counts, counts otherwise.
    pub flow_source: Option<FlowSource>,
    /// Use the segmentation maps (when the dataset has them) for the
    /// surface-aware grip and jolt judgement; `false` keeps the filter's fixed
    /// grip and one fixed jolt threshold, for comparison.
    pub surface_model: bool,
    /// The camera path's
    /// [`FrontEndConfig::redetect_below`](traction::frontend::FrontEndConfig::redetect_below)
    /// (fewest inliers carried into the next frame before corners are
    /// detected afresh); `None` for its default.
    pub redetect_below: Option<usize>,
    /// Refuse a log whose samples hold values that parse but are bad (NaN,
    /// infinite, duplicated or out-of-order time stamps) with exit 2, as
    /// syntax errors are; otherwise they reach the estimator, which rejects
    /// and counts them ([`crate::asl::BadSamples`]).
    pub strict: bool,
    /// The scale pipeline's selection method; `None` for its default
    /// ([`SelectionMethod::Fusion`]).
    pub scale_method: Option<SelectionMethod>,
    /// Which scale composes the camera path; `None` for the pipeline's
    /// default ([`ComposeScale::Pair`]).
    pub compose: Option<ComposeScale>,
    /// Which length of the wheel and flow motion is compared with the
    /// camera's `|T|`; `None` for the pipeline's default.
    pub distance: Option<Distance>,
    /// Wheel radii and track in place of `wheel0/sensor.yaml`'s (`replay
    /// --wheels FILE`, e.g. from `host-sim calibrate`); `None` keeps the
    /// dataset's.
    pub wheels: Option<crate::calibrate::WheelGeometry>,
    /// The adverse-event memory's file: restored before the first sample
    /// when it exists, written after the last one ([`memory`]); `None`: the
    /// run starts with an empty memory and keeps nothing.
    pub memory: Option<PathBuf>,
    /// Pass the scale pipeline's slip and wheel-outlier verdicts to the EKF's
    /// wheel noise ([`EstimatorConfig::wheel_distrust`](traction::estimator::EstimatorConfig::wheel_distrust));
    /// `false` cuts the link, for comparison.
    pub wheel_distrust: bool,
    /// The flow sensor on demand ([`traction::flow_demand`]): flow reports
    /// reach the estimator only while the policy has the sensor on and its
    /// power-up has had time to run; `None` keeps it always on.
    pub flow_demand: Option<traction::flow_demand::FlowDemandConfig>,
    /// The floor's expected slip in the wheel measurement's mean, learned
    /// per floor, with the wheel radii held on low-grip floors
    /// ([`traction::ego_ekf::surface::slip`]); `false` cuts it (no expected
    /// slip, the radii learn everywhere), for comparison.
    pub expected_slip: bool,
    /// Estimate the gyro's z scale factor
    /// ([`ImuConfig::estimate_gyro_scale`](traction::ego_ekf::config::ImuConfig::estimate_gyro_scale));
    /// `false` (the default) leaves the rate only bias-corrected.
    pub gyro_scale: bool,
}

/// The flow sensor's stream the replay uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlowSource {
    /// Motion counts (`flow0`): the EKF's flow velocity and the scale pipeline's `To`.
    Counts,
    /// Raw frames (`flowraw0`): the scale pipeline's `To` from the frames;
    /// the counts are not used.
    Frames,
}

impl FlowSource {
    /// The source for dataset `ds` when `choice` is `None` (see
    /// [`ReplayOptions::flow_source`]).
    pub fn resolve(choice: Option<FlowSource>, ds: &crate::asl::Dataset) -> FlowSource {
        match choice {
            Some(s) => s,
            None if ds.flow.is_none() && ds.flowraw.is_some() => FlowSource::Frames,
            None => FlowSource::Counts,
        }
    }
}

impl Default for ReplayOptions {
    /// The surface model on, the camera path's and the scale pipeline's
    /// defaults, bad samples passed to the estimator.
    fn default() -> Self {
        ReplayOptions {
            flow_source: None,
            surface_model: true,
            redetect_below: None,
            strict: false,
            scale_method: None,
            compose: None,
            distance: None,
            wheels: None,
            memory: None,
            wheel_distrust: true,
            flow_demand: None,
            expected_slip: true,
            gyro_scale: false,
        }
    }
}

/// Replays `ds` (read from `root`) through the estimator.
pub fn replay(ds: &Dataset, root: &Path, progress: bool) -> Result<ReplayOutput, CliError> {
    replay_with(ds, root, progress, ReplayOptions::default())
}

/// Replays `ds` (read from `root`) through the estimator, run as `options` say.
pub fn replay_with(
    ds: &Dataset,
    root: &Path,
    progress: bool,
    options: ReplayOptions,
) -> Result<ReplayOutput, CliError> {
    replay_feed(ds, root, progress, options, None)
}

/// [`replay_with`], with the sample streams replaced by `feed` when given
/// (the dataset's images, metadata and truth stay).
pub fn replay_feed(
    ds: &Dataset,
    root: &Path,
    progress: bool,
    options: ReplayOptions,
    feed: Option<&Feed>,
) -> Result<ReplayOutput, CliError> {
    run::run(ds, root, progress, options, feed)
}

/// Reads, replays and writes: the `replay` command's work.
pub fn run_replay(dataset: &Path, out: &Path, progress: bool) -> Result<ReplayOutput, CliError> {
    run_replay_with(dataset, out, progress, ReplayOptions::default())
}

/// [`run_replay`], run as `options` say.
pub fn run_replay_with(
    dataset: &Path,
    out: &Path,
    progress: bool,
    options: ReplayOptions,
) -> Result<ReplayOutput, CliError> {
    let bad = if options.strict {
        crate::asl::BadSamples::Refuse
    } else {
        crate::asl::BadSamples::PassOn
    };
    let ds = crate::asl::read_dataset_with(dataset, bad)?;
    let scene = crate::plot::Scene::read(dataset)?;
    let r = replay_with(&ds, dataset, progress, options)?;
    write_outputs(out, &r, ds.groundtruth.as_deref(), scene.as_ref())?;
    Ok(r)
}

/// Rejection reason names, for reports and tests.
pub fn reason_names() -> Vec<&'static str> {
    Reject::ALL.iter().map(|r| r.name()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use traction::vslam_core::{PerStream, StreamCounts};

    #[test]
    fn counts_must_match_the_outcomes_logged_and_never_shrink() {
        let mut h = Health::default();
        let mut now = StreamCounts::default();
        now[Stream::Wheel].record(Ok(()));
        now[Stream::Wheel].record(Err(Reject::Gated));
        let mut logged = PerStream::<u32>::default();
        logged[Stream::Wheel] = 2;
        let before = StreamCounts::default();
        h.check_counts(&now, &before, &logged, Timestamp(7));
        assert!(h.ok(), "{h:?}");
        logged[Stream::Wheel] = 3;
        h.check_counts(&now, &before, &logged, Timestamp(7));
        assert_eq!(h.counts_unbalanced, 1, "a sample logged but not counted");
        assert_eq!(h.first_failed_ns, Some(7));
        logged[Stream::Wheel] = 2;
        h.check_counts(&before, &now, &PerStream::default(), Timestamp(9));
        assert_eq!(h.counts_backwards, 1, "the counts went down");
        assert!(!h.ok());
    }
}
