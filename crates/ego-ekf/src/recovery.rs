//! Never locking out: what to do when the wheels' forward speed keeps failing
//! the gate.
//!
//! A run of gated forward wheel updates means the wheels and the filter's
//! velocity disagree. Either the wheels slip (spinning on carpet, turning
//! while the robot is stuck) and the gate is right, or the filter's velocity
//! has gone wrong (IMU-only dead reckoning during a gap or a slip episode, an
//! IMU glitch, a bad start) and every later update is refused: a lockout. As
//! PX4 EKF2 resets its velocity after a fusion timeout, from the best source
//! it has, the filter re-examines its velocity after
//! [`WheelConfig::reexamine_after_gated`] gated updates in a row and asks the
//! most trusted witness:
//!
//! 1. a recent flow report of valid quality ([`FlowWitness`]): if the flow
//!    disagrees with the filter beyond the flow gate, or if the wheels agree
//!    with the flow, nearer to them than to the filter (two sensors against
//!    the filter), the velocity is reset to the flow; otherwise the wheels
//!    slip: keep gating ([`Verdict::WheelsSlip`]);
//! 2. without flow, the wheels themselves when the filter overruns them
//!    (faster than the turning wheels, or against them: [`overruns`]; wheels
//!    under-read a ground robot's motion only when it is pushed or slides),
//!    or else only if nothing says they slip:
//!    the floor's grip is high ([`RecoveryConfig::wheel_min_grip`]) and the
//!    IMU agrees with the wheels about the motion. The IMU measures
//!    accelerations well and velocity offsets badly; so the run must be one
//!    steady stretch (the forward innovation changes by at most
//!    [`RecoveryConfig::steady_tolerance`]: wheels and IMU saw the same
//!    accelerations, only an offset separates them) whose onset says nothing
//!    against the wheels. While the wheels are fused they correct the
//!    velocity at every sample, so an IMU drift cannot creep over the gate:
//!    a run that begins while the wheels were being fused begins with the
//!    wheels changing speed without the IMU feeling it (a spin-up, a slip
//!    growing) or with the IMU feeling a stop the wheels do not share
//!    (stuck), however gently. Only a discrepancy found after silence (no
//!    fused wheel update for [`RecoveryConfig::silence_ns`]: a wheel or IMU
//!    gap, dead reckoning on the IMU alone) built up while nothing could be
//!    compared, and a jump inside the run that brings the wheels back
//!    towards the filter ends a slip: those onsets are trusted;
//! 3. otherwise keep gating and say so ([`Verdict::NoTrustedSource`]).
//!
//! A reset to the flow while the wheels disagree with it (the filter had
//! drifted, and the wheels spin: a lifted robot's free wheels, the flow
//! seeing the floor stand still) leaves the velocity as uncertain as the
//! flow's mean, loose enough for the spinning wheels to pass the gate. So
//! the flow's verdict against the wheels is kept ([`Refutation`]): their
//! forward speed stays gated while a recent flow witness still disagrees
//! with it, until the witness agrees, the wheels are reset to, or no
//! witness is heard for [`RecoveryConfig::silence_ns`].
//!
//! A reset ([`re_examine`]) replaces the horizontal robot-origin velocity by
//! the source's and its covariance block by the source's variance,
//! uncorrelated (the primitive is [`crate::covariance::reset_velocity`]); a
//! flow reset first combines the flow's forward speed with the wheels' when
//! the two agree ([`confirmed_flow`]). Every verdict is counted
//! ([`RecoveryCounts`]).
//!
//! The other cross-sensor rules live here too: the flow's recent mean as a
//! witness ([`FlowWindow`]) that the robot moves although the wheels stand
//! ([`flow_sees_motion`], for the still detector) and of the forward speed
//! while the IMU is silent ([`speed_witness`], for the gap's wheel dead
//! reckoning); the wheels' gated runs and their onsets ([`WheelWatch`]); and
//! the flow's own way out of a lockout, a reset to the flow after a run of
//! gated flow reports ([`flow_reset_due`]).

use nalgebra::Vector2;
use vslam_core::Timestamp;
use vslam_core::scale::disagreement;

use crate::config::{FlowConfig, RecoveryConfig, WheelConfig};
use crate::covariance::reset_velocity;
use crate::gap::odometry::SpeedWitness;
use crate::state::{Covariance, NominalState, Vec3};

