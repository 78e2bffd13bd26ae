//! Per-log terrain statistics of a replay without ground truth (BorealTC):
//! how the wheels' yaw rate compares with the gyroscope's, how consistent
//! the filter's wheel and other aids were (report.json `aids`), what it
//! learned, and the forward wheel noise the per-floor noise learner
//! ([`traction::ego_ekf::surface::learning`]) drives towards.
//!
//! - Yaw-rate residual: per wheel sample interval, the wheels' yaw rate
//!   `(r_r w_r - r_l w_l) / (b * track_factor)` (trapezoid of the interval's
//!   two samples, `wheel0/sensor.yaml` geometry) minus the mean gyroscope
//!   yaw rate over the interval (the IMU's z axis in the body frame by its
//!   `T_BS`); taken where the wheels move (`|v_l| + |v_r| > 0.02` m/s). The
//!   yaw-rate gain is the least-squares `k` of `gyro = k * wheels`: 1 when
//!   the effective track holds, below 1 when the body turns less than the
//!   wheels say (a skid steer on a grippy surface, or wheels that spin).
//! - Path lengths of the EKF's and the wheels' trajectories (horizontal):
//!   with no ground truth, an EKF path far longer than the wheels' is the
//!   filter running away on the IMU while it gates the wheels.
//! - Learned forward noise: the learner moves a floor's forward-noise
//!   multiplier `m` until its mean NIS (each capped at the learner's cap)
//!   is one. Over the log's forward wheel innovations `nu` with predicted
//!   variance `S` and noise variance `R`, it settles where
//!   `mean(min(nu^2 / (S - R + m^2 R), cap)) = 1` (solved here by bisection,
//!   holding the rest of `S` as it was: the open-loop fixed point), within
//!   the learner's bounds. The noise is `m * sqrt(R)`; a larger noise is
//!   less grip. At its default rate the learner needs more than a thousand
//!   wheel samples to move `m` by 4x even with every NIS at the cap; a
//!   BorealTC log has 130 to 850.

use crate::asl::Dataset;
use crate::replay::ReplayOutput;
use serde_json::{Value, json};
use traction::ego_ekf::aid_status::WheelStatus;
use traction::ego_ekf::surface::LearningConfig;

/// Mean, standard deviation and RMS of a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    /// Samples.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Standard deviation (population).
    pub std: f64,
    /// Root mean square.
    pub rms: f64,
}

impl Moments {
    /// Of `v`; zeros when empty.
    pub fn of(v: &[f64]) -> Self {
        if v.is_empty() {
            return Moments::default();
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let ms = v.iter().map(|x| x * x).sum::<f64>() / n;
        Moments {
            n: v.len(),
            mean,
            std: (ms - mean * mean).max(0.0).sqrt(),
            rms: ms.sqrt(),
        }
    }
}

/// The wheels' yaw rate against the gyroscope's over a log.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct YawResidual {
    /// Residual wheels minus gyro, rad/s, where the wheels move.
    pub residual: Moments,
    /// Least-squares gain of gyro on wheels.
    pub gain: f64,
}

