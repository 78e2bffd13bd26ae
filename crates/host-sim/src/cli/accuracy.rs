//! `host-sim accuracy`: the accuracy table of the fused estimate against the
//! single sensors, over scenarios and seeds.
//!
//! Each (scenario, seed) is simulated and replayed as `host-sim simulate`
//! does, into `OUT/SCENARIO-SEED` (the dataset folder is removed afterwards
//! unless `--keep`); the errors are those of the run's `report.json`
//! (`errors`: planar ATE after first-pose and SE(2) alignment, final error,
//! largest height error, yaw RMSE; see `crate::metrics`). The output is one
//! Markdown table (README's is this command's output), then the goals of
//! issue 20 checked run by run: the fused ATE at most the better of the
//! camera path's and the wheels' on every run, at most 0.25x the wheels' on
//! `slip`, the fused height error at most 1 cm.

use crate::cli::write_stdout;
use crate::error::CliError;
use crate::simulate::scenario_for;
use crate::simulate::simulate_scenario;
use clap::Args;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `host-sim accuracy`.
#[derive(Debug, Args)]
#[command(
    about = "Accuracy table: the fused estimate against the camera path and the wheels",
    long_about = "Simulates and replays every scenario with every seed (as `host-sim simulate`), \
                  then prints one Markdown table: per run the planar ATE (first-pose alignment) of \
                  the fused EKF estimate, the camera path and the wheels alone, the EKF's ATE after \
                  SE(2) alignment, final error, largest height error and yaw RMSE; then checks the \
                  goals (fused at most the better single sensor, at most 0.25x the wheels on slip, \
                  height within 1 cm). Exit code 1 when a goal is missed."
)]
pub struct AccuracyArgs {
    /// Scenarios, comma-separated.
    #[arg(
        long,
        default_value = "office,slip,short,straight",
        value_delimiter = ','
    )]
    pub scenarios: Vec<String>,
    /// Seeds: `A-B` or a comma-separated list.
    #[arg(long, default_value = "1-4", value_parser = parse_seeds)]
    pub seeds: Seeds,
    /// Output folder (one subfolder per run).
    #[arg(long, default_value = "out/accuracy")]
    pub out: PathBuf,
    /// Keep each run's dataset folder (images included).
    #[arg(long)]
    pub keep: bool,
}

/// A list of seeds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Seeds(pub Vec<u64>);

/// Parses `A-B` (inclusive, at most 1000 seeds) or `a,b,c`.
pub fn parse_seeds(s: &str) -> Result<Seeds, String> {
    let bad = |f: &str| format!("`{f}` is not a seed (expected A-B or a,b,c)");
    let seeds: Vec<u64> = if let Some((a, b)) = s.split_once('-') {
        let a: u64 = a.trim().parse().map_err(|_| bad(s))?;
        let b: u64 = b.trim().parse().map_err(|_| bad(s))?;
        if b < a || b - a >= 1000 {
            return Err(format!("`{s}`: expected A <= B and at most 1000 seeds"));
        }
        (a..=b).collect()
    } else {
        s.split(',')
            .map(|f| f.trim().parse().map_err(|_| bad(f)))
            .collect::<Result<_, _>>()?
    };
    if seeds.is_empty() {
        return Err("no seed".into());
    }
    Ok(Seeds(seeds))
}

/// One run's errors of one trajectory, from `report.json`'s `errors`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Errors {
    /// Planar ATE after first-pose alignment, m.
    pub ate: f64,
    /// Planar ATE after SE(2) alignment, m.
    pub ate_se2: f64,
    /// Final planar error, m.
    pub final_error: f64,
    /// Largest height error, m.
    pub height: f64,
    /// Yaw RMSE, degrees.
    pub yaw_rmse: f64,
}

impl Errors {
    /// The errors of `trajectory` in a report, `None` if it has none.
    pub fn of(report: &Value, trajectory: &str) -> Option<Self> {
        let e = report.get("errors")?.get(trajectory)?;
        let f = |k: &str| e.get(k).and_then(Value::as_f64);
        Some(Errors {
            ate: f("ate_rmse_m")?,
            ate_se2: f("ate_se2_rmse_m")?,
            final_error: f("final_error_m")?,
            height: f("max_height_error_m")?,
            yaw_rmse: f("yaw_rmse_deg")?,
        })
    }
}

/// One row of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Scenario name.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// The fused estimate (`ekf.tum`).
    pub fused: Errors,
    /// The camera path (`vslam.tum`), if it has poses.
    pub camera: Option<Errors>,
    /// The wheels alone (`wheel_only.tum`).
    pub wheels: Errors,
}

impl Row {
    /// The goals this run misses (empty: all met).
    pub fn missed(&self) -> Vec<String> {
        let mut out = Vec::new();
        let best = self
            .camera
            .map_or(self.wheels.ate, |c| c.ate.min(self.wheels.ate));
        if self.fused.ate > best {
            out.push(format!(
                "fused ATE {:.3} m above the better single sensor's {best:.3} m",
                self.fused.ate
            ));
        }
        if self.scenario == "slip" && self.fused.ate > 0.25 * self.wheels.ate {
            out.push(format!(
                "fused ATE {:.3} m above 0.25x the wheels' {:.3} m",
                self.fused.ate, self.wheels.ate
            ));
        }
        if self.fused.height > 0.01 {
            out.push(format!(
                "fused height error {:.3} m above 1 cm",
                self.fused.height
            ));
        }
        out
    }
}

