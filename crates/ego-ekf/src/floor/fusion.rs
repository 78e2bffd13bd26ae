//! When to make the floor update, and its bookkeeping: the floor plane's
//! height (anchored where the filter starts), the update every
//! [`FloorConfig::every`] IMU steps, the rows' weights, the counts and the
//! update's [`FloorStatus`].
//!
//! The two rows are treated apart:
//! - vertical velocity: gated (1 degree of freedom,
//!   [`FloorConfig::climb_gate`]). A cable or a threshold strip under a
//!   wheel fails it for an update or two; the update is then counted as
//!   gated and only the height row is fused (as the wheels' gated rows);
//! - height: always fused, but an innovation beyond
//!   [`FloorConfig::height_huber`] standard deviations has its noise raised
//!   until it is at that many (a Huber-type weight). A bump pulls the height
//!   a little; a height the other aids let drift is pulled back, never
//!   locked out.
//!
//! While the wheels and the filter disagree (a run of gated wheel samples:
//! slipping, stuck, or free wheels of a lifted robot) the robot may not be
//! on the floor at all: a due update is suspended, counted in
//! [`FloorFusion::suspended`], and the height is left to the IMU until the
//! wheels agree again. (A lifted robot held to the floor by the constraint
//! is explained by the filter as tilt and accelerometer bias, and its
//! horizontal velocity drifts after it is set down.)
//!
//! A height more than [`FloorConfig::level_change`] from the floor for
//! [`FloorConfig::reanchor_after`] updates in a row is another level (the
//! robot lifted, a ramp, a step between rooms): the floor is re-anchored at
//! the robot's current height, counted in [`FloorFusion::reanchored`].

use nalgebra::SMatrix;
use vslam_core::{Reject, SampleCounts, Timestamp};

use crate::aid_status::{AidOutcome, AidStatus, FloorStatus, innovation_variances};
use crate::config::FloorConfig;
use crate::floor::model::{floor_measurement, origin_height_and_climb};
use crate::state::{Covariance, DIM, NominalState, Vec3};
use crate::update::{Measurement, UpdateReport, gated_update_with};

/// The floor update's anchor, schedule, counters and status.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FloorFusion {
    floor: f32,
    since_update: u16,
    off_level_run: u16,
    reanchored: u32,
    suspended: u32,
    counts: SampleCounts,
    status: Option<FloorStatus>,
}

impl FloorFusion {
    /// Floor at height 0, nothing counted.
    pub const fn new() -> Self {
        FloorFusion {
            floor: 0.0,
            since_update: 0,
            off_level_run: 0,
            reanchored: 0,
            suspended: 0,
            counts: SampleCounts::new(),
            status: None,
        }
    }

    /// Anchors the floor plane at the robot origin's current height (the
    /// filter's start: the robot stands on its floor); the schedule and the
    /// off-level run restart, the counts are kept.
    pub fn anchor(&mut self, x: &NominalState) {
        self.floor = origin_height_and_climb(x, &Vec3::zeros()).0;
        self.since_update = 0;
        self.off_level_run = 0;
    }

    /// The floor plane's world height, m.
    pub fn floor(&self) -> f32 {
        self.floor
    }

    /// Floor updates fused, gated (the vertical-velocity row) and rejected.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Times the floor was re-anchored on a new level.
    pub fn reanchored(&self) -> u32 {
        self.reanchored
    }

    /// Due updates suspended while the wheels disagreed with the filter.
    pub fn suspended(&self) -> u32 {
        self.suspended
    }

    /// The status after the latest floor update.
    pub fn status(&self) -> Option<&FloorStatus> {
        self.status.as_ref()
    }

