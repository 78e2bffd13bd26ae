//! # host-sim
//!
//! traction on a host (std): the simulated world and robot, register-level
//! chip simulators, ASL/EuRoC dataset and TUM trajectory files, log replay,
//! two-image tracking, plots. It holds no estimation logic of its own: every
//! estimate comes from the no_std crates through `traction`.
//!
//! # Example: files in, errors that name the file and line
//!
//! ```
//! use host_sim::matches::parse_matches;
//! use host_sim::tum::format_seconds;
//! use std::path::Path;
//! use traction::Timestamp;
//!
//! // `host-sim homography` reads `x1 y1 x2 y2` per line; `#` starts a comment.
//! let path = Path::new("pairs.txt");
//! let matches = parse_matches(path, "# image 1 -> image 2\n10 20 12.5 19\n30,40,33,41\n")?;
//! assert_eq!(matches.len(), 2);
//! assert_eq!(matches[0].p2, [12.5, 19.0]);
//!
//! // Bad input is refused with the file and the line (the CLI exits with code 2).
//! let e = parse_matches(path, "10 20 12.5 19\n10 20 nan 19\n").unwrap_err();
//! assert!(e.to_string().contains("pairs.txt") && e.to_string().contains('2'), "{e}");
//!
//! // TUM trajectories carry seconds written exactly from integer nanoseconds.
//! assert_eq!(format_seconds(Timestamp::from_nanos(1_500_000_001)), "1.500000001");
//! # Ok::<(), host_sim::CliError>(())
//! ```
// Parts of the readers and simulators are used only by the tests.
#![allow(dead_code)]

pub mod asl;
pub mod calibrate;
pub mod chaos;
pub mod chips;
pub mod cli;
pub mod closed_loop;
pub mod error;
pub mod faults;
pub mod import;
pub mod matches;
pub mod metrics;
pub mod plot;
pub mod pngio;
pub mod progress;
pub mod replay;
pub mod segtrain;
pub mod sim;
pub mod simulate;
pub mod terrain;
pub mod tum;

pub use error::CliError;
