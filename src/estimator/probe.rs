//! A hook around each part of the estimator's work, for measuring it.
//!
//! [`EstimatorWith`](super::EstimatorWith) calls [`Probe::enter`] before and
//! [`Probe::leave`] after each call it makes into a part (the EKF, the
//! odometry, the scale pipeline, the camera front end, the disagreement
//! check), so a caller can attribute instructions, time or stack to the
//! parts of one `poll` or `process_camera` without a copy of the dispatch.
//! The default [`NoProbe`] is a zero-sized type whose methods are empty:
//! the compiler removes the calls, and the estimator's size and code are
//! what they are without a probe. The firmware image (`firmware/src/meter.rs`)
//! implements it with SysTick and stack painting.

/// The parts the estimator calls, one per measured call.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Part {
    /// `EgoEkf::propagate` of an IMU sample.
    Propagate,
    /// `EgoEkf::fuse_wheel`.
    FuseWheel,
    /// `EgoEkf::fuse_flow`.
    FuseFlow,
    /// `EgoEkf::fuse_camera_weighted` of a frame pair.
    FuseCamera,
    /// `DiffDriveOdometry::update` (or `update_rates`).
    Odometry,
    /// `ScalePipeline::push_imu`.
    ScaleImu,
    /// `ScalePipeline::push_wheel`.
    ScaleWheel,
    /// `ScalePipeline::push_flow`.
    ScaleFlow,
    /// `ScalePipeline::push_camera`.
    ScaleCamera,
    /// `FrontEnd::process` of one camera frame.
    FrontEnd,
    /// `DisagreementCheck::on_frame`: each sensor against the EKF per pair.
    Disagreement,
}

impl Part {
    /// Every part.
    pub const ALL: [Part; 11] = [
        Part::Propagate,
        Part::FuseWheel,
        Part::FuseFlow,
        Part::FuseCamera,
        Part::Odometry,
        Part::ScaleImu,
        Part::ScaleWheel,
        Part::ScaleFlow,
        Part::ScaleCamera,
        Part::FrontEnd,
        Part::Disagreement,
    ];
}

/// Called around every part's call; both methods default to doing nothing.
pub trait Probe {
    /// `part` is about to be called.
    #[inline(always)]
    fn enter(&mut self, part: Part) {
        let _ = part;
    }

    /// `part` returned; `done` is whether it returned `Ok` (did its work)
    /// rather than refusing the sample.
    #[inline(always)]
    fn leave(&mut self, part: Part, done: bool) {
        let _ = (part, done);
    }
}

/// No probe: the calls compile to nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoProbe;

impl Probe for NoProbe {}

/// Calls `f`, the call into `part`, between `probe`'s `enter` and `leave`.
#[inline(always)]
pub(crate) fn probed<P: Probe, T, E>(
    probe: &mut P,
    part: Part,
    f: impl FnOnce() -> Result<T, E>,
) -> Result<T, E> {
    probe.enter(part);
    let r = f();
    probe.leave(part, r.is_ok());
    r
}
