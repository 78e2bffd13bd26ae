//! The filter: one type that takes IMU, wheel and flow samples, owns the
//! state, covariance, grip and per-sensor status, and reports the estimate.
//! Here the steps that change it; its read side (accessors, statuses, counts) is in `filter/read.rs`.

use nalgebra::Matrix3;
use vslam_core::kinematics::{mid_axle, rim};
use vslam_core::sensors::{FlowSample, ImuSample, WheelRates};
use vslam_core::{Reject, SampleClock, SampleCounts, Timestamp};

use crate::camera::CameraFusion;
use crate::config::{ConfigError, FilterConfig, InitConfig};
use crate::covariance;
use crate::floor::FloorFusion;
use crate::flow::{FlowFused, FlowFusion};
use crate::gap::{GapOdometry, bridge_gap, bridge_with_wheels, wheel_geometry};
use crate::grip::GripParams;
use crate::impact::{self, ImpactWatch};
use crate::init::{Initialiser, StillStart};
use crate::observability;
use crate::plausibility::PlausibilityCheck;
use crate::propagate::{
    Transition, process_noise, propagate_covariance, propagate_covariance_clone_decoupled,
    propagate_nominal, world_acceleration,
};
use crate::recovery::{self, Evidence, FlowWitness, RecoveryCounts, Refutation, Verdict};
use crate::state::{CLONE, Covariance, ErrorState, NominalState, P, Quat, TH, V, Vec3};
use crate::update::{Measurement, UpdateReport, gated_update};
use crate::vibration::{SampleNoise, Vibration};
use crate::wheel::distrust::WheelDistrust;
use crate::wheel::{WheelFusion, WheelInnovation};
use crate::zupt::{StillDetector, ZuptFusion};

mod camera;
mod distrust;
mod read;
mod relative;
mod weights;

pub use relative::RelativeMotion;
pub use weights::SensorWeights;

/// Variance of the clone's copy of the position, m^2 (see [`covariance::clone_pose`]).
const CLONE_COPY_VAR_POSITION: f32 = 1.0e-8;
/// Variance of the clone's copy of the attitude, rad^2.
const CLONE_COPY_VAR_ATTITUDE: f32 = 1.0e-8;
/// The copy variance is at least this fraction of the largest pose variance:
/// in `f32` (7 digits) a copy of a pose known to metres (after an IMU gap)
/// would otherwise be bit-identical to it and `P` singular.
const CLONE_COPY_RELATIVE: f32 = 1.0e-5;

/// The larger of two values, `a` if `b` is NaN: what `f32::max` gives for
/// these positive inputs, without the out-of-line `fmaxf` call it becomes on
/// Cortex-M (eight per clone, about 110 instructions).
fn larger(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

/// Copies the pose into the clone, with copy variances that keep `P`
/// positive definite in `f32` whatever the pose's uncertainty.
fn clone_pose(x: &mut NominalState, p: &mut Covariance) {
    x.clone_pose();
    let (var_p, var_th) = copy_variances(p);
    covariance::clone_pose(p, var_p, var_th);
}

/// The clone's copy variances for the pose's current uncertainty: position
/// and attitude, each at least its absolute minimum and
/// [`CLONE_COPY_RELATIVE`] of the block's largest variance.
fn copy_variances(p: &Covariance) -> (f32, f32) {
    let largest = |start: usize| {
        (start..start + 3)
            .filter_map(|i| p.get((i, i)).copied())
            .fold(0.0f32, larger)
    };
    (
        larger(CLONE_COPY_VAR_POSITION, CLONE_COPY_RELATIVE * largest(P)),
        larger(CLONE_COPY_VAR_ATTITUDE, CLONE_COPY_RELATIVE * largest(TH)),
    )
}

/// One IMU step's output: the bias-corrected sample and what the events
/// module needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuStep {
    /// Time of the sample.
    pub t: Timestamp,
    /// Step integrated with this sample's reading, s (after refused
    /// readings, the part after the latest of them).
    pub dt: f32,
    /// Bias-corrected angular rate, body frame, rad/s.
    pub gyro: Vec3,
    /// Bias-corrected specific force, body frame, m/s^2.
    pub accel: Vec3,
    /// Vertical specific-force deviation `|(R a + g)_z|`, m/s^2 (jolts).
    pub vertical_deviation: f32,
    /// Whether the robot was still at this step (a ZUPT may have run).
    pub still: bool,
}

/// An explicit start state (instead of the still-sample initialisation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExplicitStart {
    /// Time of the state.
    pub t: Timestamp,
    /// IMU position, world, m.
    pub p_wb: Vec3,
    /// IMU velocity, world, m/s.
    pub v_wb: Vec3,
    /// IMU attitude.
    pub q_wb: Quat,
    /// Accelerometer bias, m/s^2.
    pub accel_bias: Vec3,
    /// Gyroscope bias, rad/s.
    pub gyro_bias: Vec3,
}