/// The yaw-rate residual of a dataset with wheel rates (or ticks) and an
/// IMU; `None` without either.
pub fn yaw_residual(ds: &Dataset) -> Option<YawResidual> {
    let (imu_meta, imu) = ds.imu.as_ref()?;
    // Body yaw rate = third row of R_BS times the sensor's rate.
    let r = &imu_meta.t_bs;
    let row = [f64::from(r[8]), f64::from(r[9]), f64::from(r[10])];
    let gyro_z: Vec<(u64, f64)> = imu
        .iter()
        .map(|s| {
            let g = s.gyro.map(f64::from);
            (s.t.0, row[0] * g[0] + row[1] * g[1] + row[2] * g[2])
        })
        .filter(|(_, z)| z.is_finite())
        .collect();
    // (t, left speed, right speed) in m/s at the contact.
    let (meta, speeds): (_, Vec<(u64, f64, f64)>) = if let Some((m, w)) = &ds.wheel_rates {
        let v = w
            .iter()
            .map(|s| {
                (
                    s.t.0,
                    f64::from(s.left) * m.wheel_radius_left,
                    f64::from(s.right) * m.wheel_radius_right,
                )
            })
            .collect();
        (m, v)
    } else {
        let (m, w) = ds.wheel.as_ref()?;
        let per_tick = std::f64::consts::TAU / m.ticks_per_revolution?;
        let v = w
            .windows(2)
            .filter(|p| p[1].t > p[0].t)
            .map(|p| {
                let dt = (p[1].t.0 - p[0].t.0) as f64 * 1e-9;
                let d = |a: i64, b: i64| (b - a) as f64 * per_tick / dt;
                (
                    p[1].t.0,
                    d(p[0].left, p[1].left) * m.wheel_radius_left,
                    d(p[0].right, p[1].right) * m.wheel_radius_right,
                )
            })
            .collect();
        (m, v)
    };
    let track = meta.wheel_base * meta.track_factor;
    let (mut res, mut sxy, mut sxx) = (Vec::new(), 0.0, 0.0);
    for p in speeds.windows(2) {
        let (a, b) = (p[0], p[1]);
        if b.0 <= a.0 {
            continue;
        }
        let (vl, vr) = (0.5 * (a.1 + b.1), 0.5 * (a.2 + b.2));
        if !(vl.is_finite() && vr.is_finite()) || vl.abs() + vr.abs() <= 0.02 {
            continue;
        }
        let lo = gyro_z.partition_point(|g| g.0 <= a.0);
        let hi = gyro_z.partition_point(|g| g.0 <= b.0);
        let Some(window) = gyro_z.get(lo..hi).filter(|w| !w.is_empty()) else {
            continue;
        };
        let gyro = window.iter().map(|g| g.1).sum::<f64>() / window.len() as f64;
        let wheels = (vr - vl) / track;
        res.push(wheels - gyro);
        sxy += wheels * gyro;
        sxx += wheels * wheels;
    }
    Some(YawResidual {
        residual: Moments::of(&res),
        gain: if sxx > 0.0 { sxy / sxx } else { f64::NAN },
    })
}

/// The forward wheel noise the learner settles on over a log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LearnedNoise {
    /// The multiplier, within the learner's bounds.
    pub multiplier: f64,
    /// The noise it gives, m/s.
    pub learned_std: f64,
    /// The noise the filter used (median over the log), m/s.
    pub filter_std: f64,
    /// The mean forward NIS as the filter ran.
    pub nis_mean: f64,
    /// The noise at which the mean NIS would be 1 without the learner's
    /// bounds (multiplier within 1e-3 and 1e3), m/s.
    pub unbounded_std: f64,
}

/// The forward noise the learner settles on over `records`; `None`
/// without a formed forward row.
pub fn learned_forward_noise(records: &[WheelStatus]) -> Option<LearnedNoise> {
    let c = LearningConfig::default();
    let cap = f64::from(c.nis_cap());
    let rows: Vec<(f64, f64, f64)> = records
        .iter()
        .map(|s| {
            (
                f64::from(s.innovation[0]),
                f64::from(s.innovation_var[0]),
                f64::from(s.observation_var[0]),
            )
        })
        .filter(|(nu, s, r)| nu.is_finite() && s.is_finite() && r.is_finite() && *r > 0.0)
        .filter(|(_, s, r)| s >= r)
        .collect();
    if rows.is_empty() {
        return None;
    }
    let n = rows.len() as f64;
    let mean_nis = |m: f64| {
        rows.iter()
            .map(|(nu, s, r)| (nu * nu / (s - r + m * m * r)).min(cap))
            .sum::<f64>()
            / n
    };
    let settle = |lo_b: f64, hi_b: f64| {
        if mean_nis(lo_b) <= 1.0 {
            lo_b
        } else if mean_nis(hi_b) >= 1.0 {
            hi_b
        } else {
            let (mut lo, mut hi) = (lo_b.ln(), hi_b.ln());
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if mean_nis(mid.exp()) > 1.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            (0.5 * (lo + hi)).exp()
        }
    };
    let m = settle(f64::from(c.min_multiplier()), f64::from(c.max_multiplier()));
    let free = settle(1e-3, 1e3);
    let mut sr: Vec<f64> = rows.iter().map(|(_, _, r)| r.sqrt()).collect();
    sr.sort_by(f64::total_cmp);
    let std = sr.get(sr.len() / 2).copied().unwrap_or(f64::NAN);
    let as_was = rows.iter().map(|(nu, s, _)| nu * nu / s).sum::<f64>() / n;
    Some(LearnedNoise {
        multiplier: m,
        learned_std: m * std,
        filter_std: std,
        nis_mean: as_was,
        unbounded_std: free * std,
    })
}

