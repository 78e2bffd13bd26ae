//! Fault injection for `host-sim simulate --faults LIST` and for tests
//! (issue 8): values, time, bus and chip, vision and motion faults, each
//! recorded with the samples it spoiled and the outcome every one of them
//! must end in, so that `report.json` can show that nothing bad was fused
//! and nothing was lost silently.
//!
//! ## Syntax
//! `KIND@START[+DUR][xCOUNT]`, comma-separated, times in seconds from the
//! start of the run: `imu-nan@4x3`, `wheel-gap@4+5`, `stuck@5+2`
//! ([`spec`]; `host-sim simulate --help` lists every kind, [`kinds_help`]).
//!
//! ## Where each fault is injected ([`Stage`])
//! The simulator generates samples, writes an ASL log, then replays it
//! through `traction::Estimator`.
//! - values and gaps go into the generated samples before the log is
//!   written, so a replay of the written log reproduces them;
//! - non-finite values, duplicate and zero-dt time stamps and late samples
//!   cannot be written (the ASL reader refuses them as a malformed log): they
//!   are injected into the stream between the log and the estimator by the
//!   same [`FaultInjector`];
//! - bus and chip faults go into the register-level chip simulators
//!   (`chips::*`) and reach the estimator through the real drivers; a failed
//!   read leaves no row in the log, `simulate` hands it to
//!   `Estimator::reject_read` with its reason;
//! - vision faults spoil the rendered images; motion faults change the drive.
//!
//! ## Accounting
//! Every spoiled sample is recorded ([`SpoiledSample`], [`FailedRead`]) with
//! the [`Expected`] outcome (`gated` and `fused` are outcomes too, e.g. an
//! IMU outlier is integrated, low SQUAL is noise). The replay logs the
//! outcome of every sample; [`report::faults_section`] matches the two and
//! writes `report.json`'s `faults` section: per fault, the samples injected,
//! the expected outcome and the outcomes observed.
//!
//! ## Recovery
//! [`recovery`] defines the trajectory error used to judge recovery.

pub mod chip;
pub mod image;
pub mod kind;
pub mod recovery;
pub mod report;
pub mod scenario;
pub mod spec;
pub mod stream;

pub use chip::FailedRead;
pub use kind::{Expected, FaultKind, Sensor, Stage, Target};
pub use spec::{FaultPlan, FaultSpec, SpecError, kinds_help};
pub use stream::{Delivery, FaultInjector, SpoiledSample, inject};
/// The sensor registry the faults, their records and the reports name
/// streams by.
pub use traction::vslam_core::Stream;
