//! The calibration's input from a dataset: per wheel sample, how far each
//! wheel turned and how the reference pose moved meanwhile.

use crate::asl::{Dataset, GroundTruth};
use crate::error::CliError;
use std::path::Path;

/// One wheel sample interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelStep {
    /// Right wheel turn, rad.
    pub dphi_right: f64,
    /// Left wheel turn, rad.
    pub dphi_left: f64,
    /// Reference heading change, rad.
    pub dth: f64,
    /// Reference translation in the reference's frame, m.
    pub dxy: [f64; 2],
    /// Reference heading at the interval's midpoint, rad.
    pub heading_mid: f64,
}

fn yaw(q: &[f64; 4]) -> f64 {
    let [w, x, y, z] = *q;
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// The reference as `(t ns, x, y, unwrapped yaw)`.
fn reference(gt: &[GroundTruth]) -> Vec<(u64, f64, f64, f64)> {
    let mut out: Vec<(u64, f64, f64, f64)> = Vec::with_capacity(gt.len());
    for g in gt {
        let mut th = yaw(&g.q_wxyz);
        if let Some(&(_, _, _, prev)) = out.last() {
            th = prev + (th - prev + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
        }
        if out.last().is_none_or(|p| g.t.0 > p.0) {
            out.push((g.t.0, g.p[0], g.p[1], th));
        }
    }
    out
}

/// The reference pose at `t` by linear interpolation; `None` outside it.
fn at(r: &[(u64, f64, f64, f64)], t: u64) -> Option<[f64; 3]> {
    let i = r.partition_point(|p| p.0 < t);
    let b = r.get(i)?;
    if b.0 == t {
        return Some([b.1, b.2, b.3]);
    }
    let a = r.get(i.checked_sub(1)?)?;
    let f = (t - a.0) as f64 / (b.0 - a.0) as f64;
    Some([
        a.1 + f * (b.1 - a.1),
        a.2 + f * (b.2 - a.2),
        a.3 + f * (b.3 - a.3),
    ])
}

/// The wheel steps of a dataset with wheel ticks (turn = ticks over
/// `ticks_per_revolution` of `wheel0/sensor.yaml`) or wheel rates
/// (trapezoid rule) and ground truth; intervals outside the ground truth's
/// span, or whose time stamps do not increase, are left out. `root` names
/// the dataset in errors.
pub fn wheel_steps(ds: &Dataset, root: &Path) -> Result<Vec<WheelStep>, CliError> {
    let gt = ds
        .groundtruth
        .as_deref()
        .filter(|g| g.len() >= 2)
        .ok_or_else(|| {
            CliError::file(
                root,
                "no ground truth (mav0/state_groundtruth_estimate0): nothing to calibrate against",
            )
        })?;
    let turns: Vec<(u64, f64, f64)> = if let Some((m, w)) = &ds.wheel {
        let per_tick = m
            .ticks_per_revolution
            .map(|t| std::f64::consts::TAU / t)
            .ok_or_else(|| CliError::file(root, "wheel0: no ticks_per_revolution"))?;
        w.windows(2)
            .filter(|p| p[1].t > p[0].t)
            .map(|p| {
                (
                    p[1].t.0,
                    (p[1].right - p[0].right) as f64 * per_tick,
                    (p[1].left - p[0].left) as f64 * per_tick,
                )
            })
            .collect()
    } else if let Some((_, r)) = &ds.wheel_rates {
        r.windows(2)
            .filter(|p| p[1].t > p[0].t)
            .map(|p| {
                let dt = (p[1].t.0 - p[0].t.0) as f64 * 1e-9;
                (
                    p[1].t.0,
                    0.5 * f64::from(p[0].right + p[1].right) * dt,
                    0.5 * f64::from(p[0].left + p[1].left) * dt,
                )
            })
            .collect()
    } else {
        return Err(CliError::file(
            root,
            "no wheel0 stream: nothing to calibrate",
        ));
    };
    let starts = ds
        .wheel
        .as_ref()
        .map(|(_, w)| w.iter().map(|s| s.t.0).collect::<Vec<_>>())
        .or_else(|| {
            ds.wheel_rates
                .as_ref()
                .map(|(_, r)| r.iter().map(|s| s.t.0).collect())
        })
        .unwrap_or_default();
    let starts: Vec<u64> = starts
        .windows(2)
        .filter(|p| p[1] > p[0])
        .map(|p| p[0])
        .collect();
    let r = reference(gt);
    Ok(turns
        .iter()
        .zip(starts)
        .filter(|((_, pr, pl), _)| pr.is_finite() && pl.is_finite())
        .filter_map(|(&(t1, pr, pl), t0)| {
            let a = at(&r, t0)?;
            let b = at(&r, t1)?;
            Some(WheelStep {
                dphi_right: pr,
                dphi_left: pl,
                dth: b[2] - a[2],
                dxy: [b[0] - a[0], b[1] - a[1]],
                heading_mid: 0.5 * (a[2] + b[2]),
            })
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_is_interpolated_and_unwrapped() {
        let q = |th: f64| [(0.5 * th).cos(), 0.0, 0.0, (0.5 * th).sin()];
        let g = |t: u64, x: f64, th: f64| GroundTruth {
            t: vslam_core::Timestamp(t),
            p: [x, 0.0, 0.0],
            q_wxyz: q(th),
            v: [0.0; 3],
            bias_gyro: [0.0; 3],
            bias_accel: [0.0; 3],
        };
        let r = reference(&[g(0, 0.0, 3.0), g(10, 1.0, -3.0), g(20, 2.0, -2.0)]);
        assert!(
            (r[1].3 - (std::f64::consts::TAU - 3.0)).abs() < 1e-9,
            "{r:?}"
        );
        assert!(
            (r[2].3 - (std::f64::consts::TAU - 2.0)).abs() < 1e-9,
            "{r:?}"
        );
        let m = at(&r, 5).unwrap();
        assert!((m[0] - 0.5).abs() < 1e-12);
        assert!(at(&r, 21).is_none());
    }
}