impl ExplicitStart {
    /// Level, standing still at the world origin, biases zero, at time `t`:
    /// the start to change one field of (`ExplicitStart { v_wb, ..at_rest(t) }`).
    pub fn at_rest(t: Timestamp) -> Self {
        ExplicitStart {
            t,
            p_wb: Vec3::zeros(),
            v_wb: Vec3::zeros(),
            q_wb: Quat::identity(),
            accel_bias: Vec3::zeros(),
            gyro_bias: Vec3::zeros(),
        }
    }
}

/// The 250 Hz surface-aware error-state EKF.
#[derive(Clone, Debug)]
pub struct EgoEkf {
    config: FilterConfig,
    x: NominalState,
    p: Covariance,
    grip: GripParams,
    initialised: bool,
    initialiser: Initialiser,
    imu_clock: SampleClock,
    /// Rate jumps and frozen readings (see [`crate::plausibility`]).
    plausibility: PlausibilityCheck,
    imu_counts: SampleCounts,
    last_step: Option<ImuStep>,
    still: StillDetector,
    zupt: ZuptFusion,
    floor: FloorFusion,
    wheel: WheelFusion,
    flow: FlowFusion,
    recovery: RecoveryCounts,
    /// The flow's standing verdict against the wheels' forward speed.
    refutation: Refutation,
    /// The scale pipeline's standing verdict against the wheels.
    distrust: WheelDistrust,
    /// The latest horizontal impact (see [`crate::impact`]).
    impact: ImpactWatch,
    /// The adverse-event memory's weights where the robot is.
    weights: SensorWeights,
    /// The ground's vibration, measured from the accelerometer.
    vibration: Vibration,
    gaps: GapCounts,
    gap_odometry: GapOdometry,
    /// What the pose clone holds and who reads it (see [`CloneUse`]).
    clone: CloneUse,
    camera: CameraFusion,
    /// The latest accepted IMU sample's rates (gyro, specific force), as
    /// measured: the zero-order hold to a camera frame between samples.
    last_imu: Option<(Vec3, Vec3)>,
    /// The time of the latest reading refused for its values (in order,
    /// since the last accepted one): the next accepted reading holds
    /// `last_imu` up to it (see [`EgoEkf::propagate`]).
    refused_at: Option<Timestamp>,
}

/// The pose clone's schedule: one clone, shared by the zero-velocity
/// update and the camera (no second clone, so the state and the cost of a
/// still step are those of the filter without a camera).
///
/// - [`CloneUse::Still`]: the pose where the robot stopped (or started),
///   read by the zero-velocity update; copied at the first still step;
/// - [`CloneUse::Due`]: moving, no camera pair to measure: the clone is
///   decoupled ([`covariance::decouple_clone`]) and costs nothing in
///   propagation until the next still step or camera frame copies the pose;
/// - [`CloneUse::Frame`]: moving, the pose at the camera frame of that time,
///   copied after the frame's update; coupled (propagated with the pose) so
///   that the next frame's pair measures the motion between the two.
///
/// A still robot's frames are not measured (the zero-velocity update already
/// holds the pose to the clone); the first frame after the robot starts
/// moving only takes the clone (see [`crate::camera::fusion`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CloneUse {
    Still,
    Due,
    Frame(Timestamp),
}

/// IMU gaps the filter bridged (see [`crate::gap`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GapCounts {
    /// Gaps bridged.
    pub bridged: u32,
    /// Their total length, ns.
    pub total_ns: u64,
    /// The longest, ns.
    pub longest_ns: u64,
    /// Of the gaps bridged, those the wheels dead-reckoned (the others at
    /// constant velocity).
    pub by_wheels: u32,
}

/// The identity covariance, evaluated at compile time (an index out of
/// range would be a compile error, not a panic).
#[allow(clippy::indexing_slicing)]
const IDENTITY_COVARIANCE: Covariance = {
    let mut a = [[0.0f32; crate::state::DIM]; crate::state::DIM];
    let mut i = 0;
    while i < crate::state::DIM {
        a[i][i] = 1.0;
        i += 1;
    }
    Covariance::from_array_storage(nalgebra::ArrayStorage(a))
};

impl GapCounts {
    /// Nothing bridged.
    pub const fn new() -> Self {
        GapCounts {
            bridged: 0,
            total_ns: 0,
            longest_ns: 0,
            by_wheels: 0,
        }
    }
}

/// Short name of [`EgoEkf`].
pub type Filter = EgoEkf;

impl EgoEkf {
    /// A filter waiting for still IMU samples (or [`EgoEkf::start`]).
    pub fn new(config: FilterConfig) -> Result<Self, ConfigError> {
        config.check()?;
        Ok(Self::unchecked(config))
    }