/// Where a reset velocity came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetSource {
    /// The latest valid flow report.
    Flow,
    /// The wheels' forward speed (no lateral motion).
    Wheels,
}

/// What the filter decided at the end of a run of gated wheel updates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The velocity was reset from this source.
    Reset(ResetSource),
    /// The flow agrees with the filter and not with the wheels: they slip,
    /// gating continues.
    WheelsSlip,
    /// No source is trusted (no recent flow; the wheels may slip): gating
    /// continues.
    NoTrustedSource,
}

impl Verdict {
    /// A short snake_case name, stable for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Verdict::Reset(ResetSource::Flow) => "reset_to_flow",
            Verdict::Reset(ResetSource::Wheels) => "reset_to_wheels",
            Verdict::WheelsSlip => "wheels_slip",
            Verdict::NoTrustedSource => "no_trusted_source",
        }
    }
}

/// What the flow said over the last moments: the inverse-variance mean of
/// its recent reports of valid quality and plausible speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowWitness {
    /// When the latest report was taken.
    pub t: Timestamp,
    /// Robot-origin horizontal velocity, robot frame, m/s (the mean).
    pub velocity: Vector2<f32>,
    /// Standard deviation of each component of the mean, m/s.
    pub std: f32,
    /// Reports in the mean.
    pub reports: u16,
}

/// Inverse-variance sums of the reports since `start`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bucket {
    start: Timestamp,
    weight: f32,
    weighted: Vector2<f32>,
    reports: u16,
}

impl Bucket {
    fn new(start: Timestamp) -> Self {
        Bucket {
            start,
            weight: 0.0,
            weighted: Vector2::zeros(),
            reports: 0,
        }
    }
}

/// The flow's recent reports, averaged over a sliding window of fixed memory
/// (two buckets of half the window each). One flow report at low quality is
/// noisy (a tenth of a metre per second on a dull floor); the mean of the
/// last quarter of a second tells a velocity that ran away from one that did
/// not. Reports are white noise to a good approximation (the sensor's counts
/// are quantised and independent); the mean's standard deviation is kept at
/// or above `floor_std` (the sensor's base noise) all the same.
///
/// The mean is the velocity only if the velocity held over the window: when
/// the older half's mean differs from the newer half's beyond
/// [`WINDOW_CHANGE_GATE`] (the robot started, stopped or turned inside the
/// window: a stuck or lifted robot driving on), the older half is stale and
/// the witness is the newer half alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowWindow {
    half_ns: u64,
    floor_std: f32,
    previous: Option<Bucket>,
    current: Option<Bucket>,
    last: Option<Timestamp>,
}

impl FlowWindow {
    /// An empty window `window_ns` long.
    pub const fn new(window_ns: u64, floor_std: f32) -> Self {
        let half_ns = window_ns / 2;
        FlowWindow {
            half_ns: if half_ns > 1 { half_ns } else { 1 },
            floor_std,
            previous: None,
            current: None,
            last: None,
        }
    }

    /// Adds one report taken at `t` (not earlier than the last) with
    /// per-component standard deviation `std`; non-finite or non-positive
    /// noise is ignored.
    pub fn push(&mut self, t: Timestamp, velocity: Vector2<f32>, std: f32) {
        let var = std * std;
        let w = 1.0 / var;
        if !(var > 0.0 && w.is_finite() && velocity.iter().all(|v| v.is_finite())) {
            return;
        }
        let current = match self.current {
            Some(c) if t.nanos_since(c.start).is_some_and(|d| d < self.half_ns) => c,
            other => {
                self.previous = other;
                Bucket::new(t)
            }
        };
        self.current = Some(Bucket {
            weight: current.weight + w,
            weighted: current.weighted + velocity * w,
            reports: current.reports.saturating_add(1),
            ..current
        });
        self.last = Some(t);
    }

    /// The mean of the reports of the last window before `t` (the current
    /// half and, if recent enough, the one before); `None` without reports.
    pub fn witness(&self, t: Timestamp) -> Option<FlowWitness> {
        let current = self.current?;
        let last = self.last?;
        let recent = |b: &Bucket| {
            t.nanos_since(b.start)
                .is_none_or(|d| d <= self.half_ns.saturating_mul(3))
        };
        let steady = |b: &Bucket| self.same_velocity(b, &current);
        let mut sum = Bucket::new(current.start);
        for b in [self.previous.filter(steady), Some(current)]
            .iter()
            .flatten()
            .filter(|b| recent(b))
        {
            sum.weight += b.weight;
            sum.weighted += b.weighted;
            sum.reports = sum.reports.saturating_add(b.reports);
        }
        if sum.weight <= 0.0 || !sum.weight.is_finite() {
            return None;
        }
        let std = libm::sqrtf(1.0 / sum.weight).max(self.floor_std);
        Some(FlowWitness {
            t: last,
            velocity: sum.weighted / sum.weight,
            std,
            reports: sum.reports,
        })
    }
}

