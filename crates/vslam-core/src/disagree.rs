//! Disagreement between one sensor's own motion over an interval and the
//! fused estimate's motion over the same interval: the adverse event of seed
//! 000 [0088], "a measurement pose versus the localisation pose beyond a
//! threshold", with the threshold from the covariances.
//!
//! The fused motion ([`FusedMotion`]) is the filter's relative pose between
//! two times (its pose at the first, held in a clone, and at the second)
//! with its 6x6 covariance (rotation vector, then translation, in the frame
//! at the first time). Each sensor's motion over the interval is compared
//! with the matching part of it; the residual `r` with the sum of the two
//! covariances `S = C_fused + C_sensor` gives the normalised squared
//! distance `r^T S^-1 r`, which for agreeing sensors is chi-square with as
//! many degrees of freedom as `r` has components, and is tested against the
//! chi-square quantile of [`Gates::probability`] ([`Gates`]):
//!
//! - wheels: the travelled distance and the heading change (2 dof);
//! - flow: the travelled distance (1 dof);
//! - camera: the rotation and, with a metric scale, the translation (3 or
//!   6 dof): the filter's camera innovation before the update;
//! - IMU: the heading change from the bias-corrected gyro (1 dof).
//!
//! Every check ends as a [`Verdict`]: agree, disagree, or skipped with a
//! [`SkipReason`]; [`DisagreementCounts`] counts them per sensor. The
//! functions here are the maths only; when to check is the caller's.

use nalgebra::{SMatrix, SVector};

use crate::adverse::SensorKind;
use crate::geometry::{Mat3, Vec3};

/// The fused estimate's relative pose over an interval: rotation vector and
/// translation of the frame at the end in the frame at the start, and their
/// joint covariance (rotation rows first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FusedMotion {
    /// Rotation vector (axis times angle), rad.
    pub rotation: Vec3,
    /// Translation, m.
    pub translation: Vec3,
    /// Covariance of `[rotation; translation]`.
    pub covariance: SMatrix<f32, 6, 6>,
}

impl FusedMotion {
    /// The horizontal distance travelled (the chord) and its variance: the
    /// translation's covariance along the direction of travel (the mean of
    /// the two horizontal variances when the distance is below 1 mm and the
    /// direction undefined).
    pub fn distance(&self) -> (f32, f32) {
        let (d, j) = self.distance_row();
        (d, quadratic(&self.covariance, &j))
    }

    /// The heading change (the rotation vector's vertical component) and
    /// its variance, rad and rad^2.
    pub fn yaw(&self) -> (f32, f32) {
        let var = self.covariance.get((2, 2)).copied().unwrap_or(f32::NAN);
        (self.rotation.z, var)
    }

    /// The distance and its row of the Jacobian with respect to
    /// `[rotation; translation]`.
    fn distance_row(&self) -> (f32, SVector<f32, 6>) {
        let (x, y) = (self.translation.x, self.translation.y);
        let d = libm::sqrtf(x * x + y * y);
        let (ux, uy) = if d > 1e-3 {
            (x / d, y / d)
        } else {
            let h = core::f32::consts::FRAC_1_SQRT_2;
            (h, h)
        };
        (d, SVector::<f32, 6>::new(0.0, 0.0, 0.0, ux, uy, 0.0))
    }
}

/// `j^T c j`.
fn quadratic(c: &SMatrix<f32, 6, 6>, j: &SVector<f32, 6>) -> f32 {
    j.dot(&(c * j))
}

/// A scalar reading with its variance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// The value.
    pub value: f32,
    /// Its variance (the sensor's own noise over the interval).
    pub var: f32,
}

/// Chi-square quantiles the normalised squared distance is tested against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gates {
    /// The probability an agreeing sensor passes (the quantiles below are
    /// this probability's, kept for reports).
    pub probability: f32,
    /// Quantile with 1 degree of freedom.
    pub dof1: f32,
    /// With 2.
    pub dof2: f32,
    /// With 3.
    pub dof3: f32,
    /// With 6.
    pub dof6: f32,
}

impl Gates {
    /// The 99.9 % quantiles (an agreeing sensor disagrees once in a
    /// thousand intervals).
    pub const DEFAULT: Gates = Gates {
        probability: 0.999,
        dof1: 10.828,
        dof2: 13.816,
        dof3: 16.266,
        dof6: 22.458,
    };
}