/// The statistics of one replayed log, as JSON: terrain, duration, the
/// yaw-rate residual, the aids' statistics, the filter's learned state, the
/// learned forward noise.
pub fn log_stats(name: &str, ds: &Dataset, r: &ReplayOutput) -> Value {
    let terrain = ds
        .labels
        .as_ref()
        .and_then(|l| l.get("terrain"))
        .unwrap_or("unknown");
    let duration = ds.imu.as_ref().and_then(|(_, v)| {
        let (a, b) = (v.first()?.t.0, v.last()?.t.0);
        Some(b.saturating_sub(a) as f64 * 1e-9)
    });
    let yaw = yaw_residual(ds);
    let learned = learned_forward_noise(&r.wheel_records);
    let f = &r.report["final"];
    let path = |t: &[crate::tum::TumPose]| -> f64 {
        t.windows(2)
            .map(|w| (w[1].p[0] - w[0].p[0]).hypot(w[1].p[1] - w[0].p[1]))
            .sum()
    };
    json!({
        "log": name,
        "terrain": terrain,
        "duration_s": duration,
        "ekf_poses": r.ekf.len(),
        "ekf_path_m": path(&r.ekf),
        "wheel_path_m": path(&r.wheel_only),
        "yaw_residual": yaw.map(|y| json!({
            "n": y.residual.n, "mean": y.residual.mean, "std": y.residual.std,
            "rms": y.residual.rms, "gain": y.gain,
        })),
        "aids": r.report["aids"],
        "learned": {
            "gyro_bias": f["gyro_bias"],
            "accel_bias": f["accel_bias"],
            "wheel_radii": f["wheel_radii"],
            "wheel_radius_std": f["wheel_radius_std"],
            "track_factor": f["track_factor"],
        },
        "forward_noise": learned.map(|n| json!({
            "multiplier": n.multiplier, "learned_std": n.learned_std, "filter_std": n.filter_std,
            "nis_mean": n.nis_mean, "unbounded_std": n.unbounded_std,
        })),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use traction::ego_ekf::aid_status::{AidOutcome, AidStatus};
    use traction::vslam_core::Timestamp;

    fn record(nu: f32, s: f32, r: f32) -> WheelStatus {
        let mut w = AidStatus::<2>::new(Timestamp(1), AidOutcome::Fused, None);
        w.innovation = [nu, 0.0];
        w.innovation_var = [s, 1.0];
        w.observation_var = [r, 1.0];
        w
    }

    #[test]
    fn the_learned_noise_makes_the_mean_nis_one() {
        // Innovations of std 0.04 m/s, the filter's S = 0.0004 + 0.0001
        // (R = 0.0004, 0.02 m/s): m^2 * 0.0004 + 0.0001 = 0.0016 -> m = 1.936.
        let recs: Vec<WheelStatus> = (0..1000)
            .map(|i| record(if i % 2 == 0 { 0.04 } else { -0.04 }, 0.0005, 0.0004))
            .collect();
        let n = learned_forward_noise(&recs).unwrap();
        assert!((n.multiplier - 1.936_49).abs() < 1e-3, "{n:?}");
        assert!((n.learned_std - n.multiplier * 0.02).abs() < 1e-6);
        assert!((n.filter_std - 0.02).abs() < 1e-6, "{n:?}");
        assert!((n.nis_mean - 3.2).abs() < 1e-3, "{n:?}");
        assert!(
            (n.unbounded_std - n.learned_std).abs() < 1e-6,
            "within the bounds"
        );
        // Innovations of std 0.2 m/s: beyond the learner's 4x bound.
        let loud: Vec<WheelStatus> = (0..1000)
            .map(|i| record(if i % 2 == 0 { 0.2 } else { -0.2 }, 0.0005, 0.0004))
            .collect();
        let n = learned_forward_noise(&loud).unwrap();
        assert_eq!(n.multiplier, 4.0);
        // m^2 * 0.0004 + 0.0001 = 0.04 -> m = 9.987.
        assert!((n.unbounded_std - 9.987_49 * 0.02).abs() < 1e-3, "{n:?}");
        // A quiet log settles at the learner's lower bound.
        let quiet: Vec<WheelStatus> = (0..100).map(|_| record(0.0, 0.0005, 0.0004)).collect();
        assert_eq!(learned_forward_noise(&quiet).unwrap().multiplier, 0.5);
        assert!(learned_forward_noise(&[]).is_none());
    }

    #[test]
    fn moments_of_a_sample() {
        let m = Moments::of(&[1.0, -1.0, 3.0, 1.0]);
        assert_eq!((m.n, m.mean), (4, 1.0));
        assert!((m.std - 2f64.sqrt()).abs() < 1e-12 && (m.rms - 3f64.sqrt()).abs() < 1e-12);
        assert_eq!(Moments::of(&[]), Moments::default());
    }
}
