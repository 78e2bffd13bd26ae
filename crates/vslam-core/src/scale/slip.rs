//! Slip: how much of the wheels' reported motion over one frame interval was
//! not real motion, from four independent kinds of evidence (seed: slip
//! detection; Ojeda & Borenstein 2004 for wheel-vs-gyro, Reina et al. 2006 for
//! wheel-vs-IMU and wheel-vs-optical-flow slip indicators):
//!
//! 1. wheel vs flow path disagreement, `|Tw - To| / max(Tw, To)`, when the flow
//!    is trustworthy;
//! 2. wheels turning while the camera sees no translation (spinning in place);
//! 3. wheel-derived yaw rate vs the gyro, wheel acceleration vs the
//!    accelerometer;
//! 4. discontinuities in the wheel data (gaps, rejected glitches);
//! 5. wheels and camera both moving but disagreeing (seed [0136]): the wheel
//!    path against the camera's metric motion `|T| s` at the running scale.
//!
//! The amount is on the scale of indicator 1 (a fraction of the wheel path);
//! each other indicator is mapped so that its tolerance equals the threshold,
//! and the amount is the largest of them.
//!
//! Per sample, two sensors' measurements of one speed (or path) are compared
//! by [`disagreement`], their normalised squared difference (a 1-DOF
//! chi-square value): the pipeline's wheel-outlier test, the EKF's slip check
//! of the wheels during an IMU gap and its re-examination of a gated run
//! (`ego_ekf::gap::odometry`, `ego_ekf::recovery`) all call it.

/// How far two measurements `a`, `b` of one quantity with variances `var_a`,
/// `var_b` disagree: `(a - b)^2 / (var_a + var_b)`, a 1-DOF chi-square value
/// (compare it with a gate such as 9 for three standard deviations). The
/// summed variance is kept at or above `f32::MIN_POSITIVE`; non-finite
/// inputs give a non-finite or NaN value, which fails every `<=` test.
#[inline]
pub fn disagreement(a: f32, var_a: f32, b: f32, var_b: f32) -> f32 {
    let d = a - b;
    d * d / (var_a + var_b).max(f32::MIN_POSITIVE)
}

/// Everything the slip check looks at over one interval.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlipEvidence {
    /// Interval length, seconds.
    pub dt: f32,
    /// Wheel path `Tw`, metres.
    pub wheel_path: f32,
    /// Wheel heading change, radians.
    pub wheel_yaw: f32,
    /// Wheel forward acceleration, m/s^2, if two samples were seen.
    pub wheel_accel: Option<f32>,
    /// Gaps and glitches in the wheel data inside the interval.
    pub wheel_discontinuities: u16,
    /// Flow path `To`, metres.
    pub flow_path: f32,
    /// Flow confidence over the interval.
    pub flow_confidence: f32,
    /// Gyro heading change, radians, if the IMU covered the interval.
    pub imu_yaw: Option<f32>,
    /// Mean forward specific force, m/s^2, if the IMU covered the interval.
    pub imu_accel: Option<f32>,
    /// Camera baseline `|T|` (unit-less).
    pub camera_baseline: f32,
    /// Running scale, if known: `|T| * scale` is the camera's metric motion.
    pub scale: Option<f32>,
}

/// Thresholds of the slip check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlipParams {
    /// Slip amount above which the wheels are slipping.
    pub threshold: f32,
    /// Paths below this (metres) are too short to compare.
    pub min_path: f32,
    /// Flow confidence needed to compare wheel and flow.
    pub min_flow_confidence: f32,
    /// Yaw-rate disagreement (rad/s) that counts as the threshold.
    pub yaw_rate_tolerance: f32,
    /// Acceleration disagreement (m/s^2) that counts as the threshold.
    pub accel_tolerance: f32,
    /// Camera motion below this fraction of the wheel path is "no translation".
    pub spin_ratio: f32,
    /// Baseline `|T|` below which the camera sees no translation when no scale is known.
    pub min_baseline: f32,
    /// Wheel/camera relative disagreement `|Tw - |T| s| / max` that counts
    /// as the threshold (looser than wheel/flow: the running scale lags a
    /// change of ceiling height).
    pub camera_tolerance: f32,
}

impl Default for SlipParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SlipParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = SlipParams {
        threshold: 0.15,
        min_path: 0.003,
        min_flow_confidence: 0.3,
        yaw_rate_tolerance: 0.3,
        accel_tolerance: 1.5,
        spin_ratio: 0.2,
        min_baseline: 0.002,
        camera_tolerance: 0.3,
    };
}

