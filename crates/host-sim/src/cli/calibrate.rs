//! `host-sim calibrate DATASET... --out FILE`: a differential drive's wheel
//! radii and track from runs with wheel encoders and ground truth
//! ([`crate::calibrate`]), printed beside the dataset's nominal geometry and
//! written as the file `host-sim replay --wheels FILE` takes.

use crate::asl::read_dataset;
use crate::calibrate::{WheelGeometry, calibrate, wheel_steps};
use crate::error::CliError;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `host-sim calibrate`.
#[derive(Debug, Args)]
#[command(
    about = "Calibrate wheel radii and track against ground truth",
    long_about = "Reads one or more ASL datasets with wheel0 (ticks or rates) and \
                  state_groundtruth_estimate0 (e.g. `host-sim import optiodom` of a calibration \
                  run), estimates the left and right wheel radii and the track by linear least \
                  squares of the wheel turns against the reference's heading and translation over \
                  windows (Antonelli et al., IEEE T-RO 2005), prints them beside the first \
                  dataset's nominal geometry and writes them to --out for `host-sim replay \
                  --wheels FILE`. The path must have straight stretches and turns (a square): a \
                  path that does not tell the parameters apart exits 1."
)]
pub struct CalibrateArgs {
    /// The calibration run(s): dataset folders (the ones that contain `mav0/`).
    #[arg(required = true)]
    pub datasets: Vec<PathBuf>,
    /// Where to write the calibrated geometry (YAML).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Wheel samples per least-squares window.
    #[arg(long, value_name = "N", default_value_t = 20)]
    pub window: usize,
}

/// Runs `calibrate`.
pub fn run(a: CalibrateArgs) -> Result<(), CliError> {
    if a.window == 0 {
        return Err(CliError::Usage(
            "--window: expected at least 1 sample".into(),
        ));
    }
    let mut steps = Vec::new();
    let mut nominal: Option<WheelGeometry> = None;
    for d in &a.datasets {
        let ds = read_dataset(d)?;
        steps.extend(wheel_steps(&ds, d)?);
        if nominal.is_none() {
            nominal = ds
                .wheel
                .as_ref()
                .map(|(m, _)| m)
                .or(ds.wheel_rates.as_ref().map(|(m, _)| m))
                .map(|m| WheelGeometry {
                    radius_left: m.wheel_radius_left,
                    radius_right: m.wheel_radius_right,
                    track: m.wheel_base,
                });
        }
    }
    let names: Vec<String> = a.datasets.iter().map(|d| d.display().to_string()).collect();
    let c = calibrate(&steps, a.window, &names.join(", "))?;
    let g = c.geometry;
    let mut s = String::new();
    outln!(
        s,
        "calibration over {} windows of {} wheel samples from {}",
        c.windows,
        a.window,
        names.join(", ")
    );
    outln!(s, "               nominal [m]  calibrated [m]  change");
    let rows = [
        ("radius left", nominal.map(|n| n.radius_left), g.radius_left),
        (
            "radius right",
            nominal.map(|n| n.radius_right),
            g.radius_right,
        ),
        ("track", nominal.map(|n| n.track), g.track),
    ];
    for (name, n, v) in rows {
        match n {
            Some(n) => outln!(
                s,
                "{name:<13} {n:>12.6}  {v:>14.6}  {:>+6.2} %",
                100.0 * (v / n - 1.0)
            ),
            None => outln!(s, "{name:<13} {:>12}  {v:>14.6}", "-"),
        }
    }
    outln!(
        s,
        "heading fit: c_r {:.6e}, c_l {:.6e} rad/rad, residual RMS {:.3} mrad per window, \
         condition {:.1}",
        c.heading_coefficients[0],
        c.heading_coefficients[1],
        1e3 * c.heading_rms,
        c.heading_condition
    );
    outln!(
        s,
        "translation fit: residual RMS {:.2} mm per window and axis",
        1e3 * c.translation_rms
    );
    if let Some(out) = &a.out {
        let comments = vec![
            "host-sim calibrate: wheel geometry by least squares against ground truth".to_string(),
            format!("from {}", names.join(", ")),
            format!("{} windows of {} wheel samples", c.windows, a.window),
        ];
        g.write(out, &comments)?;
        outln!(s, "wrote {}", out.display());
    }
    super::write_stdout(&s)
}