/// The chi-square gate (2 DOF, 99 %) on the difference of the flow window's
/// two half means beyond which the velocity changed inside the window
/// ([`FlowWindow`]).
pub const WINDOW_CHANGE_GATE: f32 = 9.21;

impl FlowWindow {
    /// Whether bucket `a`'s mean velocity and `b`'s are the same within
    /// [`WINDOW_CHANGE_GATE`] (each mean's variance at least `floor_std`
    /// squared); an empty bucket changes nothing.
    fn same_velocity(&self, a: &Bucket, b: &Bucket) -> bool {
        if !(a.weight > 0.0 && b.weight > 0.0) {
            return true;
        }
        let floor = self.floor_std * self.floor_std;
        let var = (1.0 / a.weight).max(floor) + (1.0 / b.weight).max(floor);
        let d = a.weighted / a.weight - b.weighted / b.weight;
        // NaN compares false: a non-finite difference keeps the older half out.
        d.norm_squared() <= WINDOW_CHANGE_GATE * var
    }
}

/// A run of consecutive gated forward wheel updates, cut into steady
/// stretches.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GatedRun {
    len: u16,
    steady_len: u16,
    reference: f32,
    previous: f32,
    trusted_onset: bool,
}

impl GatedRun {
    /// No run.
    pub const fn new() -> Self {
        GatedRun {
            len: 0,
            steady_len: 0,
            reference: 0.0,
            previous: 0.0,
            trusted_onset: false,
        }
    }

    /// Gated updates in the run.
    pub fn len(&self) -> u16 {
        self.len
    }

    /// Whether the run is empty (the last update was fused).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Updates in the current steady stretch.
    pub fn steady_len(&self) -> u16 {
        self.steady_len
    }

    /// Whether the current stretch began in a way that says nothing against
    /// the wheels (after silence, or back towards the filter).
    pub fn trusted_onset(&self) -> bool {
        self.trusted_onset
    }

    /// Adds one gated update with forward innovation `forward`, m/s;
    /// `after_silence` if no forward update was fused for the silence time
    /// before it.
    pub fn push(&mut self, config: &RecoveryConfig, forward: f32, after_silence: bool) {
        if self.len == 0 {
            self.start(forward, after_silence);
        } else if libm::fabsf(forward - self.reference) > config.steady_tolerance {
            // A jump inside the run: back towards the filter ends a slip,
            // away from it starts one.
            let towards =
                libm::fabsf(forward) + config.steady_tolerance < libm::fabsf(self.previous);
            self.start(forward, towards);
        } else {
            self.steady_len = self.steady_len.saturating_add(1);
        }
        self.len = self.len.saturating_add(1);
        self.previous = forward;
    }

    fn start(&mut self, forward: f32, trusted: bool) {
        self.steady_len = 1;
        self.reference = forward;
        self.trusted_onset = trusted;
    }

    /// Ends the run (a fused update, or a reset).
    pub fn clear(&mut self) {
        *self = GatedRun::default();
    }

    /// Whether the run has reached a multiple of the re-examination length.
    pub fn due(&self, wheel: &WheelConfig) -> bool {
        wheel.reexamine_after_gated > 0
            && self.len > 0
            && self.len.is_multiple_of(wheel.reexamine_after_gated)
    }
}

/// The wheels' side of the lockout watch: the current run of gated forward
/// updates and when the wheels were last fused, which tells whether a run
/// began after silence (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelWatch {
    run: GatedRun,
    last_fused: Option<Timestamp>,
    resumed: Option<Timestamp>,
}

impl WheelWatch {
    /// Nothing watched yet.
    pub const fn new() -> Self {
        WheelWatch {
            run: GatedRun::new(),
            last_fused: None,
            resumed: None,
        }
    }

    /// The current run of gated updates.
    pub fn run(&self) -> &GatedRun {
        &self.run
    }

    /// Ends the run of gated updates (after a velocity reset).
    pub fn end_run(&mut self) {
        self.run.clear();
    }