/// The indicator that gave the slip amount.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlipCause {
    /// No indicator above zero.
    None,
    /// Wheel and flow paths disagree.
    WheelVsFlow,
    /// Wheels turn, the camera sees no translation.
    SpinInPlace,
    /// Wheel yaw rate disagrees with the gyro.
    WheelVsGyro,
    /// Wheel acceleration disagrees with the accelerometer.
    WheelVsAccel,
    /// The wheel data jump or have gaps.
    Discontinuity,
    /// Wheels and camera both moved but disagree.
    WheelVsCamera,
}

/// The slip check's verdict over one interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlipReport {
    /// Slip amount (fraction of the wheel path that was not real), `>= 0`.
    pub amount: f32,
    /// `amount > threshold`.
    pub exceeded: bool,
    /// The indicator that gave the amount.
    pub cause: SlipCause,
    /// `|Tw - To| / max(Tw, To)`, when comparable.
    pub wheel_vs_flow: Option<f32>,
    /// Wheels turned while the camera saw no translation.
    pub spinning: bool,
    /// `|Tw - |T| s| / max(Tw, |T| s)` when both moved and the scale is known.
    pub wheel_vs_camera: Option<f32>,
    /// `|wheel yaw - gyro yaw| / dt`, rad/s.
    pub yaw_rate_error: Option<f32>,
    /// `|wheel accel - accelerometer|`, m/s^2.
    pub accel_error: Option<f32>,
    /// Discontinuities seen.
    pub discontinuities: u16,
}

impl SlipReport {
    /// No slip evidence at all.
    pub const NONE: SlipReport = SlipReport {
        amount: 0.0,
        exceeded: false,
        cause: SlipCause::None,
        wheel_vs_flow: None,
        spinning: false,
        wheel_vs_camera: None,
        yaw_rate_error: None,
        accel_error: None,
        discontinuities: 0,
    };
}

fn finite_or(v: f32, alt: f32) -> f32 {
    if v.is_finite() { v } else { alt }
}

/// Weighs the evidence; non-finite evidence counts as maximal slip on its indicator.
pub fn assess(e: &SlipEvidence, p: &SlipParams) -> SlipReport {
    let mut report = SlipReport::NONE;
    let consider = |amount: f32, cause: SlipCause, report: &mut SlipReport| {
        let a = finite_or(amount, f32::MAX).max(0.0);
        if a > report.amount {
            report.amount = a;
            report.cause = cause;
        }
    };
    let wheel = finite_or(e.wheel_path, f32::MAX);
    let flow = finite_or(e.flow_path, f32::MAX);

    // 1. Wheel vs flow.
    let longest = wheel.max(flow);
    if e.flow_confidence >= p.min_flow_confidence && longest >= p.min_path {
        let r = libm::fabsf(wheel - flow) / longest;
        report.wheel_vs_flow = Some(r);
        consider(r, SlipCause::WheelVsFlow, &mut report);
    }

    // 2. Spinning in place: wheels report a path, the camera did not move.
    if wheel >= p.min_path {
        let still = match e.scale {
            Some(s) => e.camera_baseline * s < p.spin_ratio * wheel,
            None => e.camera_baseline < p.min_baseline,
        };
        if still {
            report.spinning = true;
            consider(1.0, SlipCause::SpinInPlace, &mut report);
        }
    }

    let per_tol = |err: f32, tol: f32| {
        if tol > 0.0 {
            err / tol * p.threshold
        } else {
            f32::MAX
        }
    };
    // 5. Wheels and camera both moving but disagreeing.
    if let Some(s) = e.scale
        && !report.spinning
    {
        let camera = finite_or(e.camera_baseline * s, f32::MAX);
        if wheel >= p.min_path && camera >= p.min_path {
            let r = libm::fabsf(wheel - camera) / wheel.max(camera);
            report.wheel_vs_camera = Some(r);
            consider(
                per_tol(r, p.camera_tolerance),
                SlipCause::WheelVsCamera,
                &mut report,
            );
        }
    }
    // 3. Wheel vs IMU.
    if let Some(g) = e.imu_yaw
        && e.dt > 0.0
    {
        let err = libm::fabsf(e.wheel_yaw - g) / e.dt;
        report.yaw_rate_error = Some(err);
        consider(
            per_tol(err, p.yaw_rate_tolerance),
            SlipCause::WheelVsGyro,
            &mut report,
        );
    }
    if let (Some(aw), Some(ai)) = (e.wheel_accel, e.imu_accel) {
        let err = libm::fabsf(aw - ai);
        report.accel_error = Some(err);
        consider(
            per_tol(err, p.accel_tolerance),
            SlipCause::WheelVsAccel,
            &mut report,
        );
    }

    // 4. Discontinuities: each one counts as the threshold itself.
    report.discontinuities = e.wheel_discontinuities;
    if e.wheel_discontinuities > 0 {
        let a = p.threshold * (1.0 + f32::from(e.wheel_discontinuities)) * 0.75;
        consider(a, SlipCause::Discontinuity, &mut report);
    }

    report.exceeded = report.amount > p.threshold;
    report
}