/// The Markdown table of `rows`.
pub fn table(rows: &[Row]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| scenario | seed | fused ATE [m] | camera ATE [m] | wheels ATE [m] | fused ATE SE(2) [m] | fused final [m] | fused height max [m] | fused yaw RMSE [deg] | goals |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    for r in rows {
        let camera = r
            .camera
            .map_or("-".to_string(), |c| format!("{:.3}", c.ate));
        let missed = r.missed();
        let goals = if missed.is_empty() {
            "met".to_string()
        } else {
            format!("missed: {}", missed.join("; "))
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.3} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {} |",
            r.scenario,
            r.seed,
            r.fused.ate,
            camera,
            r.wheels.ate,
            r.fused.ate_se2,
            r.fused.final_error,
            r.fused.height,
            r.fused.yaw_rmse,
            goals
        );
    }
    s
}

/// Runs `host-sim accuracy`.
pub fn run(args: AccuracyArgs) -> Result<(), CliError> {
    let mut rows = Vec::new();
    for name in &args.scenarios {
        let scenario = scenario_for(name, None)?;
        for &seed in &args.seeds.0 {
            let out = args.out.join(format!("{name}-{seed}"));
            eprintln!("accuracy: {name} seed {seed} into {}", out.display());
            simulate_scenario(&scenario, seed, &out, false)?;
            if !args.keep {
                let _ = std::fs::remove_dir_all(out.join("dataset"));
            }
            let path = out.join("report.json");
            let report: Value = std::fs::read_to_string(&path)
                .ok()
                .and_then(|t| serde_json::from_str(&t).ok())
                .ok_or_else(|| CliError::file(&path, "cannot read the run's report"))?;
            let missing = |t: &str| {
                CliError::NoResult(format!(
                    "{name} seed {seed}: no errors for {t} in report.json"
                ))
            };
            rows.push(Row {
                scenario: name.clone(),
                seed,
                fused: Errors::of(&report, "ekf").ok_or_else(|| missing("ekf"))?,
                camera: Errors::of(&report, "vslam"),
                wheels: Errors::of(&report, "wheel_only").ok_or_else(|| missing("wheel_only"))?,
            });
        }
    }
    let mut text = table(&rows);
    let missed: usize = rows.iter().filter(|r| !r.missed().is_empty()).count();
    let _ = writeln!(
        text,
        "\ngoals met on {} of {} runs",
        rows.len() - missed,
        rows.len()
    );
    write_stdout(&text)?;
    if missed > 0 {
        return Err(CliError::NoResult(format!(
            "{missed} of {} runs miss a goal",
            rows.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(ate: f64, height: f64) -> Errors {
        Errors {
            ate,
            ate_se2: ate,
            final_error: ate,
            height,
            yaw_rmse: 0.1,
        }
    }

    #[test]
    fn seeds_parse_as_ranges_and_lists() {
        assert_eq!(parse_seeds("1-4"), Ok(Seeds(vec![1, 2, 3, 4])));
        assert_eq!(parse_seeds("3, 7"), Ok(Seeds(vec![3, 7])));
        assert!(parse_seeds("4-1").is_err());
        assert!(parse_seeds("x").is_err());
        assert!(parse_seeds("1-5000").is_err());
    }

    #[test]
    fn goals_are_the_issues() {
        let row = |scenario: &str, fused: Errors, camera: f64, wheels: f64| Row {
            scenario: scenario.into(),
            seed: 1,
            fused,
            camera: Some(errors(camera, 0.0)),
            wheels: errors(wheels, 0.0),
        };
        assert!(
            row("office", errors(0.05, 0.005), 0.06, 1.0)
                .missed()
                .is_empty()
        );
        // Worse than the camera path.
        assert_eq!(
            row("office", errors(0.07, 0.005), 0.06, 1.0).missed().len(),
            1
        );
        // Height above 1 cm.
        assert_eq!(
            row("office", errors(0.05, 0.02), 0.06, 1.0).missed().len(),
            1
        );
        // On slip, above 0.25x the wheels though below both sensors.
        assert_eq!(row("slip", errors(0.3, 0.005), 1.0, 1.0).missed().len(), 1);
        assert!(
            row("slip", errors(0.2, 0.005), 1.0, 1.0)
                .missed()
                .is_empty()
        );
        let t = table(&[row("straight", errors(0.05, 0.005), 0.06, 1.0)]);
        assert!(
            t.contains("| straight | 1 | 0.050 | 0.060 | 1.000 |"),
            "{t}"
        );
        assert!(
            t.lines().nth(2).is_some_and(|l| l.ends_with("| met |")),
            "{t}"
        );
    }

    #[test]
    fn errors_are_read_from_a_report() {
        let report = serde_json::json!({"errors": {"ekf": {
            "ate_rmse_m": 0.1, "ate_se2_rmse_m": 0.05, "final_error_m": 0.2,
            "max_height_error_m": 0.004, "yaw_rmse_deg": 0.5}}});
        let e = Errors::of(&report, "ekf").unwrap();
        assert_eq!((e.ate, e.height), (0.1, 0.004));
        assert!(Errors::of(&report, "vslam").is_none());
    }
}
