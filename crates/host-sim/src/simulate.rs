//! `host-sim simulate`: a scenario end to end. Generates the sensor log of a
//! simulated run as an ASL dataset in `OUT/dataset`, replays it through the
//! estimator exactly as a recorded log would be, and writes the estimates,
//! the report and the plot into `OUT`.

use crate::asl::write_dataset;
use crate::error::CliError;
use crate::replay::{ReplayOutput, run_replay};
use crate::sim::scenario::{SCENARIOS, Scenario, generate};
use std::path::Path;

/// Runs scenario `name` with `seed` into `out`.
pub fn run_simulate(
    name: &str,
    seed: u64,
    out: &Path,
    progress: bool,
) -> Result<ReplayOutput, CliError> {
    let scenario = Scenario::by_name(name).ok_or_else(|| {
        CliError::Usage(format!(
            "unknown scenario `{name}`; known: {}",
            SCENARIOS.join(", ")
        ))
    })?;
    let dataset = out.join("dataset");
    if dataset.exists() {
        std::fs::remove_dir_all(&dataset)
            .map_err(|e| CliError::file(&dataset, format!("cannot clear the old dataset: {e}")))?;
    }
    let (ds, _truth) = generate(&scenario, seed, &dataset)?;
    write_dataset(&dataset, &ds)?;
    run_replay(&dataset, out, progress)
}
