//! # host-sim
//!
//! traction on a host (std): the simulated world and robot, register-level
//! chip simulators, ASL/EuRoC dataset and TUM trajectory files, log replay,
//! two-image tracking, plots. It holds no estimation logic of its own: every
//! estimate comes from the no_std crates through `traction`.
// Parts of the readers and simulators are used only by tests until every
// command that uses them has landed.
#![allow(dead_code)]

pub mod asl;
pub mod chips;
pub mod cli;
pub mod error;
pub mod faults;
pub mod matches;
pub mod metrics;
pub mod pngio;
pub mod replay;
pub mod sim;
pub mod simulate;
pub mod svg;
pub mod tum;

pub use error::CliError;