impl Default for Gates {
    /// [`Gates::DEFAULT`].
    fn default() -> Self {
        Gates::DEFAULT
    }
}

/// Why a check was not made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum SkipReason {
    /// The filter had no motion over the interval (not started, still, or
    /// no pose clone at the interval's start).
    NoFused = 0,
    /// The sensor's samples covered too little of the interval.
    NoData = 1,
    /// The sensor's own quality was too low to test (flow below its
    /// minimum confidence, a camera pair without confidence).
    LowQuality = 2,
    /// The residual or the covariance was not finite, or the covariance not
    /// positive definite.
    Degenerate = 3,
}

impl SkipReason {
    /// How many reasons.
    pub const COUNT: usize = 4;
    /// Every reason, in order.
    pub const ALL: [SkipReason; 4] = [
        SkipReason::NoFused,
        SkipReason::NoData,
        SkipReason::LowQuality,
        SkipReason::Degenerate,
    ];

    /// The reason's report name.
    pub const fn name(self) -> &'static str {
        match self {
            SkipReason::NoFused => "no_fused",
            SkipReason::NoData => "no_data",
            SkipReason::LowQuality => "low_quality",
            SkipReason::Degenerate => "degenerate",
        }
    }
}

/// How one check ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// Within the gate: the normalised squared distance.
    Agree(f32),
    /// Beyond the gate: the normalised squared distance.
    Disagree(f32),
    /// Not checked, and why.
    Skipped(SkipReason),
}

/// `r^T S^-1 r` tested against `gate`.
pub fn test<const M: usize>(r: &SVector<f32, M>, s: &SMatrix<f32, M, M>, gate: f32) -> Verdict {
    if !(r.iter().all(|v| v.is_finite()) && s.iter().all(|v| v.is_finite())) {
        return Verdict::Skipped(SkipReason::Degenerate);
    }
    let Some(c) = s.cholesky() else {
        return Verdict::Skipped(SkipReason::Degenerate);
    };
    let Some(z) = c.l().solve_lower_triangular(r) else {
        return Verdict::Skipped(SkipReason::Degenerate);
    };
    let d2 = z.norm_squared();
    if !d2.is_finite() {
        Verdict::Skipped(SkipReason::Degenerate)
    } else if d2 > gate {
        Verdict::Disagree(d2)
    } else {
        Verdict::Agree(d2)
    }
}

/// The wheels: their travelled distance and heading change against the
/// fused motion's (2 dof). The distance is the chord, so a heading change
/// over the interval shortens it as it does the fused one.
pub fn wheels(distance: Reading, yaw: Reading, fused: &FusedMotion, gates: &Gates) -> Verdict {
    let (d, jd) = fused.distance_row();
    let jy = SVector::<f32, 6>::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    let r = SVector::<f32, 2>::new(distance.value - d, yaw.value - fused.rotation.z);
    let c = &fused.covariance;
    let cross = jd.dot(&(c * jy));
    let s = SMatrix::<f32, 2, 2>::new(
        quadratic(c, &jd) + distance.var,
        cross,
        cross,
        quadratic(c, &jy) + yaw.var,
    );
    test(&r, &s, gates.dof2)
}

/// The flow sensor: its travelled distance against the fused one (1 dof).
pub fn flow(distance: Reading, fused: &FusedMotion, gates: &Gates) -> Verdict {
    scalar(distance, fused.distance(), gates.dof1)
}

/// The IMU: the heading change of the bias-corrected gyro against the fused
/// one (1 dof).
pub fn imu(yaw: Reading, fused: &FusedMotion, gates: &Gates) -> Verdict {
    scalar(yaw, fused.yaw(), gates.dof1)
}

fn scalar(sensor: Reading, (f, f_var): (f32, f32), gate: f32) -> Verdict {
    let r = SVector::<f32, 1>::new(sensor.value - f);
    let s = SMatrix::<f32, 1, 1>::new(sensor.var + f_var);
    test(&r, &s, gate)
}

