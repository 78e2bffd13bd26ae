//! One status record per aiding source, of one shape for every aid: what the
//! latest sample measured, how it compared with the state, and what the
//! filter did with it.
//!
//! After PX4 EKF2's `estimator_aid_source` messages (`estimator_aid_source2d`
//! and friends: `timestamp_sample`, `observation`, `observation_variance`,
//! `innovation`, `innovation_variance`, `test_ratio`, `fused`,
//! `innovation_rejected`, `time_last_fuse`). `N` is the number of components
//! the aid measures and reports:
//!
//! - wheels, [`WheelStatus`]: the gated rows, forward speed and differential
//!   (the lateral and vertical non-holonomic rows are fused whatever the
//!   gate says; see [`crate::wheel::model`]);
//! - optical flow, [`FlowStatus`]: the robot-origin horizontal velocity;
//! - zero-velocity update, [`ZuptStatus`]: velocity, position against the
//!   clone, attitude against the clone (see [`crate::zupt::model`]);
//! - floor constraint, [`FloorStatus`]: the robot origin's height over the
//!   floor plane and its vertical velocity, world frame (see
//!   [`crate::floor::model`]);
//! - camera, [`CameraStatus`]: a frame pair's rotation and translation of
//!   the IMU frame (see [`crate::camera::model`]).
//!
//! The filter keeps the latest record of each aid
//! ([`crate::EgoEkf::wheel_status`], [`crate::EgoEkf::flow_status`],
//! [`crate::EgoEkf::zupt_status`], [`crate::EgoEkf::floor_status`],
//! [`crate::EgoEkf::camera_status`]). The records only report: nothing in the
//! filter reads them back.

use nalgebra::{SMatrix, SVector};
use vslam_core::{Reject, Timestamp};

use crate::state::DIM;
use crate::update::Measurement;

/// What the filter did with a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AidOutcome {
    /// Fused.
    Fused,
    /// Failed the chi-square gate (for the wheels: the gated rows were not
    /// fused, the others were).
    Gated,
    /// The aid's state was reset to the measurement instead of updated (the
    /// velocity, after a run of gated samples; see [`crate::recovery`]).
    Reset,
    /// Refused for this reason (before or by the maths; not
    /// [`Reject::Gated`], which is [`AidOutcome::Gated`]).
    Rejected(Reject),
}

impl AidOutcome {
    /// The outcome of an update: `Ok` is fused, [`Reject::Gated`] gated.
    pub fn of<T>(result: &Result<T, Reject>) -> Self {
        match result {
            Ok(_) => AidOutcome::Fused,
            Err(Reject::Gated) => AidOutcome::Gated,
            Err(r) => AidOutcome::Rejected(*r),
        }
    }

    /// Whether the measurement changed the state (fused or reset).
    pub const fn changed_state(self) -> bool {
        matches!(self, AidOutcome::Fused | AidOutcome::Reset)
    }
}

/// The status of one aiding source after its latest sample; see the module
/// documentation.
///
/// A sample refused before the maths ran leaves the numeric fields `NaN`:
/// they would describe a measurement that was never formed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidStatus<const N: usize> {
    /// Time of the sample.
    pub t: Timestamp,
    /// What the sensor measured, per component (units of the aid).
    pub observation: [f32; N],
    /// The noise variance given to each component.
    pub observation_var: [f32; N],
    /// Innovation (measured minus predicted), per component.
    pub innovation: [f32; N],
    /// Its predicted variance `H P H^T + R` under the prior, per component.
    pub innovation_var: [f32; N],
    /// The statistic the gate tested: the normalised innovation squared over
    /// all components (for the wheels, the larger of the forward and the
    /// differential 1-DOF values, each gated on its own); `NaN` if not
    /// formed.
    pub nis: f32,
    /// The chi-square gate `nis` was tested against (infinite for an
    /// ungated aid).
    pub gate: f32,
    /// What the filter did with the sample.
    pub outcome: AidOutcome,
    /// Samples gated in a row up to and including this one (the aid's own
    /// count, which a fused sample or a reset ends).
    pub consecutive_gated: u16,
    /// Time of the latest fused sample of this aid, if any.
    pub last_fused: Option<Timestamp>,
}