    /// Counts one IMU step at time `t` and, when an update is due and
    /// `wheels_agree`, makes it with the bias-corrected body rate `gyro`;
    /// returns its outcome (`None` when none was made): `Ok` both rows
    /// fused, [`Reject::Gated`] the vertical-velocity row gated (and the
    /// height fused, if on the floor), another reason nothing fused.
    pub fn step(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        gyro: &Vec3,
        config: &FloorConfig,
        t: Timestamp,
        wheels_agree: bool,
    ) -> Option<Result<(), Reject>> {
        self.since_update = self.since_update.saturating_add(1);
        if self.since_update < config.every {
            return None;
        }
        self.since_update = 0;
        if !wheels_agree {
            self.suspended = self.suspended.saturating_add(1);
            return None;
        }
        let on_floor = self.check_level(x, gyro, config);
        let mut m = floor_measurement(x, gyro, self.floor, config);
        let (result, innovation_var, nis) = fuse_rows(x, p, &mut m, config, on_floor);
        let outcome = result.map(|_| ());
        self.counts.record(outcome);
        let noise_var = core::array::from_fn(|i| m.noise.get((i, i)).copied().unwrap_or(f32::NAN));
        let status = AidStatus::new(t, AidOutcome::of(&outcome), self.status.as_ref())
            .with_gated_run(self.off_level_run)
            .with_observation([self.floor, 0.0], noise_var)
            .with_innovation(m.residual.data.0[0], innovation_var)
            .with_test(nis, Some(config.climb_gate));
        self.status = Some(status);
        Some(outcome)
    }

    /// Whether the robot is on the floor: within
    /// [`FloorConfig::level_change`] of it, or just re-anchored after
    /// [`FloorConfig::reanchor_after`] updates off it.
    fn check_level(&mut self, x: &NominalState, gyro: &Vec3, config: &FloorConfig) -> bool {
        let height = origin_height_and_climb(x, gyro).0;
        if libm::fabsf(height - self.floor) <= config.level_change {
            self.off_level_run = 0;
            return true;
        }
        self.off_level_run = self.off_level_run.saturating_add(1);
        if self.off_level_run < config.reanchor_after {
            return false;
        }
        self.floor = height;
        self.reanchored = self.reanchored.saturating_add(1);
        self.off_level_run = 0;
        true
    }
}

/// Fuses the floor rows of `m` (its height noise raised in place when the
/// Huber weight applies): both rows, or the height alone when the
/// vertical-velocity row fails its gate; off the floor (`on_floor` false)
/// the vertical-velocity row alone, or nothing ([`Reject::Gated`]). Returns
/// the result, the rows' innovation variances under the prior and the
/// vertical-velocity row's NIS (the gated statistic).
fn fuse_rows(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &mut Measurement<2>,
    config: &FloorConfig,
    on_floor: bool,
) -> (Result<UpdateReport, Reject>, [f32; 2], f32) {
    if !m.is_finite() {
        return (Err(Reject::NonFinite), [f32::NAN; 2], f32::NAN);
    }
    let pht = m.p_ht(p);
    let s = innovation_variances(m, &pht);
    let [s_height, s_climb] = s;
    let [y_height, y_climb] = m.residual.data.0[0];
    let climb_nis = y_climb * y_climb / s_climb;
    let height_nis = y_height * y_height / s_height;
    let huber2 = config.height_huber * config.height_huber;
    if height_nis > huber2
        && let Some(r) = m.noise.get_mut((0, 0))
    {
        // Raise R so that y^2 / (H P H^T + R) = huber^2.
        *r += y_height * y_height / huber2 - s_height;
    }
    let climb_ok = climb_nis.is_finite() && climb_nis <= config.climb_gate;
    let result = match (on_floor, climb_ok) {
        (true, true) => gated_update_with(x, p, m, &pht, None),
        (true, false) => fuse_row(x, p, m, &pht, 0).and(Err(Reject::Gated)),
        (false, true) => fuse_row(x, p, m, &pht, 1),
        (false, false) => Err(Reject::Gated),
    };
    (result, s, climb_nis)
}

/// Fuses row `row` of `m` alone (`pht` is `P H^T` of both rows).
fn fuse_row(
    x: &mut NominalState,
    p: &mut Covariance,
    m: &Measurement<2>,
    pht: &SMatrix<f32, DIM, 2>,
    row: usize,
) -> Result<UpdateReport, Reject> {
    let one = m.select([row]).ok_or(Reject::Degenerate)?;
    let column: SMatrix<f32, DIM, 1> = pht.fixed_columns::<1>(row.min(1)).into_owned();
    gated_update_with(x, p, &one, &column, None)
}
