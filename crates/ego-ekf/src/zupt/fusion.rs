//! Making a zero-velocity update once the still detector says one is due
//! ([`crate::zupt::detector`]): the measurement from [`crate::zupt::model`],
//! the update (ungated), the counters and the update's [`ZuptStatus`].

use vslam_core::{Reject, SampleCounts, Timestamp};

use crate::aid_status::{AidOutcome, AidStatus, ZuptStatus, diagonal};
use crate::config::ZuptConfig;
use crate::observability;
use crate::state::{Covariance, NominalState};
use crate::update::gated_update_reporting;
use crate::zupt::model::zupt_measurement;

/// The zero-velocity update's counters and status.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ZuptFusion {
    counts: SampleCounts,
    status: Option<ZuptStatus>,
}

impl ZuptFusion {
    /// Nothing counted.
    pub const fn new() -> Self {
        ZuptFusion {
            counts: SampleCounts::new(),
            status: None,
        }
    }

    /// Zero-velocity updates fused and rejected.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// The status after the latest zero-velocity update.
    pub fn status(&self) -> Option<&ZuptStatus> {
        self.status.as_ref()
    }

    /// Makes one zero-velocity update (ungated) at time `t`, counts it and
    /// keeps its status; with `constrain_heading` its rows projected to be
    /// blind to the heading at the estimate
    /// ([`observability::project`]).
    pub fn fuse(
        &mut self,
        x: &mut NominalState,
        p: &mut Covariance,
        config: &ZuptConfig,
        constrain_heading: bool,
        t: Timestamp,
    ) -> Result<(), Reject> {
        let mut m = zupt_measurement(x, config);
        if constrain_heading {
            observability::project(&mut m, x);
        }
        let (result, s) = gated_update_reporting(x, p, &m, None);
        let outcome = result.map(|_| ());
        self.counts.record(outcome);
        let status = AidStatus::new(t, AidOutcome::of(&outcome), self.status.as_ref())
            .with_observation(
                [0.0; 9],
                core::array::from_fn(|i| m.noise.get((i, i)).copied().unwrap_or(f32::NAN)),
            )
            .with_innovation(m.residual.data.0[0], diagonal(s.as_ref()))
            .with_test(result.map_or(f32::NAN, |r| r.nis), None);
        self.status = Some(status);
        outcome
    }
}