/// The wheels' status: forward speed (m/s) and differential (the wheels'
/// speed difference, `r_r w_r - r_l w_l`, m/s), both times `1 - s` for the
/// floor's expected slip `s` ([`crate::grip::GripParams::slip`]).
pub type WheelStatus = AidStatus<2>;
/// The optical flow's status: robot-origin horizontal velocity, robot
/// frame, m/s.
pub type FlowStatus = AidStatus<2>;
/// The zero-velocity update's status: velocity (m/s), position against the
/// clone (m), attitude against the clone (rad), world frame.
pub type ZuptStatus = AidStatus<9>;
/// The floor constraint's status: the robot origin's height (m; the
/// observation is the floor plane's height) and vertical velocity (m/s),
/// world frame.
pub type FloorStatus = AidStatus<2>;
/// The camera's status: the IMU frame's rotation between the pair's frames
/// (rotation vector, rad) and its translation (m; `NaN` when only the
/// rotation was measured), in the IMU frame at the first frame (see
/// [`crate::camera::model`]).
pub type CameraStatus = AidStatus<6>;

impl<const N: usize> AidStatus<N> {
    /// The record of a sample taken at `t` with `outcome`, numeric fields
    /// `NaN`, the counters carried over from `previous` (this aid's last
    /// record): `last_fused` moves to `t` if fused; `consecutive_gated` is
    /// the previous count, which the aid sets ([`AidStatus::with_gated_run`]).
    pub fn new(t: Timestamp, outcome: AidOutcome, previous: Option<&Self>) -> Self {
        let last_fused = if outcome == AidOutcome::Fused {
            Some(t)
        } else {
            previous.and_then(|p| p.last_fused)
        };
        AidStatus {
            t,
            observation: [f32::NAN; N],
            observation_var: [f32::NAN; N],
            innovation: [f32::NAN; N],
            innovation_var: [f32::NAN; N],
            nis: f32::NAN,
            gate: f32::INFINITY,
            outcome,
            consecutive_gated: previous.map_or(0, |p| p.consecutive_gated),
            last_fused,
        }
    }

    /// With the aid's count of samples gated in a row.
    #[must_use]
    pub fn with_gated_run(mut self, consecutive_gated: u16) -> Self {
        self.consecutive_gated = consecutive_gated;
        self
    }

    /// With the measurement's observation and its noise variances.
    #[must_use]
    pub fn with_observation(mut self, observation: [f32; N], observation_var: [f32; N]) -> Self {
        self.observation = observation;
        self.observation_var = observation_var;
        self
    }

    /// With the innovation and its variances.
    #[must_use]
    pub fn with_innovation(mut self, innovation: [f32; N], innovation_var: [f32; N]) -> Self {
        self.innovation = innovation;
        self.innovation_var = innovation_var;
        self
    }

    /// With the tested statistic and its gate (`None`: ungated).
    #[must_use]
    pub fn with_test(mut self, nis: f32, gate: Option<f32>) -> Self {
        self.nis = nis;
        self.gate = gate.unwrap_or(f32::INFINITY);
        self
    }

    /// `nis / gate`: above 1 the sample failed the gate; 0 for an ungated
    /// aid; `NaN` if the statistic was not formed.
    pub fn test_ratio(&self) -> f32 {
        self.nis / self.gate
    }

    /// Whether the sample changed the state (fused or reset).
    pub fn fused(&self) -> bool {
        self.outcome.changed_state()
    }
}

/// The innovation covariance `S = H P H^T + R` of `m`, given `pht = P H^T`:
/// for reporting (the update forms its own).
pub fn innovation_covariance<const M: usize>(
    m: &Measurement<M>,
    pht: &SMatrix<f32, DIM, M>,
) -> SMatrix<f32, M, M> {
    m.h * pht + m.noise
}

/// The diagonal of [`innovation_covariance`] only: `H_i (P H^T)_i + R_ii`
/// per row.
pub fn innovation_variances<const M: usize>(
    m: &Measurement<M>,
    pht: &SMatrix<f32, DIM, M>,
) -> [f32; M] {
    core::array::from_fn(|i| {
        let h = m.h.row(i);
        let ph = pht.column(i);
        h.dot(&ph.transpose()) + m.noise.get((i, i)).copied().unwrap_or(f32::NAN)
    })
}