    /// A filter with the default configuration ([`FilterConfig::DEFAULT`]),
    /// waiting for still IMU samples: a `const` value, so that a filter can
    /// live in a `static` and be configured there ([`EgoEkf::reset`])
    /// without a filter-sized value passing through the stack.
    pub const fn unconfigured() -> Self {
        Self::unchecked(FilterConfig::DEFAULT)
    }

    /// Starts over in place with `config` (a checked configuration), as
    /// [`EgoEkf::new`] would build it: every field is written where it is,
    /// the covariance set to the identity in place. A refused configuration
    /// leaves the filter as it was.
    pub fn reset(&mut self, config: FilterConfig) -> Result<(), ConfigError> {
        config.check()?;
        // Every field by name: a field added to the filter and not reset
        // here does not compile.
        let EgoEkf {
            config: c,
            x,
            p,
            grip,
            initialised,
            initialiser,
            imu_clock,
            plausibility,
            imu_counts,
            last_step,
            still,
            zupt,
            floor,
            wheel,
            flow,
            recovery,
            refutation,
            distrust,
            impact,
            weights,
            vibration,
            gaps,
            gap_odometry,
            clone,
            camera,
            last_imu,
            refused_at,
        } = self;
        *x = Self::nominal(&config);
        p.fill_with_identity();
        *grip = config.grip;
        *initialised = false;
        *initialiser = Initialiser::new();
        *imu_clock = SampleClock::new(config.imu.max_dt_ns);
        *plausibility = PlausibilityCheck::new();
        *imu_counts = SampleCounts::new();
        *last_step = None;
        *still = StillDetector::new();
        *zupt = ZuptFusion::new();
        *floor = FloorFusion::new();
        *wheel = Self::wheel_fusion(&config);
        *flow = Self::flow_fusion(&config);
        *recovery = RecoveryCounts::new();
        *refutation = Refutation::new();
        *distrust = WheelDistrust::new();
        *impact = ImpactWatch::new();
        *weights = SensorWeights::FULL;
        *vibration = Vibration::new();
        *gaps = GapCounts::new();
        *gap_odometry = GapOdometry::new();
        *clone = CloneUse::Still;
        *camera = CameraFusion::new();
        *last_imu = None;
        *refused_at = None;
        *c = config;
        Ok(())
    }

