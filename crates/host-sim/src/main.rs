//! `host-sim`: the host program of traction. Parses the command line and
//! dispatches to `host_sim::cli::*::run`; errors print as `host-sim: {error}`
//! and exit with [`host_sim::CliError::exit_code`] (2 bad input, 1 no result).

use clap::{Parser, Subcommand};
use host_sim::cli;
use std::process::ExitCode;

/// traction on a host: simulate, replay recorded logs, track, estimate homographies.
#[derive(Debug, Parser)]
#[command(name = "host-sim", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// The commands. Their help lives on the argument structs in `host_sim::cli`
// (a doc comment here would replace it).
#[derive(Debug, Subcommand)]
enum Command {
    Simulate(cli::run::SimulateArgs),
    Replay(cli::run::ReplayArgs),
    Import(cli::import::ImportArgs),
    Calibrate(cli::calibrate::CalibrateArgs),
    TerrainStats(cli::terrain::TerrainStatsArgs),
    TrainSegmenter(cli::segmenter::TrainSegmenterArgs),
    Accuracy(cli::accuracy::AccuracyArgs),
    Track(cli::track::TrackArgs),
    Homography(cli::homography::HomographyArgs),
}

fn main() -> ExitCode {
    let args = Cli::parse();
    let result = match args.command {
        Command::Simulate(a) => cli::run::run_simulate_cmd(a),
        Command::Replay(a) => cli::run::run_replay_cmd(a),
        Command::Import(a) => cli::import::run(a),
        Command::Calibrate(a) => cli::calibrate::run(a),
        Command::TerrainStats(a) => cli::terrain::run(a),
        Command::TrainSegmenter(a) => cli::segmenter::run_cmd(a),
        Command::Accuracy(a) => cli::accuracy::run(a),
        Command::Track(a) => cli::track::run(a),
        Command::Homography(a) => cli::homography::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-sim: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
