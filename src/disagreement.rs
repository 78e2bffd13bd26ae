//! When and with what the estimator checks each sensor against the fused
//! estimate (seed 000 [0088]; the tests themselves: `vslam_core::disagree`).
//!
//! Once per camera frame pair, before the pair is fused, the filter's own
//! motion since its pose clone at the pair's first frame
//! ([`EgoEkf::relative_motion`], with its covariance) is compared with each
//! sensor's motion over the same interval as the scale pipeline summed it
//! for the pair's [`FrameDecision`]:
//!
//! - wheels: the distance (the scale pipeline's `Tw`, for the camera's
//!   optical centre) and the heading change, each with the pipeline's wheel
//!   noise at full confidence (`rel_sigma`, `floor_sigma`; the heading's
//!   from the two wheels' path noise over the track);
//! - flow: its distance `To` with the pipeline's flow noise, when its own
//!   confidence reaches the slip test's minimum;
//! - camera: the pair's rotation and, with a scale, its metric translation
//!   in the IMU frame, with the filter's camera noise (the filter's
//!   innovation before the update);
//! - IMU: the gyro's heading change, corrected with the filter's gyro bias
//!   and scale, with the gyro's white noise and the bias's uncertainty.
//!
//! A sensor beyond the gate is an [`AdverseKind::Disagreement`] event of
//! that sensor where the robot is (one per episode:
//! `ScalePipeline::record_event`); every check is counted
//! ([`DisagreementCounts`]).

use ego_ekf::EgoEkf;
use ego_ekf::camera::model::imu_motion;
use vslam_core::adverse::{AdverseKind, SensorKind};
use vslam_core::disagree::{
    self, DisagreementCounts, FusedMotion, Gates, Reading, SkipReason, Verdict,
};
use vslam_core::scale::{CameraMotion, FrameDecision, PipelineConfig, ScalePipeline, Transaction};

/// The checks of one frame pair, in [`SensorKind::ALL`] order.
pub type FrameVerdicts = [Verdict; SensorKind::COUNT];

/// The checks' gates and counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DisagreementCheck {
    gates: Gates,
    counts: DisagreementCounts,
    last: Option<FrameVerdicts>,
}

impl DisagreementCheck {
    /// No checks yet, with `gates`.
    pub const fn new(gates: Gates) -> Self {
        DisagreementCheck {
            gates,
            counts: DisagreementCounts::new(),
            last: None,
        }
    }

    /// The gates.
    pub fn gates(&self) -> &Gates {
        &self.gates
    }

    /// The verdicts of the latest frame pair checked.
    pub fn last(&self) -> Option<&FrameVerdicts> {
        self.last.as_ref()
    }

    /// Every check so far.
    pub fn counts(&self) -> &DisagreementCounts {
        &self.counts
    }

    /// Checks the pair `motion` (whose scale decision is `decision`)
    /// against `ekf` before the pair is fused, counts the verdicts and
    /// records each disagreement in `scale`'s memory.
    pub fn on_frame<const N: usize, const W: usize>(
        &mut self,
        ekf: &EgoEkf,
        motion: &CameraMotion,
        decision: &FrameDecision,
        camera_scale: Option<(f32, f32)>,
        scale: &mut ScalePipeline<N, W>,
    ) -> FrameVerdicts {
        let verdicts = frame_verdicts(
            ekf,
            motion,
            decision,
            camera_scale,
            scale.config(),
            &self.gates,
        );
        for (sensor, verdict) in SensorKind::ALL.iter().zip(verdicts.iter()) {
            self.counts.count(*sensor, *verdict);
            if matches!(verdict, Verdict::Disagree(_))
                && scale.record_event(*sensor, AdverseKind::Disagreement, decision.t1) == Ok(true)
            {
                self.counts.count_recorded(*sensor);
            }
        }
        self.last = Some(verdicts);
        verdicts
    }
}