/// The diagonal of an innovation covariance formed by the update
/// ([`crate::update::gated_update_reporting`]); `NaN`s when there is none.
pub fn diagonal<const M: usize>(s: Option<&SMatrix<f32, M, M>>) -> [f32; M] {
    core::array::from_fn(|i| s.and_then(|s| s.get((i, i)).copied()).unwrap_or(f32::NAN))
}

/// The normalised innovation squared `y^T S^-1 y` by Cholesky; `NaN` when
/// `S` is not positive definite.
pub fn nis<const M: usize>(s: &SMatrix<f32, M, M>, y: &SVector<f32, M>) -> f32 {
    s.cholesky().map_or(f32::NAN, |c| {
        let z = c.l().solve_lower_triangular(y);
        z.map_or(f32::NAN, |z| z.norm_squared())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::{Covariance, V};

    fn velocity_measurement(y: [f32; 2], r: f32) -> Measurement<2> {
        let mut h = SMatrix::<f32, 2, DIM>::zeros();
        h[(0, V)] = 1.0;
        h[(1, V + 1)] = 1.0;
        Measurement {
            residual: SVector::<f32, 2>::from(y),
            h,
            noise: SMatrix::<f32, 2, 2>::identity() * r,
        }
    }

    #[test]
    fn innovation_variance_is_prior_plus_noise() {
        let mut p = Covariance::identity() * 0.5;
        p[(V, V + 1)] = 0.1;
        p[(V + 1, V)] = 0.1;
        let m = velocity_measurement([0.3, -0.4], 0.25);
        let pht = m.p_ht(&p);
        let s = innovation_covariance(&m, &pht);
        assert_eq!(innovation_variances(&m, &pht), [0.75, 0.75]);
        assert_eq!(s[(0, 1)], 0.1);
        // y^T S^-1 y for S = [[0.75, 0.1], [0.1, 0.75]].
        let det = 0.75f32 * 0.75 - 0.01;
        let expect = (0.75 * 0.09 - 2.0 * 0.1 * 0.3 * -0.4 + 0.75 * 0.16) / det;
        assert!((nis(&s, &m.residual) - expect).abs() < 1e-5);
        assert!(nis(&(s * -1.0), &m.residual).is_nan());
    }

    #[test]
    fn counters_carry_over_and_refusals_are_nan() {
        let fused = AidStatus::<1>::new(Timestamp(5), AidOutcome::Fused, None)
            .with_observation([1.0], [0.1])
            .with_innovation([0.2], [0.4])
            .with_test(0.1, Some(4.0));
        assert_eq!(fused.last_fused, Some(Timestamp(5)));
        assert!((fused.test_ratio() - 0.025).abs() < 1e-7);
        assert!(fused.fused());
        let gated = AidStatus::<1>::new(Timestamp(6), AidOutcome::Gated, Some(&fused))
            .with_gated_run(1)
            .with_test(9.0, Some(4.0));
        assert_eq!(gated.last_fused, Some(Timestamp(5)));
        assert!(gated.test_ratio() > 1.0 && !gated.fused());
        let refused = AidStatus::<1>::new(
            Timestamp(7),
            AidOutcome::Rejected(Reject::NonFinite),
            Some(&gated),
        );
        assert_eq!(refused.consecutive_gated, 1);
        assert!(refused.innovation[0].is_nan() && refused.test_ratio().is_nan());
        let ungated =
            AidStatus::<1>::new(Timestamp(8), AidOutcome::Fused, None).with_test(3.0, None);
        assert_eq!(ungated.test_ratio(), 0.0);
    }

    #[test]
    fn outcome_of_a_result() {
        assert_eq!(AidOutcome::of(&Ok::<(), Reject>(())), AidOutcome::Fused);
        assert_eq!(AidOutcome::of::<()>(&Err(Reject::Gated)), AidOutcome::Gated);
        assert_eq!(
            AidOutcome::of::<()>(&Err(Reject::Degenerate)),
            AidOutcome::Rejected(Reject::Degenerate)
        );
    }
}