    /// Records a gated update at `t` with forward innovation `forward`, m/s.
    pub fn gated(&mut self, config: &RecoveryConfig, t: Timestamp, forward: f32) {
        // Silence: nothing fused for a while, or fusing resumed only just
        // now after such a while (the first samples back may pass the gate
        // and leave the rest of the offset).
        let within = |since: Option<Timestamp>| {
            since.is_some_and(|s| t.nanos_since(s).is_some_and(|d| d <= config.silence_ns))
        };
        let after_silence = !within(self.last_fused) || within(self.resumed);
        self.run.push(config, forward, after_silence);
    }

    /// Records a fused update at `t`: the run ends.
    pub fn fused(&mut self, config: &RecoveryConfig, t: Timestamp) {
        let silent_before = self
            .last_fused
            .is_none_or(|f| t.nanos_since(f).is_none_or(|d| d > config.silence_ns));
        if silent_before {
            self.resumed = Some(t);
        }
        self.run.clear();
        self.last_fused = Some(t);
    }
}

/// What the filter knows when it re-examines its velocity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evidence<'a> {
    /// The filter's robot-origin horizontal velocity, robot frame, m/s.
    pub filter_velocity: Vector2<f32>,
    /// Its variance per component, (m/s)^2.
    pub filter_var: f32,
    /// The wheels' forward speed, m/s.
    pub wheel_speed: f32,
    /// The faster wheel's rim speed, m/s (not below zero): whether the
    /// wheels turn at all (a turn in place has no forward speed).
    pub wheel_rim_speed: f32,
    /// Its standard deviation on the current floor, m/s.
    pub wheel_std: f32,
    /// The wheels' 1-DOF chi-square gate on the current floor.
    pub wheel_gate: f32,
    /// The current floor's grip.
    pub grip: f32,
    /// A recent flow report, if any.
    pub flow: Option<FlowWitness>,
    /// The flow's 2-DOF chi-square gate.
    pub flow_gate: f32,
    /// The gated run.
    pub run: &'a GatedRun,
}

/// The verdict for `evidence`; see the module documentation.
pub fn decide(config: &RecoveryConfig, wheel: &WheelConfig, evidence: &Evidence<'_>) -> Verdict {
    let e = evidence;
    // A vague flow mean (the sensor saw no floor) is no witness.
    let flow = e.flow.filter(|f| f.std <= config.flow_witness_max_std);
    if let Some(f) = flow {
        let d = f.velocity - e.filter_velocity;
        let flow_var = f.std * f.std;
        let flow_vs_filter = d.norm_squared() / (flow_var + e.filter_var).max(f32::MIN_POSITIVE);
        let wheel_vs_flow = disagreement(
            e.wheel_speed,
            e.wheel_std * e.wheel_std,
            f.velocity.x,
            flow_var,
        );
        // The wheels vouch for the flow only when its forward speed is
        // nearer to theirs than to the filter's: a flow too vague to tell
        // the two apart (a lifted robot's sensor, out of focus) agrees with
        // both and decides nothing.
        let forward_vs_filter = d.x * d.x / (flow_var + e.filter_var).max(f32::MIN_POSITIVE);
        let wheels_vouch = wheel_vs_flow <= e.wheel_gate && wheel_vs_flow < forward_vs_filter;
        // NaN compares false: no reset on a non-finite comparison.
        if flow_vs_filter > e.flow_gate || wheels_vouch {
            return Verdict::Reset(ResetSource::Flow);
        }
        return Verdict::WheelsSlip;
    }
    if overruns(config, e) {
        return Verdict::Reset(ResetSource::Wheels);
    }
    let run = e.run;
    if e.grip >= config.wheel_min_grip
        && run.trusted_onset
        && run.steady_len >= wheel.reexamine_after_gated
        && e.wheel_speed.is_finite()
    {
        return Verdict::Reset(ResetSource::Wheels);
    }
    Verdict::NoTrustedSource
}

