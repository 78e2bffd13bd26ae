//! Making the camera update and its bookkeeping: the gates, the counts, the
//! frames not measured and why, and the update's [`CameraStatus`].
//!
//! A pair with a metric translation (and [`CameraConfig::translation`] on)
//! is tested on all six rows against [`CameraConfig::pose_gate`]; if it
//! fails, the rotation rows alone are tested against
//! [`CameraConfig::rotation_gate`] and fused if they pass (a scale spoiled
//! by slip leaves the rotation good). The pair then counts as gated, as a
//! wheel sample whose gated rows were dropped does. A pair without a
//! scale measures the rotation only.
//!
//! The schedule of the pose clone it shares with the zero-velocity update
//! is the filter's (`crate::filter`): a frame is measured only when the
//! clone holds the pose of the pair's first frame; otherwise it is counted
//! as [`Reject::NotReady`] with its reason in [`CameraSkips`].

use vslam_core::{Reject, SampleCounts, Timestamp};

use crate::aid_status::{AidOutcome, AidStatus, CameraStatus, diagonal, nis};
use crate::camera::model::{ImuMotion, pose_measurement, rotation_measurement};
use crate::config::CameraConfig;
use crate::state::{Covariance, NominalState};
use crate::update::{Measurement, gated_update_reporting};

/// Frames the camera update did not measure, by reason (each also counted
/// as [`Reject::NotReady`]), and pairs whose translation was gated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CameraSkips {
    /// The robot was still: the zero-velocity update owns the clone and a
    /// still camera pair measures nothing it does not.
    pub still: u32,
    /// No clone at the pair's first frame (the first frame after the robot
    /// started moving, after an IMU gap, or after a frame the camera path
    /// refused): the frame only takes the clone.
    pub no_clone: u32,
    /// Pairs whose six rows failed the gate and whose rotation rows were
    /// fused alone (counted as gated).
    pub translation_gated: u32,
}

/// The camera update's counters and status.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraFusion {
    counts: SampleCounts,
    skips: CameraSkips,
    status: Option<CameraStatus>,
    gated_run: u16,
}

impl CameraFusion {
    /// Nothing counted.
    pub const fn new() -> Self {
        CameraFusion {
            counts: SampleCounts::new(),
            skips: CameraSkips {
                still: 0,
                no_clone: 0,
                translation_gated: 0,
            },
            status: None,
            gated_run: 0,
        }
    }

    /// Frame pairs fused, gated and rejected.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Frames not measured, by reason; pairs fused on their rotation alone.
    pub fn skips(&self) -> &CameraSkips {
        &self.skips
    }

    /// The status after the latest frame.
    pub fn status(&self) -> Option<&CameraStatus> {
        self.status.as_ref()
    }

    /// Counts a frame taken at `t` refused for `reason` and returns it.
    pub fn refuse(&mut self, t: Timestamp, reason: Reject) -> Reject {
        self.counts.record(Err(reason));
        self.status = Some(AidStatus::new(
            t,
            AidOutcome::Rejected(reason),
            self.status.as_ref(),
        ));
        reason
    }

    /// Counts a frame at `t` not measured while the robot is still.
    pub fn skip_still(&mut self, t: Timestamp) -> Reject {
        self.skips.still = self.skips.still.saturating_add(1);
        self.refuse(t, Reject::NotReady)
    }

    /// Counts a frame at `t` not measured for want of a clone at its pair's
    /// first frame.
    pub fn skip_no_clone(&mut self, t: Timestamp) -> Reject {
        self.skips.no_clone = self.skips.no_clone.saturating_add(1);
        self.refuse(t, Reject::NotReady)
    }