#[cfg(test)]
mod tests {
    use super::*;

    fn calm() -> SlipEvidence {
        SlipEvidence {
            dt: 0.1,
            wheel_path: 0.03,
            wheel_yaw: 0.01,
            wheel_accel: Some(0.1),
            wheel_discontinuities: 0,
            flow_path: 0.0295,
            flow_confidence: 0.9,
            imu_yaw: Some(0.011),
            imu_accel: Some(0.12),
            camera_baseline: 0.012,
            scale: Some(2.5),
        }
    }

    #[test]
    fn calm_driving_is_not_slip() {
        let r = assess(&calm(), &SlipParams::default());
        assert!(!r.exceeded, "{r:?}");
        assert!(r.amount < 0.05);
    }

    #[test]
    fn each_indicator_can_raise_slip() {
        let p = SlipParams::default();
        let r = assess(
            &SlipEvidence {
                wheel_path: 0.045,
                camera_baseline: 0.018,
                ..calm()
            },
            &p,
        );
        assert!(r.exceeded);
        assert_eq!(r.cause, SlipCause::WheelVsFlow);

        let r = assess(
            &SlipEvidence {
                flow_path: 0.0,
                flow_confidence: 0.0,
                camera_baseline: 0.0001,
                ..calm()
            },
            &p,
        );
        assert!(r.exceeded && r.spinning);
        assert_eq!(r.cause, SlipCause::SpinInPlace);

        let r = assess(
            &SlipEvidence {
                wheel_yaw: 0.06,
                ..calm()
            },
            &p,
        );
        assert!(r.exceeded);
        assert_eq!(r.cause, SlipCause::WheelVsGyro);

        let r = assess(
            &SlipEvidence {
                wheel_accel: Some(2.5),
                ..calm()
            },
            &p,
        );
        assert!(r.exceeded);
        assert_eq!(r.cause, SlipCause::WheelVsAccel);

        let r = assess(
            &SlipEvidence {
                wheel_discontinuities: 1,
                ..calm()
            },
            &p,
        );
        assert!(r.exceeded);
        assert_eq!(r.cause, SlipCause::Discontinuity);

        let r = assess(
            &SlipEvidence {
                wheel_path: f32::NAN,
                ..calm()
            },
            &p,
        );
        assert!(r.exceeded);
    }

    /// Seed [0136]: wheels and camera both moving but disagreeing is slip,
    /// also when no flow sensor can tell.
    #[test]
    fn wheels_and_camera_moving_but_disagreeing_is_slip() {
        let p = SlipParams::default();
        let no_flow = SlipEvidence {
            flow_path: 0.0,
            flow_confidence: 0.0,
            ..calm()
        };
        // The camera saw 0.012 x 2.5 = 3 cm; the wheels agree within 2 %.
        let r = assess(&no_flow, &p);
        assert!(!r.exceeded, "{r:?}");
        assert!(r.wheel_vs_camera.is_some_and(|v| v < 0.02), "{r:?}");
        // The wheels report 5 cm: the camera moved, but 40 % less.
        let r = assess(
            &SlipEvidence {
                wheel_path: 0.05,
                ..no_flow
            },
            &p,
        );
        assert!(r.exceeded && !r.spinning, "{r:?}");
        assert_eq!(r.cause, SlipCause::WheelVsCamera);
        // Without a running scale the camera's motion is not metric.
        let r = assess(
            &SlipEvidence {
                wheel_path: 0.05,
                scale: None,
                ..no_flow
            },
            &p,
        );
        assert_eq!(r.wheel_vs_camera, None);
        assert!(!r.exceeded, "{r:?}");
    }

    #[test]
    fn disagreement_is_the_normalised_squared_difference() {
        assert!((disagreement(0.5, 0.01, 0.3, 0.03) - 1.0).abs() < 1e-5);
        assert_eq!(
            disagreement(0.3, 0.01, 0.5, 0.03),
            disagreement(0.5, 0.01, 0.3, 0.03)
        );
        assert!(disagreement(1.0, 0.0, 0.0, 0.0) > 1e30);
        assert!(disagreement(f32::NAN, 1.0, 0.0, 1.0).is_nan());
    }

    #[test]
    fn low_quality_flow_is_not_compared() {
        let r = assess(
            &SlipEvidence {
                flow_path: 0.0,
                flow_confidence: 0.1,
                ..calm()
            },
            &SlipParams::default(),
        );
        assert_eq!(r.wheel_vs_flow, None);
        assert!(!r.exceeded);
    }
}
