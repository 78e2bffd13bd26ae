//! Errors of the host program: every one names the file (and line, where it has one).
//!
//! Bad input exits with code 2; an estimation that found no answer on valid
//! input exits with code 1. Nothing partial is reported as valid.

use std::path::{Path, PathBuf};

/// Why a command failed.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A file could not be read or is not what it should be.
    #[error("{}: {msg}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// A line of a text file is malformed.
    #[error("{}:{line}: {msg}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong with the line.
        msg: String,
    },
    /// The command line itself is wrong.
    #[error("{0}")]
    Usage(String),
    /// The input was valid but the estimation found no answer.
    #[error("{0}")]
    NoResult(String),
}

impl CliError {
    /// An error about a whole file.
    pub fn file(path: &Path, msg: impl Into<String>) -> Self {
        CliError::File {
            path: path.to_path_buf(),
            msg: msg.into(),
        }
    }

    /// An error about one line of a file.
    pub fn line(path: &Path, line: u64, msg: impl Into<String>) -> Self {
        CliError::Line {
            path: path.to_path_buf(),
            line,
            msg: msg.into(),
        }
    }

    /// The process exit code for this error.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::NoResult(_) => 1,
            _ => 2,
        }
    }
}