/// The camera: its rotation vector (each angle with variance
/// `rotation_var`) and, with a metric scale, its translation and
/// covariance, against the fused motion (6 dof, or 3 for the rotation
/// alone).
pub fn camera(
    rotation: &Vec3,
    rotation_var: f32,
    translation: Option<(&Vec3, &Mat3)>,
    fused: &FusedMotion,
    gates: &Gates,
) -> Verdict {
    let c = &fused.covariance;
    match translation {
        Some((t, t_cov)) => {
            let mut r = SVector::<f32, 6>::zeros();
            r.fixed_rows_mut::<3>(0)
                .copy_from(&(rotation - fused.rotation));
            r.fixed_rows_mut::<3>(3).copy_from(&(t - fused.translation));
            let mut sensor = SMatrix::<f32, 6, 6>::zeros();
            sensor
                .fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&(Mat3::identity() * rotation_var));
            sensor.fixed_view_mut::<3, 3>(3, 3).copy_from(t_cov);
            test(&r, &(c + sensor), gates.dof6)
        }
        None => {
            let r = rotation - fused.rotation;
            let s = c.fixed_view::<3, 3>(0, 0).into_owned() + Mat3::identity() * rotation_var;
            test(&r, &s, gates.dof3)
        }
    }
}

/// One sensor's checks: agreed, disagreed, skipped by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SensorChecks {
    /// Checks within the gate.
    pub agree: u32,
    /// Checks beyond the gate.
    pub disagree: u32,
    /// Checks not made, by [`SkipReason`].
    pub skipped: [u32; SkipReason::COUNT],
    /// Disagreements recorded in the adverse-event memory (one per
    /// episode; see the caller).
    pub recorded: u32,
}

impl SensorChecks {
    /// Every check counted.
    pub fn total(&self) -> u32 {
        self.skipped
            .iter()
            .fold(self.agree.saturating_add(self.disagree), |a, b| {
                a.saturating_add(*b)
            })
    }

    /// Checks skipped for `reason`.
    pub fn skipped_for(&self, reason: SkipReason) -> u32 {
        self.skipped.get(reason as usize).copied().unwrap_or(0)
    }
}

/// Every sensor's checks, indexed by [`SensorKind`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DisagreementCounts {
    sensors: [SensorChecks; SensorKind::COUNT],
}

impl DisagreementCounts {
    /// Nothing counted.
    pub const fn new() -> Self {
        DisagreementCounts {
            sensors: [SensorChecks {
                agree: 0,
                disagree: 0,
                skipped: [0; SkipReason::COUNT],
                recorded: 0,
            }; SensorKind::COUNT],
        }
    }

    /// Counts `verdict` for `sensor`.
    pub fn count(&mut self, sensor: SensorKind, verdict: Verdict) {
        if let Some(c) = self.sensors.get_mut(sensor as usize) {
            let slot = match verdict {
                Verdict::Agree(_) => &mut c.agree,
                Verdict::Disagree(_) => &mut c.disagree,
                Verdict::Skipped(r) => match c.skipped.get_mut(r as usize) {
                    Some(s) => s,
                    None => return,
                },
            };
            *slot = slot.saturating_add(1);
        }
    }

    /// Counts a disagreement of `sensor` recorded in the memory.
    pub fn count_recorded(&mut self, sensor: SensorKind) {
        if let Some(c) = self.sensors.get_mut(sensor as usize) {
            c.recorded = c.recorded.saturating_add(1);
        }
    }

