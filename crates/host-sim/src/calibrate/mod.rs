//! Differential-drive odometry calibration against ground truth: wheel
//! radii (left, right) and track from a run with wheel encoders and a
//! reference trajectory, by linear least squares in two steps after
//! Antonelli, Chiaverini and Fusco, "A calibration method for odometry of
//! mobile robots based on the least-squares technique: theory and
//! experimental validation", IEEE Trans. Robotics 21(5), 2005.
//!
//! The run is cut into windows of `window` wheel samples. Over window `w`
//! the wheels turn by `dphi_r`, `dphi_l` (rad, per sample `k`) and the
//! reference turns by `dth` and moves by `dx`, `dy`:
//!
//! 1. heading: `dth = c_r * sum dphi_r - c_l * sum dphi_l` with
//!    `c_r = r_r / b`, `c_l = r_l / b`: two unknowns, linear;
//! 2. translation: with the ratio `rho = r_l / r_r = c_l / c_r` from step 1,
//!    `[dx, dy] = r_r * sum_k (dphi_r + rho dphi_l) / 2 * [cos th_k, sin th_k]`
//!    with `th_k` the reference heading at the sample's midpoint: one
//!    unknown, linear;
//! 3. `r_l = rho r_r`, `b = r_r / c_r`.
//!
//! The reference heading is used in step 2 (Antonelli et al. use the one
//! odometry gives with the step-1 parameters; on motion capture the two
//! differ by its noise only). A calibration path needs turns and straight
//! stretches both (a square, UMBmark's path), or step 1 is singular: that is
//! refused, not guessed.
//!
//! [`WheelGeometry`] is what the calibration yields and what
//! `host-sim replay --wheels FILE` takes in place of the dataset's
//! `wheel0/sensor.yaml` geometry ([`geometry_file`]).

mod geometry_file;
mod samples;

pub use geometry_file::WheelGeometry;
pub use samples::{WheelStep, wheel_steps};

use crate::error::CliError;

/// What a calibration found, with the fit's residuals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    /// The calibrated geometry.
    pub geometry: WheelGeometry,
    /// `c_r = r_r / b`, `c_l = r_l / b` of the heading fit.
    pub heading_coefficients: [f64; 2],
    /// Windows used (with any wheel motion).
    pub windows: usize,
    /// RMS of the heading fit's residual per window, rad.
    pub heading_rms: f64,
    /// RMS of the translation fit's residual per window and axis, m.
    pub translation_rms: f64,
    /// Condition number of the heading fit's normal matrix (large: the
    /// path does not tell the wheels apart).
    pub heading_condition: f64,
}

/// Sums of one window: wheel turns, reference heading change, and the
/// translation regressors for the right and the left wheel.
#[derive(Clone, Copy, Debug, Default)]
struct Window {
    phi_r: f64,
    phi_l: f64,
    dth: f64,
    dx: f64,
    dy: f64,
    /// `sum dphi_r / 2 * (cos th, sin th)`.
    right: [f64; 2],
    /// `sum dphi_l / 2 * (cos th, sin th)`.
    left: [f64; 2],
}

fn windows(steps: &[WheelStep], window: usize) -> Vec<Window> {
    steps
        .chunks(window.max(1))
        .map(|c| {
            let mut w = Window::default();
            for s in c {
                let (sin, cos) = s.heading_mid.sin_cos();
                w.phi_r += s.dphi_right;
                w.phi_l += s.dphi_left;
                w.dth += s.dth;
                w.dx += s.dxy[0];
                w.dy += s.dxy[1];
                w.right[0] += 0.5 * s.dphi_right * cos;
                w.right[1] += 0.5 * s.dphi_right * sin;
                w.left[0] += 0.5 * s.dphi_left * cos;
                w.left[1] += 0.5 * s.dphi_left * sin;
            }
            w
        })
        .filter(|w| w.phi_r != 0.0 || w.phi_l != 0.0)
        .collect()
}