    /// Makes the update of the pair ending at `t` (the clone holds the pose
    /// of its first frame, the state is at `t`) with the measurement noise
    /// covariance times `noise_factor` (the camera's adverse-memory weight's
    /// inverse; 1 leaves it as the configuration makes it), counts it and
    /// keeps its status: `Ok` all rows fused, [`Reject::Gated`] none or
    /// only the rotation (see the module doc), another reason nothing fused.
    pub fn fuse(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        motion: &ImuMotion,
        config: &CameraConfig,
        noise_factor: f32,
        t: Timestamp,
    ) -> Result<(), Reject> {
        let inflate = |mut m: Measurement<3>| {
            if noise_factor != 1.0 {
                m.noise *= noise_factor;
            }
            m
        };
        let rotation = inflate(rotation_measurement(x, &motion.rotation, config));
        let observed_rotation = motion.rotation.scaled_axis();
        let full = motion
            .translation
            .filter(|_| config.translation)
            .map(|(t_m, cov)| {
                let mut m = pose_measurement(x, &motion.rotation, &t_m, &cov, config);
                if noise_factor != 1.0 {
                    m.noise *= noise_factor;
                }
                (t_m, m)
            });
        let (outcome, record) = match full {
            Some((t_m, m)) => {
                let (result, s) = gated_update_reporting(x, p, &m, Some(config.pose_gate));
                let record = Record::of(&m, s.as_ref(), config.pose_gate, |i| {
                    if i < 3 {
                        observed_rotation.get(i).copied()
                    } else {
                        t_m.get(i - 3).copied()
                    }
                });
                match result {
                    Err(Reject::Gated) => {
                        let (rot, _) = fuse_rotation(x, p, &rotation, config);
                        if rot.is_ok() {
                            self.skips.translation_gated =
                                self.skips.translation_gated.saturating_add(1);
                        }
                        (Err(Reject::Gated), record)
                    }
                    other => (other.map(|_| ()), record),
                }
            }
            None => {
                let (result, record) = fuse_rotation(x, p, &rotation, config);
                let record = Record {
                    observation: core::array::from_fn(|i| {
                        observed_rotation.get(i).copied().unwrap_or(f32::NAN)
                    }),
                    ..record
                };
                (result, record)
            }
        };
        self.counts.record(outcome);
        self.gated_run = match outcome {
            Err(Reject::Gated) => self.gated_run.saturating_add(1),
            Ok(()) => 0,
            Err(_) => self.gated_run,
        };
        let status = AidStatus::new(t, AidOutcome::of(&outcome), self.status.as_ref())
            .with_gated_run(self.gated_run)
            .with_observation(record.observation, record.observation_var)
            .with_innovation(record.innovation, record.innovation_var)
            .with_test(record.nis, Some(record.gate));
        self.status = Some(status);
        outcome
    }
}

/// The numbers of one update for its [`CameraStatus`], six components
/// (the translation's `NaN` for a rotation-only update).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Record {
    observation: [f32; 6],
    observation_var: [f32; 6],
    innovation: [f32; 6],
    innovation_var: [f32; 6],
    nis: f32,
    gate: f32,
}

impl Record {
    /// The record of `m` with innovation covariance `s` (if formed) and
    /// gate `gate`; `observed(i)` is component `i`'s observation.
    fn of<const M: usize>(
        m: &Measurement<M>,
        s: Option<&nalgebra::SMatrix<f32, M, M>>,
        gate: f32,
        observed: impl Fn(usize) -> Option<f32>,
    ) -> Self {
        let s_diag = diagonal(s);
        let pick = |values: &[f32], i: usize| values.get(i).copied().unwrap_or(f32::NAN);
        Record {
            observation: core::array::from_fn(|i| {
                if i < M {
                    observed(i).unwrap_or(f32::NAN)
                } else {
                    f32::NAN
                }
            }),
            observation_var: core::array::from_fn(|i| {
                m.noise.get((i, i)).copied().unwrap_or(f32::NAN)
            }),
            innovation: core::array::from_fn(|i| pick(m.residual.as_slice(), i)),
            innovation_var: core::array::from_fn(|i| pick(&s_diag, i)),
            nis: s.map_or(f32::NAN, |s| nis(s, &m.residual)),
            gate,
        }
    }
}

/// Fuses the rotation rows `m` alone, gated by
/// [`CameraConfig::rotation_gate`].
fn fuse_rotation(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &Measurement<3>,
    config: &CameraConfig,
) -> (Result<(), Reject>, Record) {
    let (result, s) = gated_update_reporting(x, p, m, Some(config.rotation_gate));
    let record = Record::of(m, s.as_ref(), config.rotation_gate, |_| None);
    (result.map(|_| ()), record)
}
