//! The adverse-event memory across runs (`host-sim simulate|replay --memory
//! FILE`): the scale pipeline's memory of where and when each sensor
//! misbehaved ([`traction::vslam_core::adverse`]) is restored from FILE
//! before the first sample, when FILE exists, and written back to it after
//! the last one, so a second run over the same slippery place trusts the
//! wheels less there from its first frame on.
//!
//! FILE holds one record of
//! [`PipelineMemory::export`](traction::vslam_core::scale::pipeline::PipelineMemory)
//! (magic, version, shape, settings, cells, CRC-32). A record the memory
//! refuses (corrupt, another version or shape, other settings) is reported
//! on stderr with the reason, moved aside to `FILE.refused`, and the run
//! goes on with an empty memory, which is written to FILE at the end. The
//! record is written to `FILE.tmp` first and renamed over FILE, so an
//! interrupted run leaves the previous record whole.
//!
//! The memory's clock is the log's time stamps: time slots and decay
//! follow them. Logs whose time starts at zero (the simulator's) all fall
//! in the same hours of the same day, so nothing decays between such runs.

use crate::error::CliError;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use traction::estimator::Estimator;
use traction::vslam_core::scale::pipeline::PipelineMemory;

/// What became of the memory file at the start of a run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Loaded {
    /// There was no file: the run starts with an empty memory.
    Absent,
    /// The record was restored.
    Restored,
    /// The file was refused (`reason`) and moved to `kept_as` (`None` when
    /// the move failed too); the run starts with an empty memory.
    Refused {
        /// Why, as the memory or the file system said.
        reason: String,
        /// Where the refused file went.
        kept_as: Option<PathBuf>,
    },
}

impl Loaded {
    /// The report's name of the outcome.
    pub fn name(&self) -> &'static str {
        match self {
            Loaded::Absent => "absent",
            Loaded::Restored => "restored",
            Loaded::Refused { .. } => "refused",
        }
    }
}

/// `path` with `suffix` appended to its file name.
fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(suffix);
    path.with_file_name(name)
}

/// Restores `est`'s memory from `path`, when it exists. A file that cannot
/// be read or is refused is named on stderr with the reason and moved to
/// `path.refused`; the memory then stays empty.
pub fn load(est: &mut Estimator<'_>, path: &Path) -> Loaded {
    let reason = match std::fs::read(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Loaded::Absent,
        Err(e) => format!("cannot read: {e}"),
        Ok(bytes) => match est.restore_memory(&bytes) {
            Ok(()) => return Loaded::Restored,
            Err(e) => e.to_string(),
        },
    };
    let aside = with_suffix(path, ".refused");
    let kept_as = std::fs::rename(path, &aside).ok().map(|()| aside);
    let kept = match &kept_as {
        Some(p) => format!("the file is moved to {}", p.display()),
        None => "the file could not be moved aside".to_string(),
    };
    eprintln!(
        "error: memory file {}: refused ({reason}); the run starts with an empty \
         adverse-event memory, {kept}, and the memory is written to {} at the end",
        path.display(),
        path.display()
    );
    Loaded::Refused { reason, kept_as }
}

/// Writes `est`'s memory to `path` (through `path.tmp`, renamed over it).
pub fn save(est: &Estimator<'_>, path: &Path) -> Result<(), CliError> {
    let mut record = vec![0u8; PipelineMemory::RECORD_LEN];
    let n = est
        .export_memory(&mut record)
        .map_err(|e| CliError::file(path, format!("cannot export the memory: {e}")))?;
    record.truncate(n);
    let tmp = with_suffix(path, ".tmp");
    std::fs::write(&tmp, &record)
        .map_err(|e| CliError::file(&tmp, format!("cannot write: {e}")))?;
    std::fs::rename(&tmp, path).map_err(|e| CliError::file(path, format!("cannot write: {e}")))
}

/// The report's `memory` section: the file, what became of it at the start,
/// and the cells with events at the start and the end.
pub fn report(path: &Path, loaded: &Loaded, cells_at_start: usize, est: &Estimator<'_>) -> Value {
    let memory = est.scale().memory();
    let (reason, kept_as) = match loaded {
        Loaded::Refused { reason, kept_as } => (
            json!(reason),
            json!(kept_as.as_ref().map(|p| p.display().to_string())),
        ),
        _ => (Value::Null, Value::Null),
    };
    json!({
        "file": path.display().to_string(),
        "at_start": loaded.name(),
        "refused_because": reason,
        "refused_file_kept_as": kept_as,
        "cells_at_start": cells_at_start,
        "cells_at_end": memory.cells(),
        "cells_evicted": memory.evicted(),
    })
}

/// The summary's line about the memory; empty when the run had none.
pub fn summary(report: &Value) -> String {
    let m = &report["memory"];
    let Some(file) = m["file"].as_str() else {
        return String::new();
    };
    let start = match m["at_start"].as_str() {
        Some("restored") => format!("restored with {} cells", m["cells_at_start"]),
        Some("refused") => "refused, started empty".to_string(),
        _ => "absent, started empty".to_string(),
    };
    format!(
        "adverse-event memory {file}: {start}; written with {} cells\n",
        m["cells_at_end"]
    )
}