/// Calibrates from the wheel steps of one or more runs (see [`wheel_steps`]),
/// `window` samples a window. `what` names the input in errors.
pub fn calibrate(steps: &[WheelStep], window: usize, what: &str) -> Result<Calibration, CliError> {
    let ws = windows(steps, window);
    if ws.len() < 3 {
        return Err(CliError::NoResult(format!(
            "{what}: {} windows with wheel motion; the calibration needs at least 3",
            ws.len()
        )));
    }
    // Step 1: dth = c_r * phi_r + c_l' * (-phi_l), normal equations 2x2.
    let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for w in &ws {
        let (u, v) = (w.phi_r, -w.phi_l);
        a11 += u * u;
        a12 += u * v;
        a22 += v * v;
        b1 += u * w.dth;
        b2 += v * w.dth;
    }
    let det = a11 * a22 - a12 * a12;
    let trace = a11 + a22;
    let disc = ((a11 - a22).powi(2) + 4.0 * a12 * a12).sqrt();
    let (l_max, l_min) = (0.5 * (trace + disc), 0.5 * (trace - disc));
    let condition = if l_min > 0.0 {
        l_max / l_min
    } else {
        f64::INFINITY
    };
    if !(det > 0.0 && condition < 1e8) {
        return Err(CliError::NoResult(format!(
            "{what}: the heading fit is singular (condition {condition:.3e}): the path needs \
             both straight stretches and turns"
        )));
    }
    let c_r = (a22 * b1 - a12 * b2) / det;
    let c_l = (a11 * b2 - a12 * b1) / det;
    if !(c_r > 0.0 && c_l > 0.0) {
        return Err(CliError::NoResult(format!(
            "{what}: the heading fit gives non-positive wheel coefficients ({c_r:.4e}, {c_l:.4e}): \
             are left and right, or the reference's heading, reversed?"
        )));
    }
    let rho = c_l / c_r;
    // Step 2: [dx, dy] = r_r * (right + rho * left).
    let (mut num, mut den) = (0.0, 0.0);
    for w in &ws {
        for i in 0..2 {
            let g = w.right[i] + rho * w.left[i];
            let d = if i == 0 { w.dx } else { w.dy };
            num += g * d;
            den += g * g;
        }
    }
    if den <= 0.0 {
        return Err(CliError::NoResult(format!(
            "{what}: the run does not translate: no wheel radius from it"
        )));
    }
    let r_r = num / den;
    if r_r <= 0.0 {
        return Err(CliError::NoResult(format!(
            "{what}: the translation fit gives a non-positive radius ({r_r:.4e})"
        )));
    }
    let r_l = rho * r_r;
    let b = r_r / c_r;
    let n = ws.len() as f64;
    let heading_rms = (ws
        .iter()
        .map(|w| (w.dth - c_r * w.phi_r + c_l * w.phi_l).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let translation_rms = (ws
        .iter()
        .map(|w| {
            let ex = w.dx - r_r * (w.right[0] + rho * w.left[0]);
            let ey = w.dy - r_r * (w.right[1] + rho * w.left[1]);
            ex * ex + ey * ey
        })
        .sum::<f64>()
        / (2.0 * n))
        .sqrt();
    Ok(Calibration {
        geometry: WheelGeometry {
            radius_left: r_l,
            radius_right: r_r,
            track: b,
        },
        heading_coefficients: [c_r, c_l],
        windows: ws.len(),
        heading_rms,
        translation_rms,
        heading_condition: condition,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps of a robot with geometry `g` driving `commands` (right, left
    /// wheel turn per step, rad), integrated exactly by the midpoint rule.
    fn drive(g: WheelGeometry, commands: &[(f64, f64)]) -> Vec<WheelStep> {
        let mut th = 0.0f64;
        commands
            .iter()
            .map(|&(pr, pl)| {
                let ds = 0.5 * (g.radius_right * pr + g.radius_left * pl);
                let dth = (g.radius_right * pr - g.radius_left * pl) / g.track;
                let mid = th + 0.5 * dth;
                th += dth;
                WheelStep {
                    dphi_right: pr,
                    dphi_left: pl,
                    dth,
                    dxy: [ds * mid.cos(), ds * mid.sin()],
                    heading_mid: mid,
                }
            })
            .collect()
    }

    fn square() -> Vec<(f64, f64)> {
        let mut c = Vec::new();
        for _ in 0..4 {
            c.extend(std::iter::repeat_n((0.5, 0.5), 80));
            c.extend(std::iter::repeat_n((0.3, -0.3), 20));
        }
        c
    }

    #[test]
    fn a_square_gives_back_the_geometry_it_was_driven_with() {
        let g = WheelGeometry {
            radius_left: 0.0418,
            radius_right: 0.0423,
            track: 0.2034,
        };
        let c = calibrate(&drive(g, &square()), 20, "sq").unwrap();
        let got = c.geometry;
        assert!((got.radius_left - g.radius_left).abs() < 1e-9, "{got:?}");
        assert!((got.radius_right - g.radius_right).abs() < 1e-9, "{got:?}");
        assert!((got.track - g.track).abs() < 1e-9, "{got:?}");
        assert!(c.heading_rms < 1e-12 && c.translation_rms < 1e-12, "{c:?}");
    }

    #[test]
    fn a_straight_line_alone_is_refused() {
        let g = WheelGeometry {
            radius_left: 0.042,
            radius_right: 0.042,
            track: 0.2,
        };
        let straight = vec![(0.5, 0.5); 200];
        let e = calibrate(&drive(g, &straight), 20, "line").unwrap_err();
        assert!(e.to_string().contains("singular"), "{e}");
        assert_eq!(e.exit_code(), 1);
        let e = calibrate(&drive(g, &straight[..30]), 20, "short").unwrap_err();
        assert!(e.to_string().contains("at least 3"), "{e}");
    }

    #[test]
    fn swapped_wheels_are_named() {
        let g = WheelGeometry {
            radius_left: 0.042,
            radius_right: 0.042,
            track: 0.2,
        };
        let swapped: Vec<WheelStep> = drive(g, &square())
            .into_iter()
            .map(|s| WheelStep {
                dphi_right: s.dphi_left,
                dphi_left: s.dphi_right,
                ..s
            })
            .collect();
        let e = calibrate(&swapped, 20, "sw").unwrap_err();
        assert!(e.to_string().contains("reversed"), "{e}");
    }
}
