//! `host-sim`: the host program of traction. Parses the command line and
//! dispatches to `host_sim::cli::*::run`; errors print as `host-sim: {error}`
//! and exit with [`host_sim::CliError::exit_code`] (2 bad input, 1 no result).

use clap::{Parser, Subcommand};
use host_sim::cli;
use std::process::ExitCode;

/// traction on a host: two-image tracking and homographies.
#[derive(Debug, Parser)]
#[command(name = "host-sim", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The commands.
#[derive(Debug, Subcommand)]
enum Command {
    /// Track corners from IMG1 to IMG2, fit a homography, decompose it.
    Track(cli::track::TrackArgs),
    /// Robust homography from a file of point matches.
    Homography(cli::homography::HomographyArgs),
}

fn main() -> ExitCode {
    let args = Cli::parse();
    let result = match args.command {
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
