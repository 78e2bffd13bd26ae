//! `labels.yaml` beside `mav0/`: what a dataset is, in words, for the people
//! who read a replay's output: where it came from (`source`), what the
//! reference trajectory is (`reference`: `simulator`, `optitrack`, `gps`,
//! `none`), the terrain it was recorded on (`terrain`), and notes on what it
//! lacks (`notes`). A flat YAML mapping of names to strings (a list of
//! strings for `notes`); the replay prints it and copies it into
//! `report.json`. Optional: a dataset without it has no labels.

use super::yaml::SensorYaml;
use crate::error::CliError;
use std::collections::BTreeMap;
use std::path::Path;

/// File name of the labels, in the dataset's root folder.
pub const LABELS_FILE: &str = "labels.yaml";

/// A dataset's labels: name to text, and notes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Labels {
    /// Single-valued labels (`source`, `reference`, `terrain`, ...).
    pub values: BTreeMap<String, String>,
    /// Free-text notes, in order.
    pub notes: Vec<String>,
}

impl Labels {
    /// Sets label `key` to `value`.
    pub fn set(&mut self, key: &str, value: impl Into<String>) -> &mut Self {
        self.values.insert(key.to_string(), value.into());
        self
    }

    /// Adds a note.
    pub fn note(&mut self, text: impl Into<String>) -> &mut Self {
        self.notes.push(text.into());
        self
    }

    /// Label `key`, when present.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.values.get(key).map(String::as_str)
    }

    /// Reads `labels.yaml` from a dataset root; `None` when there is none.
    pub fn read(root: &Path) -> Result<Option<Self>, CliError> {
        let path = root.join(LABELS_FILE);
        if !path.is_file() {
            return Ok(None);
        }
        let y = SensorYaml::load(&path)?;
        let mut out = Labels::default();
        for key in y.keys() {
            if key == "notes" {
                out.notes = y.strings("notes")?;
            } else {
                let v = y.string(&key)?;
                out.values.insert(key, v);
            }
        }
        Ok(Some(out))
    }

    /// Writes `labels.yaml` into a dataset root.
    pub fn write(&self, root: &Path) -> Result<(), CliError> {
        let path = root.join(LABELS_FILE);
        // JSON strings are YAML double-quoted scalars: any text survives.
        let q = |s: &str| serde_json::Value::String(s.to_string()).to_string();
        let mut s = String::new();
        for (k, v) in &self.values {
            s += &format!("{k}: {}\n", q(v));
        }
        if !self.notes.is_empty() {
            s += "notes:\n";
            for n in &self.notes {
                s += &format!("  - {}\n", q(n));
            }
        }
        std::fs::write(&path, s).map_err(|e| CliError::file(&path, format!("cannot write: {e}")))
    }

    /// One line per label and note, for the replay's summary.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        for (k, v) in &self.values {
            s += &format!("{k}: {v}\n");
        }
        for n in &self.notes {
            s += &format!("note: {n}\n");
        }
        s
    }

    /// The labels as JSON, for `report.json`.
    pub fn to_json(&self) -> serde_json::Value {
        let mut m: serde_json::Map<String, serde_json::Value> = self
            .values
            .iter()
            .map(|(k, v)| (k.clone(), serde_json::Value::String(v.clone())))
            .collect();
        m.insert("notes".into(), serde_json::json!(self.notes));
        serde_json::Value::Object(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_round_trip_with_any_text() {
        let scratch = tempfile::tempdir().unwrap();
        let d = scratch.path();
        let mut l = Labels::default();
        l.set("terrain", "ICE")
            .set("source", "borealtc: a: \"b\", #c")
            .note("no IMU: wheels only");
        l.write(d).unwrap();
        assert_eq!(Labels::read(d).unwrap(), Some(l.clone()));
        assert!(l.summary().contains("terrain: ICE\n"));
        std::fs::write(d.join(LABELS_FILE), "terrain: [1, 2]\n").unwrap();
        let e = Labels::read(d).unwrap_err().to_string();
        assert!(e.contains("labels.yaml:1: `terrain`"), "{e}");
    }
}