    const fn nominal(config: &FilterConfig) -> NominalState {
        let r = &config.robot;
        let zero = Vec3::new(0.0, 0.0, 0.0);
        let identity = Quat::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0));
        NominalState {
            p_wb: zero,
            v_wb: zero,
            q_wb: identity,
            accel_bias: zero,
            gyro_bias: zero,
            gravity: Vec3::new(0.0, 0.0, -config.gravity),
            gyro_scale: 0.0,
            clone_p_wb: zero,
            clone_q_wb: identity,
            p_bl: r.p_bl,
            p_br: r.p_br,
            q_rb: r.q_rb,
            radius_left: r.radius,
            radius_right: r.radius,
        }
    }

    const fn wheel_fusion(config: &FilterConfig) -> WheelFusion {
        WheelFusion::new(
            config.wheel.max_dt_ns,
            config.wheel.max_age_ns,
            config.zupt.max_wheel_rate,
        )
        .with_gyro_scale(config.imu.estimate_gyro_scale)
        .with_skid(config.wheel.skid)
    }

    const fn flow_fusion(config: &FilterConfig) -> FlowFusion {
        match config.flow {
            Some(f) => FlowFusion::new(f.max_dt_ns, f.max_age_ns, f.window_ns, f.base_std),
            None => FlowFusion::new(1, 1, 1, 0.0),
        }
    }

    /// The filter of `config` without checking it.
    const fn unchecked(config: FilterConfig) -> Self {
        EgoEkf {
            x: Self::nominal(&config),
            p: IDENTITY_COVARIANCE,
            grip: config.grip,
            initialised: false,
            initialiser: Initialiser::new(),
            imu_clock: SampleClock::new(config.imu.max_dt_ns),
            plausibility: PlausibilityCheck::new(),
            imu_counts: SampleCounts::new(),
            last_step: None,
            still: StillDetector::new(),
            zupt: ZuptFusion::new(),
            floor: FloorFusion::new(),
            wheel: Self::wheel_fusion(&config),
            flow: Self::flow_fusion(&config),
            recovery: RecoveryCounts::new(),
            refutation: Refutation::new(),
            distrust: WheelDistrust::new(),
            impact: ImpactWatch::new(),
            weights: SensorWeights::FULL,
            vibration: Vibration::new(),
            gaps: GapCounts::new(),
            gap_odometry: GapOdometry::new(),
            clone: CloneUse::Still,
            camera: CameraFusion::new(),
            last_imu: None,
            refused_at: None,
            config,
        }
    }

    /// Starts from an explicit state, with the configured initial standard
    /// deviations; any still-sample averaging is dropped.
    pub fn start(&mut self, start: &ExplicitStart) -> Result<(), Reject> {
        let v = [
            &start.p_wb,
            &start.v_wb,
            &start.accel_bias,
            &start.gyro_bias,
        ];
        if !v.iter().all(|v| v.iter().all(|x| x.is_finite()))
            || !start.q_wb.coords.iter().all(|x| x.is_finite())
        {
            return Err(Reject::NonFinite);
        }
        self.x.p_wb = start.p_wb;
        self.x.v_wb = start.v_wb;
        self.x.q_wb = start.q_wb;
        self.x.accel_bias = start.accel_bias;
        self.x.gyro_bias = start.gyro_bias;
        self.begin(start.t, self.config.init);
        Ok(())
    }

    fn start_still(&mut self, t: Timestamp, s: &StillStart) {
        self.x.p_wb = Vec3::zeros();
        self.x.v_wb = Vec3::zeros();
        self.x.q_wb = s.q_wb;
        self.x.accel_bias = Vec3::zeros();
        self.x.gyro_bias = s.gyro_bias;
        let init = if s.moving {
            self.config.init.moving()
        } else {
            self.config.init
        };
        self.begin(t, init);
    }

    fn begin(&mut self, t: Timestamp, init: InitConfig) {
        let d = covariance::initial_variances(&init, &self.config.robot);
        self.p = Covariance::from_diagonal(&d);
        clone_pose(&mut self.x, &mut self.p);
        self.clone = CloneUse::Still;
        self.last_imu = None;
        self.refused_at = None;
        self.refutation.clear();
        self.distrust.clear();
        self.imu_clock.reset();
        // Anchor the IMU clock at the start time; cannot fail after a reset.
        let _ = self.imu_clock.accept(t);
        self.initialiser.restart();
        self.still = StillDetector::new();
        self.zupt = ZuptFusion::new();
        self.floor.anchor(&self.x);
        self.initialised = true;
    }

    /// Propagates with one IMU sample (bias-corrected first), runs the still
    /// detector and, when due, a zero-velocity update against the pose clone
    /// (copied at the first still step after motion: it then holds the pose
    /// of the last moving step; see `clone_if_due`).
    ///
    /// Before initialisation the sample feeds the still-sample average and is
    /// counted as [`Reject::NotReady`]. Bad time stamps, gaps, samples at
    /// or beyond the configured full scale ([`Reject::Saturated`]) and,
    /// with `ImuConfig::plausibility`, rate jumps beyond the robot's angular
    /// acceleration ([`Reject::OutOfRange`]) and frozen readings
    /// ([`Reject::LowQuality`], see [`crate::plausibility`]) are
    /// rejected with their reason and leave
    /// the state untouched; the next accepted sample holds the last
    /// accepted rates up to the latest refused one (also those the caller
    /// refused, [`EgoEkf::refused_imu_at`]) and integrates its own reading
    /// after it. The sample ending a gap (longer than
    /// the configured step) first bridges it: pose moved by the wheels'
    /// dead reckoning over the gap (or, without it, extrapolated at constant
    /// velocity and the last yaw rate), the covariance grown by what was not
    /// measured (see [`crate::gap`]), counted in [`EgoEkf::gaps`].
    pub fn propagate(&mut self, sample: &ImuSample) -> Result<ImuStep, Reject> {
        let outcome = self.propagate_inner(sample);
        self.imu_counts.record(outcome.map(|_| ()));
        if let Ok(step) = outcome {
            self.last_step = Some(step);
            self.wheel.observe_imu(&self.x, sample.gyro(), step.dt);
        }
        debug_assert!(covariance::looks_valid(&self.p));
        outcome
    }

    fn propagate_inner(&mut self, sample: &ImuSample) -> Result<ImuStep, Reject> {
        let previous = self.imu_clock.last();
        // A time stamp the clock refuses is refused for that reason, not judged.
        let in_order = self.imu_clock.follows(sample.t());
        if let Err(reason) = self.judge_values(sample, in_order) {
            if in_order {
                self.refused_imu_at(sample.t());
            }
            return Err(reason);
        }
        if let Some(refused) = self.refused_at.filter(|&r| r <= sample.t()) {
            self.refused_at = None;
            self.hold_over_refused(previous, refused, sample.t());
        }
        let previous = self.imu_clock.last();
        let dt = self.imu_clock.accept(sample.t());
        if in_order {
            self.plausibility.accepted(sample.t(), sample.gyro());
        }
        if self.initialised
            && dt == Err(Reject::Gap)
            && let Some(gap_ns) = previous.and_then(|p| sample.t().nanos_since(p))
        {
            self.bridge(gap_ns, previous, sample.t());
        }
        if !self.initialised {
            dt?;
            if let Some(s) = self.initialiser.add(
                &self.config.init,
                self.config.gravity,
                sample.gyro(),
                sample.accel(),
            ) {
                self.start_still(sample.t(), &s);
            }
            return Err(Reject::NotReady);
        }
        let dt = dt?.ok_or(Reject::NotReady)?;
        if dt.is_nan() || dt <= 0.0 {
            return Err(Reject::Duplicate);
        }
        self.last_imu = Some((*sample.gyro(), *sample.accel()));
        let gyro = self.x.corrected_gyro(sample.gyro());
        let accel = sample.accel() - self.x.accel_bias;
        // The still detector reads only the sample and the wheels' and the
        // flow's latest word, so it runs before the state moves.
        let zc = self.config.zupt;
        let still = self.still.step(
            &zc,
            &gyro,
            &accel,
            self.config.gravity,
            self.wheel.stopped()
                && !recovery::flow_sees_motion(
                    &self.config.recovery,
                    self.flow_max_age_ns(),
                    self.flow_witness_at(sample.t()),
                    sample.t(),
                ),
        );
        self.clone_if_due(still);
        let r_wb = self.x.q_wb.to_rotation_matrix().into_inner();
        let f = self.transition(&r_wb, &accel, &gyro, dt);
        let weighted = self.weighted_imu();
        let imu = weighted.as_ref().unwrap_or(&self.config.imu);
        let mut q = process_noise(imu, &self.config.robot, dt);
        if let Some(vc) = &self.config.vibration {
            let noise = SampleNoise::new(imu.noise.accel_density, imu.noise.gyro_density, dt);
            self.vibration.step(vc, &(r_wb * accel), &gyro, noise, dt);
            self.vibration.add_to_process_noise(vc, &mut q, noise, dt);
        }
        propagate_nominal(&mut self.x, &accel, &gyro, dt);
        self.propagate_covariance(&f, &q);

        if !still && self.clone == CloneUse::Still {
            // Nothing reads the clone until the next still step or camera
            // frame copies the pose over it: decoupled, it costs nothing in
            // the meantime.
            covariance::decouple_clone(&mut self.p);
            self.clone = CloneUse::Due;
        } else if self.still.update_due(&zc) {
            let before = self.before_update();
            let constrain = self.config.imu.constrain_heading;
            let _ = self
                .zupt
                .fuse(&mut self.x, &mut self.p, &zc, constrain, sample.t());
            self.reanchor(before.as_ref());
            // The update tied the pose to the clone: no tighter than a copy.
            let (var_p, var_th) = copy_variances(&self.p);
            covariance::keep_clone_apart(&mut self.p, var_p, var_th);
        }
        if let Some(fc) = &self.config.floor {
            let wheels_agree = self.wheel.watch().run().is_empty();
            let before = self.before_update();
            let _ = self.floor.step(
                &mut self.x,
                &mut self.p,
                &gyro,
                fc,
                sample.t(),
                wheels_agree,
            );
            self.reanchor(before.as_ref());
        }
        // The body's acceleration: the jolts' vertical part, the impacts' horizontal.
        let a_w = world_acceleration(&self.x, &accel);
        self.impact
            .step(&self.config.recovery, sample.t(), impact::horizontal(&a_w));
        Ok(ImuStep {
            t: sample.t(),
            dt,
            gyro,
            accel,
            vertical_deviation: libm::fabsf(a_w.z),
            still,
        })
    }

    /// Tells the filter that the IMU reading taken at `t` was refused before
    /// it was handed over (not finite, saturated: the caller's entry check,
    /// [`ImuSample::with_range`], and the caller's count): like a reading
    /// [`EgoEkf::propagate`] refuses, it told nothing, and the next accepted
    /// reading holds the last accepted rates up to `t`. A time at or before
    /// the latest accepted reading's, or more than the IMU's longest step
    /// after it (a time stamp in error, or a gap that is bridged anyway),
    /// changes nothing.
    pub fn refused_imu_at(&mut self, t: Timestamp) {
        let near = self.imu_clock.last().is_none_or(|last| {
            t.nanos_since(last)
                .is_some_and(|d| d > 0 && d <= self.imu_clock.max_step_ns())
        });
        if near && self.refused_at.is_none_or(|r| r < t) {
            self.refused_at = Some(t);
        }
    }

    /// The range check and, with `ImuConfig::plausibility` and a time stamp
    /// in order, the plausibility check of one reading.
    fn judge_values(&mut self, sample: &ImuSample, in_order: bool) -> Result<(), Reject> {
        sample.check_range(self.config.imu.gyro_max, self.config.imu.accel_max)?;
        if in_order && let Some(cfg) = &self.config.imu.plausibility {
            // The vertical in the IMU's frame, once the attitude is known.
            let up = self
                .initialised
                .then(|| self.x.q_wb.inverse_transform_vector(&Vec3::z()));
            self.plausibility.check(cfg, sample, up.as_ref())?;
        }
        Ok(())
    }

    /// Before the reading at `t` is integrated: the readings refused since
    /// the last accepted one (at `previous`), the latest at `refused`, told
    /// the filter nothing, so the last accepted rates are held up to
    /// `refused` ([`EgoEkf::propagate_to`]) and the reading at `t` is
    /// integrated over its own part of the interval only, not over the
    /// whole of it. Nothing happens when the interval is a gap (bridged
    /// instead) or `refused` does not lie inside it.
    fn hold_over_refused(&mut self, previous: Option<Timestamp>, refused: Timestamp, t: Timestamp) {
        let Some(previous) = previous.filter(|_| self.initialised) else {
            return;
        };
        let inside = refused.nanos_since(previous).is_some_and(|n| n > 0)
            && t.nanos_since(refused).is_some_and(|n| n > 0);
        let no_gap = t
            .nanos_since(previous)
            .is_some_and(|n| n <= self.imu_clock.max_step_ns());
        if inside && no_gap {
            let _ = self.propagate_to(refused);
        }
    }

    /// Clones the pose if the clone is due and `still` (the step about to be
    /// propagated is still, so a zero-velocity update may read the clone).
    ///
    /// The clone is the pose at the end of the latest moving step. Between
    /// that step and this one only updates changed the state, and none of
    /// them has the clone in its Jacobian: right after a copy, the clone's
    /// rows of `P` are the pose's, so such an update corrects the clone
    /// exactly as the pose (and leaves its rows equal to the pose's). So
    /// copying now, after those updates, gives the same clone (up to
    /// rounding and the copy variance, taken from the current pose
    /// variances) as copying at the end of every moving step, without its
    /// cost on the steps that never read it. While the clone is due it is
    /// decoupled ([`covariance::decouple_clone`]): a past pose with zero
    /// covariance with the other states, which propagation and updates
    /// leave untouched (and propagation skips).
    ///
    /// A clone held for the camera ([`CloneUse::Frame`]) is replaced the
    /// same way: the zero-velocity update needs the pose where the robot
    /// stopped.
    fn clone_if_due(&mut self, still: bool) {
        if still && self.clone != CloneUse::Still {
            clone_pose(&mut self.x, &mut self.p);
            self.clone = CloneUse::Still;
        }
    }

    /// The error-state transition of one step from the attitude `r_wb` and
    /// the corrected samples; the attitude coupled to the gyro's scale
    /// factor when it is estimated ([`crate::config::ImuConfig::estimate_gyro_scale`]).
    fn transition(&self, r_wb: &Matrix3<f32>, accel: &Vec3, gyro: &Vec3, dt: f32) -> Transition {
        let f = Transition::new(r_wb, accel, gyro, dt);
        if self.config.imu.estimate_gyro_scale {
            f.with_gyro_scale(&self.x.gyro_scale_jacobian(gyro))
        } else {
            f
        }
    }

    /// The state before an update, kept only when the heading is
    /// constrained (the copy is what [`EgoEkf::reanchor`] needs; without
    /// the constraint nothing is copied).
    fn before_update(&self) -> Option<NominalState> {
        self.config.imu.constrain_heading.then_some(self.x)
    }

    /// After an update took the state from `before` to the current one,
    /// when the heading is constrained: the covariance's heading direction
    /// moved to the current estimate ([`observability::reanchor`]).
    fn reanchor(&mut self, before: Option<&NominalState>) {
        let Some(before) = before else {
            return;
        };
        let x = &self.x;
        if before.p_wb != x.p_wb
            || before.v_wb != x.v_wb
            || before.q_wb != x.q_wb
            || before.gravity != x.gravity
            || before.clone_p_wb != x.clone_p_wb
            || before.clone_q_wb != x.clone_q_wb
        {
            let clone = if self.clone == CloneUse::Due {
                observability::CloneCoupling::Decoupled
            } else {
                observability::CloneCoupling::Coupled
            };
            let max_std = self.config.imu.max_heading_std;
            observability::reanchor(&mut self.p, before, x, clone, max_std * max_std);
        }
    }

    /// The covariance's propagation by `f` with noise `q`: the clone's rows
    /// skipped while it is decoupled ([`CloneUse::Due`]).
    fn propagate_covariance(&mut self, f: &Transition, q: &ErrorState) {
        if self.clone == CloneUse::Due {
            propagate_covariance_clone_decoupled(&mut self.p, f, q);
        } else {
            propagate_covariance(&mut self.p, f, q);
        }
    }

    /// The oldest flow report that is still a witness, ns
    /// ([`crate::config::FlowConfig::max_age_ns`]; 0 without a flow sensor).
    fn flow_max_age_ns(&self) -> u64 {
        self.config.flow.map_or(0, |f| f.max_age_ns)
    }

    /// The flow's recent mean at `t`, if a flow sensor is configured.
    fn flow_witness_at(&self, t: Timestamp) -> Option<FlowWitness> {
        self.config.flow.and_then(|_| self.flow.witness(t))
    }

    /// Bridges the gap from `start` to `end` (`gap_ns` long): with the
    /// wheels' dead reckoning if they covered it, else at constant velocity
    /// and the latest step's yaw rate.
    fn bridge(&mut self, gap_ns: u64, start: Option<Timestamp>, end: Timestamp) {
        let gap_s = vslam_core::time::nanos_to_seconds(gap_ns);
        // The bridge moves the pose: the clone due from the last moving step
        // is that step's pose, taken now (as if cloned at that step).
        self.clone_if_due(true);
        let geometry = wheel_geometry(&self.x, &self.grip);
        let motion = start.and_then(|s| self.gap_odometry.take(s, end, &geometry, &self.config));
        let by_wheels = motion
            .is_some_and(|m| bridge_with_wheels(&mut self.x, &mut self.p, &self.config, &m, gap_s));
        let gyro = self.angular_velocity();
        if by_wheels || bridge_gap(&mut self.x, &mut self.p, &self.config, &gyro, gap_s) {
            self.still.interrupt();
            let g = &mut self.gaps;
            g.by_wheels = g.by_wheels.saturating_add(u32::from(by_wheels));
            g.bridged = g.bridged.saturating_add(1);
            g.total_ns = g.total_ns.saturating_add(gap_ns);
            g.longest_ns = g.longest_ns.max(gap_ns);
        }
    }

    /// Fuses one wheel-rate sample at the filter's time; see
    /// [`crate::wheel`]. A gated forward part still returns its innovation
    /// (with `gated` set) and is counted as [`Reject::Gated`]. When the
    /// sample completes a run of gated samples, the filter re-examines its
    /// velocity and may reset it from the most trusted source (see
    /// [`crate::recovery`]); the verdict is in
    /// [`WheelInnovation::recovery`] and counted ([`EgoEkf::recovery`]).
    pub fn fuse_wheel(&mut self, rates: &WheelRates) -> Result<WheelInnovation, Reject> {
        let (true, Some(now)) = (self.initialised, self.imu_clock.last()) else {
            return Err(self.wheel.refuse(rates.t(), Reject::NotReady));
        };
        // While the IMU is silent the sample dead-reckons the gap (counted in
        // `gap_wheel_counts`); the wheel fusion below refuses it if it is
        // too far ahead of the filter's time. Geometry and witness only then.
        if GapOdometry::during_gap(now, rates.t(), &self.config) {
            let geometry = wheel_geometry(&self.x, &self.grip);
            let witness = recovery::speed_witness(
                &self.config.recovery,
                self.flow_max_age_ns(),
                self.flow_witness_at(rates.t()),
                rates.t(),
            );
            let _ = self
                .gap_odometry
                .offer(now, rates, &geometry, witness, &self.config);
        }
        let gyro = self.angular_velocity();
        let refuted = self.refutation.is_active() && {
            let speed = mid_axle(
                rim(self.x.radius_left, rates.left()),
                rim(self.x.radius_right, rates.right()),
            );
            let witness = recovery::recent(
                self.flow_max_age_ns(),
                self.flow_witness_at(rates.t()),
                rates.t(),
            );
            self.refutation.holds(
                &self.config.recovery,
                rates.t(),
                speed,
                self.grip.forward_std(),
                self.grip.forward_gate(),
                witness,
            )
        };
        let noise_factor =
            self.distrust.factor_at(rates.t()) * weights::std_factor(self.weights.wheel);
        // An infinite factor refuses the forward rows, as the flow's refutation does.
        let refuted = refuted || noise_factor.is_infinite();
        let strict = self.impact.holds_at(&self.config.recovery, rates.t());
        let before = self.before_update();
        let mut out = self.wheel.fuse(
            &mut self.x,
            &mut self.p,
            &gyro,
            rates,
            &self.grip,
            now,
            &self.config.recovery,
            refuted,
            noise_factor,
            strict,
        );
        self.reanchor(before.as_ref());
        if strict && let Ok(inn) = &out {
            self.impact.judged(rates.t(), inn.forward_fused, inn.gated);
        }
        if self.distrust.holds_at(rates.t()) {
            self.distrust.record(match &out {
                Ok(inn) if inn.gated => Err(Reject::Gated),
                Ok(_) => Ok(()),
                Err(r) => Err(*r),
            });
        }
        if let Ok(inn) = out.as_mut()
            && !inn.forward_fused
            && self.wheel.watch().run().due(&self.config.wheel)
        {
            let verdict = self.re_examine(rates, inn);
            inn.recovery = Some(verdict);
            self.recovery.record(rates.t(), verdict);
        }
        debug_assert!(covariance::looks_valid(&self.p));
        out
    }

    /// Asks the most trusted witness about the velocity after a run of gated
    /// wheel samples and resets it if the witness says so (see
    /// [`crate::recovery`]).
    fn re_examine(&mut self, rates: &WheelRates, inn: &WheelInnovation) -> Verdict {
        let gyro = self.angular_velocity();
        let v = self.robot_velocity();
        let flow = recovery::recent(
            self.flow_max_age_ns(),
            self.flow_witness_at(rates.t()),
            rates.t(),
        );
        let var = self.p.fixed_view::<2, 2>(V, V).trace() * 0.5;
        let run = *self.wheel.watch().run();
        let evidence = Evidence {
            filter_velocity: nalgebra::Vector2::new(v.x, v.y),
            filter_var: var,
            wheel_speed: inn.speed,
            wheel_rim_speed: rim(self.x.radius_left, rates.left())
                .abs()
                .max(rim(self.x.radius_right, rates.right()).abs()),
            wheel_std: self.grip.forward_std(),
            wheel_gate: self.grip.forward_gate(),
            grip: self.grip.grip(),
            flow,
            flow_gate: self.config.flow.map_or(f32::INFINITY, |f| f.gate),
            run: &run,
        };
        let verdict = recovery::re_examine(
            &self.config.recovery,
            &self.config.wheel,
            &evidence,
            &mut self.x,
            &mut self.p,
            &gyro,
        );
        match verdict {
            Verdict::Reset(recovery::ResetSource::Flow) if recovery::wheels_refuted(&evidence) => {
                self.refutation.refute(rates.t());
            }
            Verdict::Reset(_) => self.refutation.clear(),
            _ => {}
        }
        if let Verdict::Reset(_) = verdict {
            self.wheel.end_run();
        }
        verdict
    }

    /// Fuses one optical-flow report at the filter's time; see
    /// [`crate::flow`]. Without a configured flow sensor, or before the
    /// filter starts, every report is [`Reject::NotReady`]; so is one more
    /// than [`crate::config::FlowConfig::max_age_ns`] ahead of the
    /// filter's time (the IMU silent: the report only closes its interval
    /// and witnesses the speed for the gap's wheels), and one that far
    /// behind is [`Reject::OutOfOrder`].
    pub fn fuse_flow(&mut self, sample: &FlowSample) -> Result<FlowFused, Reject> {
        let Some(config) = self.config.flow else {
            return Err(self.flow.refuse(sample.t, Reject::NotReady));
        };
        let (true, Some(now)) = (self.initialised, self.imu_clock.last()) else {
            return Err(self.flow.refuse(sample.t, Reject::NotReady));
        };
        let gyro = self.angular_velocity();
        let factor = weights::std_factor(self.weights.flow);
        let before = self.before_update();
        let out = self.flow.fuse(
            &mut self.x,
            &mut self.p,
            &gyro,
            sample,
            &config,
            now,
            factor,
        );
        // A reset (not a Kalman update) leaves the velocity uncorrelated.
        if !out.as_ref().is_ok_and(|f| f.reset) {
            self.reanchor(before.as_ref());
        }
        debug_assert!(covariance::looks_valid(&self.p));
        out
    }

    /// Fuses a measurement formed outside this crate (a new aid written
    /// against the public API; `tests/new_aid.rs` is a worked example) at
    /// the filter's time: the shared gated update
    /// ([`crate::update::gated_update`]: chi-square gate `gate` on the NIS
    /// when given, Kalman update, injection into the nominal state, error
    /// reset), as the built-in aids run it.
    ///
    /// The aid forms `m` against [`EgoEkf::state`] (and, for its status,
    /// `P H^T` from [`EgoEkf::covariance`]), checks its own sample times
    /// against [`EgoEkf::time`], and keeps its own counts and
    /// [`crate::AidStatus`]. `m.h` must be zero on the pose clone's columns
    /// ([`crate::state::CLONE`]: the bookkeeping of the zero-velocity update
    /// and the camera, see [`crate::camera`]), else [`Reject::Degenerate`].
    /// Before the filter starts every measurement is [`Reject::NotReady`].
    /// On any error the state and covariance are unchanged.
    pub fn fuse_external<const M: usize>(
        &mut self,
        m: &Measurement<M>,
        gate: Option<f32>,
    ) -> Result<UpdateReport, Reject> {
        if !self.initialised || self.imu_clock.last().is_none() {
            return Err(Reject::NotReady);
        }
        let touches_clone = m.h.columns_range(CLONE).iter().any(|v| *v != 0.0);
        if touches_clone {
            return Err(Reject::Degenerate);
        }
        let out = gated_update(&mut self.x, &mut self.p, m, gate);
        debug_assert!(covariance::looks_valid(&self.p));
        out
    }

    /// Sets the grip the surface model derived for the current floor.
    pub fn set_grip(&mut self, grip: GripParams) {
        self.grip = grip;
    }
}