/// Whether the filter's forward speed overruns the wheels': faster than
/// their forward speed in its direction, or against it, beyond the wheels'
/// gate, while a wheel turns at [`RecoveryConfig::overrun_min_speed`] or
/// more (frozen wheels prove nothing; a turn in place does). A
/// ground robot's wheels do not under-read its motion unless it is pushed
/// or slides (spinning, stuck and lifted robots' wheels read more, not
/// less), so the filter's velocity has drifted on the IMU alone (a tilt
/// leaking gravity, vibration integrated): without a flow witness the
/// wheels are the reset source.
pub fn overruns(config: &RecoveryConfig, evidence: &Evidence<'_>) -> bool {
    let (v, w) = (evidence.filter_velocity.x, evidence.wheel_speed);
    if !(evidence.wheel_rim_speed >= config.overrun_min_speed && v.is_finite() && w.is_finite()) {
        return false;
    }
    // Against the wheels' direction it is the filter's own speed that counts:
    // a filter near rest with the other sign is not overrunning wheels that
    // spin (a lifted robot's free wheels).
    let excess = if v * w >= 0.0 {
        v.abs() - w.abs()
    } else {
        v.abs()
    };
    let var = evidence.filter_var + evidence.wheel_std * evidence.wheel_std;
    // NaN compares false: no reset on a non-finite comparison.
    excess > 0.0 && excess * excess > evidence.wheel_gate * var
}

/// Whether the wheels disagree with the flow witness of `evidence` (its
/// wheels' 1-DOF gate): a reset to that flow leaves them refuted.
pub fn wheels_refuted(evidence: &Evidence<'_>) -> bool {
    evidence.flow.is_some_and(|f| {
        disagreement(
            evidence.wheel_speed,
            evidence.wheel_std * evidence.wheel_std,
            f.velocity.x,
            f.std * f.std,
        ) > evidence.wheel_gate
    })
}

/// The flow's standing verdict against the wheels' forward speed (module
/// docs): set by a reset to a flow that disagreed with the wheels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Refutation {
    /// When a witness last disagreed with the wheels, while refuted.
    confirmed: Option<Timestamp>,
}

impl Refutation {
    /// No standing verdict.
    pub const fn new() -> Self {
        Refutation { confirmed: None }
    }

    /// The wheels are refuted from `t`.
    pub fn refute(&mut self, t: Timestamp) {
        self.confirmed = Some(t);
    }

    /// The refutation is lifted.
    pub fn clear(&mut self) {
        self.confirmed = None;
    }

    /// Whether the wheels are refuted.
    pub fn is_active(&self) -> bool {
        self.confirmed.is_some()
    }

    /// Whether the wheels' forward `speed` (standard deviation `std`, 1-DOF
    /// gate `gate`) at `t` is still refuted by `witness` (recent, or
    /// `None`): a precise witness that disagrees confirms it, one that
    /// agrees lifts it, and so does silence longer than
    /// [`RecoveryConfig::silence_ns`] since the last confirmation.
    pub fn holds(
        &mut self,
        config: &RecoveryConfig,
        t: Timestamp,
        speed: f32,
        std: f32,
        gate: f32,
        witness: Option<FlowWitness>,
    ) -> bool {
        let Some(confirmed) = self.confirmed else {
            return false;
        };
        match witness.filter(|w| w.std <= config.flow_witness_max_std) {
            Some(w) => {
                let d = disagreement(speed, std * std, w.velocity.x, w.std * w.std);
                // NaN compares false: a non-finite comparison lifts it.
                if d > gate {
                    self.confirmed = Some(t);
                } else {
                    self.confirmed = None;
                }
            }
            None => {
                if t.nanos_since(confirmed)
                    .is_some_and(|d| d > config.silence_ns)
                {
                    self.confirmed = None;
                }
            }
        }
        self.confirmed.is_some()
    }
}

/// Decides on `evidence` ([`decide`]) and applies the verdict: a
/// [`Verdict::Reset`] resets the velocity (robot origin, horizontal) from
/// its source, with the source's variance, given the body rate `gyro`. The
/// caller ends the wheels' gated run after a reset.
pub fn re_examine(
    config: &RecoveryConfig,
    wheel: &WheelConfig,
    evidence: &Evidence<'_>,
    x: &mut NominalState,
    p: &mut Covariance,
    gyro: &Vec3,
) -> Verdict {
    let e = evidence;
    let verdict = decide(config, wheel, e);
    let reset = match (verdict, e.flow) {
        (Verdict::Reset(ResetSource::Flow), Some(f)) => Some((confirmed_flow(&f, e), f.std)),
        (Verdict::Reset(ResetSource::Wheels), _) => {
            Some((Vector2::new(e.wheel_speed, 0.0), e.wheel_std))
        }
        _ => None,
    };
    if let Some((z, std)) = reset {
        reset_velocity(x, p, gyro, &z, std);
    }
    verdict
}