/// The four checks of one frame pair (see the module doc).
pub fn frame_verdicts(
    ekf: &EgoEkf,
    motion: &CameraMotion,
    decision: &FrameDecision,
    camera_scale: Option<(f32, f32)>,
    cfg: &PipelineConfig,
    gates: &Gates,
) -> FrameVerdicts {
    let skipped = [Verdict::Skipped(SkipReason::NoFused); SensorKind::COUNT];
    let Some(fused) = ekf
        .relative_motion(decision.t1)
        .filter(|f| f.t0 == decision.t0)
    else {
        return skipped;
    };
    let dt = decision.t1.seconds_since(decision.t0).unwrap_or(0.0);
    [
        wheels(ekf, decision, cfg, &fused.camera_point, gates),
        flow(decision, cfg, &fused.camera_point, gates),
        camera(ekf, motion, decision, camera_scale, &fused.imu, gates),
        imu(ekf, decision, dt, &fused.imu, gates),
    ]
}

fn wheels(
    ekf: &EgoEkf,
    d: &FrameDecision,
    cfg: &PipelineConfig,
    fused: &FusedMotion,
    gates: &Gates,
) -> Verdict {
    if d.wheel.coverage < cfg.min_wheel_coverage {
        return Verdict::Skipped(SkipReason::NoData);
    }
    let var = Transaction::variance_for(
        d.wheel.metres,
        cfg.wheel.rel_sigma,
        cfg.wheel.floor_sigma,
        1.0,
    );
    let robot = &ekf.config().robot;
    let track = (robot.p_bl - robot.p_br).norm();
    let yaw_var = if track > 0.0 {
        2.0 * var / (track * track)
    } else {
        f32::INFINITY
    };
    disagree::wheels(
        Reading {
            value: d.wheel.metres,
            var,
        },
        Reading {
            value: d.wheel_yaw,
            var: yaw_var,
        },
        fused,
        gates,
    )
}

fn flow(d: &FrameDecision, cfg: &PipelineConfig, fused: &FusedMotion, gates: &Gates) -> Verdict {
    if d.flow.coverage < cfg.min_wheel_coverage {
        return Verdict::Skipped(SkipReason::NoData);
    }
    // The confidence before the memory's weight: the sensor's own quality.
    let own = if d.flow_weight > 0.0 {
        d.flow.confidence / d.flow_weight
    } else {
        0.0
    };
    if own < cfg.slip.min_flow_confidence {
        return Verdict::Skipped(SkipReason::LowQuality);
    }
    let var =
        Transaction::variance_for(d.flow.metres, cfg.flow.rel_sigma, cfg.flow.floor_sigma, 1.0);
    disagree::flow(
        Reading {
            value: d.flow.metres,
            var,
        },
        fused,
        gates,
    )
}

fn camera(
    ekf: &EgoEkf,
    motion: &CameraMotion,
    d: &FrameDecision,
    camera_scale: Option<(f32, f32)>,
    fused: &FusedMotion,
    gates: &Gates,
) -> Verdict {
    let Some(config) = ekf.config().camera else {
        return Verdict::Skipped(SkipReason::NoFused);
    };
    if d.camera_confidence <= 0.0 {
        return Verdict::Skipped(SkipReason::LowQuality);
    }
    let m = imu_motion(&config, motion.r(), motion.t_over_d(), camera_scale);
    let rotation = m.rotation.scaled_axis();
    let translation = m.translation.filter(|_| config.translation);
    disagree::camera(
        &rotation,
        config.rotation_std * config.rotation_std,
        translation.as_ref().map(|(t, c)| (t, c)),
        fused,
        gates,
    )
}

fn imu(ekf: &EgoEkf, d: &FrameDecision, dt: f32, fused: &FusedMotion, gates: &Gates) -> Verdict {
    let Some(raw) = d.imu_yaw.filter(|_| dt > 0.0) else {
        return Verdict::Skipped(SkipReason::NoData);
    };
    let mean_rate = ego_ekf::state::Vec3::new(0.0, 0.0, raw / dt);
    let yaw = ekf.state().corrected_gyro(&mean_rate).z * dt;
    let noise = &ekf.config().imu.noise;
    let bias = ekf.gyro_bias_std().z * dt;
    let scale = ekf.gyro_scale_std() * yaw;
    let var = noise.gyro_density * noise.gyro_density * dt + bias * bias + scale * scale;
    disagree::imu(Reading { value: yaw, var }, fused, gates)
}