    /// The checks of `sensor`.
    pub fn of(&self, sensor: SensorKind) -> SensorChecks {
        self.sensors
            .get(sensor as usize)
            .copied()
            .unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fused motion of `d` metres forward and `yaw` rad, with standard
    /// deviations `sd` (m) and `sy` (rad) on every component.
    fn fused(d: f32, yaw: f32, sd: f32, sy: f32) -> FusedMotion {
        let mut c = SMatrix::<f32, 6, 6>::zeros();
        for i in 0..3 {
            c[(i, i)] = sy * sy;
            c[(i + 3, i + 3)] = sd * sd;
        }
        FusedMotion {
            rotation: Vec3::new(0.0, 0.0, yaw),
            translation: Vec3::new(d, 0.0, 0.0),
            covariance: c,
        }
    }

    fn r(value: f32, sd: f32) -> Reading {
        Reading {
            value,
            var: sd * sd,
        }
    }

    #[test]
    fn the_gate_scales_with_the_covariance() {
        let g = Gates::default();
        let f = fused(0.030, 0.0, 0.002, 0.001);
        // 1 cm off: 3.5 sigma of a 2 mm + 2 mm sum, beyond the 99.9 % gate
        // (3.29 sigma) ...
        assert!(matches!(
            flow(r(0.040, 0.002), &f, &g),
            Verdict::Disagree(_)
        ));
        // ... and within it when the flow itself is noisier (5 mm).
        assert!(matches!(flow(r(0.040, 0.005), &f, &g), Verdict::Agree(_)));
        // The statistic is the normalised squared distance.
        let Verdict::Agree(d2) = flow(r(0.033, 0.002), &f, &g) else {
            panic!("3 mm is within the gate");
        };
        assert!((d2 - (0.003 * 0.003) / 8e-6).abs() < 1e-3, "{d2}");
    }

    #[test]
    fn wheels_disagree_on_distance_or_heading() {
        let g = Gates::default();
        let f = fused(0.030, 0.05, 0.002, 0.005);
        let ok = wheels(r(0.031, 0.001), r(0.052, 0.005), &f, &g);
        assert!(matches!(ok, Verdict::Agree(_)), "{ok:?}");
        // Slipping: the wheels turned twice as far as the robot moved.
        let slip = wheels(r(0.060, 0.001), r(0.05, 0.005), &f, &g);
        assert!(matches!(slip, Verdict::Disagree(_)), "{slip:?}");
        // One wheel spun: the heading change is 0.1 rad off.
        let turn = wheels(r(0.030, 0.001), r(0.15, 0.005), &f, &g);
        assert!(matches!(turn, Verdict::Disagree(_)), "{turn:?}");
    }

    #[test]
    fn the_camera_is_tested_on_rotation_and_translation() {
        let g = Gates::default();
        let f = fused(0.030, 0.02, 0.002, 0.002);
        let rot = Vec3::new(0.0, 0.0, 0.021);
        let cov = Mat3::identity() * 4e-6;
        let t_ok = Vec3::new(0.031, 0.0, 0.0);
        assert!(matches!(
            camera(&rot, 1e-6, Some((&t_ok, &cov)), &f, &g),
            Verdict::Agree(_)
        ));
        // A wrong scale: 6 cm instead of 3.
        let t_bad = Vec3::new(0.060, 0.0, 0.0);
        assert!(matches!(
            camera(&rot, 1e-6, Some((&t_bad, &cov)), &f, &g),
            Verdict::Disagree(_)
        ));
        // Without a scale only the rotation counts.
        assert!(matches!(
            camera(&rot, 1e-6, None, &f, &g),
            Verdict::Agree(_)
        ));
        let rot_bad = Vec3::new(0.0, 0.0, 0.08);
        assert!(matches!(
            camera(&rot_bad, 1e-6, None, &f, &g),
            Verdict::Disagree(_)
        ));
    }

    #[test]
    fn the_imu_is_tested_on_heading() {
        let g = Gates::default();
        let f = fused(0.0, 0.10, 0.001, 0.002);
        assert!(matches!(imu(r(0.101, 0.001), &f, &g), Verdict::Agree(_)));
        assert!(matches!(imu(r(0.13, 0.001), &f, &g), Verdict::Disagree(_)));
    }

    #[test]
    fn bad_numbers_are_skipped_not_judged() {
        let g = Gates::default();
        let f = fused(0.03, 0.0, 0.002, 0.001);
        assert_eq!(
            flow(r(f32::NAN, 0.001), &f, &g),
            Verdict::Skipped(SkipReason::Degenerate)
        );
        // A zero total variance is not positive definite.
        let exact = fused(0.03, 0.0, 0.0, 0.0);
        assert_eq!(
            flow(r(0.03, 0.0), &exact, &g),
            Verdict::Skipped(SkipReason::Degenerate)
        );
    }

    #[test]
    fn counts_add_up_per_sensor() {
        let mut c = DisagreementCounts::new();
        c.count(SensorKind::Wheel, Verdict::Agree(1.0));
        c.count(SensorKind::Wheel, Verdict::Disagree(30.0));
        c.count(SensorKind::Wheel, Verdict::Skipped(SkipReason::NoData));
        c.count(SensorKind::Camera, Verdict::Skipped(SkipReason::NoFused));
        c.count_recorded(SensorKind::Wheel);
        let w = c.of(SensorKind::Wheel);
        assert_eq!((w.agree, w.disagree, w.recorded, w.total()), (1, 1, 1, 3));
        assert_eq!(w.skipped_for(SkipReason::NoData), 1);
        assert_eq!(c.of(SensorKind::Camera).skipped_for(SkipReason::NoFused), 1);
        assert_eq!(c.of(SensorKind::Flow).total(), 0);
    }
}