/// The flow's velocity, its forward component combined (inverse-variance)
/// with the wheels' speed when the two agree within the wheels' gate: the
/// flow vouches for the wheels, which are the more precise. The variance of
/// the reset stays the flow's (conservative).
pub fn confirmed_flow(flow: &FlowWitness, evidence: &Evidence<'_>) -> Vector2<f32> {
    let var_f = flow.std * flow.std;
    let var_w = evidence.wheel_std * evidence.wheel_std;
    let d = evidence.wheel_speed - flow.velocity.x;
    let agree = d * d <= evidence.wheel_gate * (var_f + var_w);
    let mut z = flow.velocity;
    if agree && var_f + var_w > 0.0 {
        z.x = (flow.velocity.x * var_w + evidence.wheel_speed * var_f) / (var_f + var_w);
    }
    z
}

/// The flow witness if its latest report lies within `max_age_ns`
/// ([`FlowConfig::max_age_ns`]) of `t`.
pub fn recent(max_age_ns: u64, witness: Option<FlowWitness>, t: Timestamp) -> Option<FlowWitness> {
    witness.filter(|w| t.as_nanos().abs_diff(w.t.as_nanos()) <= max_age_ns)
}

/// Whether the flow, recent and precise, sees the robot move at `t`: then
/// wheels that report no motion (frozen counts) cannot make it still.
/// Moving means a mean speed above three of its standard deviations and
/// above 3 cm/s.
pub fn flow_sees_motion(
    config: &RecoveryConfig,
    max_age_ns: u64,
    witness: Option<FlowWitness>,
    t: Timestamp,
) -> bool {
    witness.is_some_and(|w| {
        let recent = t.as_nanos().abs_diff(w.t.as_nanos()) <= max_age_ns;
        let speed = w.velocity.norm();
        recent && w.std <= config.flow_witness_max_std && speed > 0.03_f32.max(3.0 * w.std)
    })
}

/// The flow's forward speed at `t`, if it is recent and precise: the wheels
/// are checked against it while the IMU is silent
/// ([`crate::gap::odometry`]).
pub fn speed_witness(
    config: &RecoveryConfig,
    max_age_ns: u64,
    witness: Option<FlowWitness>,
    t: Timestamp,
) -> Option<SpeedWitness> {
    recent(max_age_ns, witness, t)
        .filter(|w| w.std <= config.flow_witness_max_std)
        .map(|w| SpeedWitness {
            speed: w.velocity.x,
            std: w.std,
        })
}

/// Whether the flow's own run of `gated_run` gated reports ends in a reset
/// of the velocity to the report: after [`FlowConfig::velocity_reset_after_gated`]
/// in a row (0: never), of plausible speed.
pub fn flow_reset_due(config: &FlowConfig, gated_run: u16, plausible: bool) -> bool {
    let n = config.velocity_reset_after_gated;
    n != 0 && gated_run >= n && plausible
}

/// Verdicts counted, and the latest.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecoveryCounts {
    /// Velocity resets to the flow.
    pub resets_to_flow: u32,
    /// Velocity resets to the wheels.
    pub resets_to_wheels: u32,
    /// Re-examinations that found the wheels slipping.
    pub wheels_slip: u32,
    /// Re-examinations without a trusted source.
    pub no_trusted_source: u32,
    /// The latest verdict and when it was made.
    pub last: Option<(Timestamp, Verdict)>,
}

impl RecoveryCounts {
    /// Nothing counted.
    pub const fn new() -> Self {
        RecoveryCounts {
            resets_to_flow: 0,
            resets_to_wheels: 0,
            wheels_slip: 0,
            no_trusted_source: 0,
            last: None,
        }
    }

    /// Counts one verdict made at `t`.
    pub fn record(&mut self, t: Timestamp, verdict: Verdict) {
        let slot = match verdict {
            Verdict::Reset(ResetSource::Flow) => &mut self.resets_to_flow,
            Verdict::Reset(ResetSource::Wheels) => &mut self.resets_to_wheels,
            Verdict::WheelsSlip => &mut self.wheels_slip,
            Verdict::NoTrustedSource => &mut self.no_trusted_source,
        };
        *slot = slot.saturating_add(1);
        self.last = Some((t, verdict));
    }

    /// Resets from any source.
    pub fn resets(&self) -> u32 {
        self.resets_to_flow.saturating_add(self.resets_to_wheels)
    }
}

#[cfg(test)]
mod tests;
