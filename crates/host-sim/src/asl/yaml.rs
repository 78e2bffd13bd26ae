//! `sensor.yaml` reading: the keys traction uses, with errors that name the
//! file and, where the key is found in the text, its line. Unknown keys
//! (comments, vendor fields) are ignored. A leading OpenCV-style `%YAML:1.0`
//! directive is tolerated.

use crate::error::CliError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use yaml_rust2::{Yaml, YamlLoader};

/// A parsed `sensor.yaml`.
pub struct SensorYaml {
    path: PathBuf,
    text: String,
    doc: Yaml,
}

impl SensorYaml {
    /// Reads and parses `path`.
    pub fn load(path: &Path) -> Result<Self, CliError> {
        let raw = std::fs::read_to_string(path)
            .map_err(|e| CliError::file(path, format!("cannot read: {e}")))?;
        let text: String = raw
            .lines()
            .map(|l| {
                if l.trim_start().starts_with("%YAML:") {
                    ""
                } else {
                    l
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        let docs = YamlLoader::load_from_str(&text).map_err(|e| {
            CliError::line(
                path,
                e.marker().line() as u64,
                format!("malformed YAML: {}", e.info()),
            )
        })?;
        let doc = docs.into_iter().next().unwrap_or(Yaml::Null);
        if doc.as_hash().is_none() {
            return Err(CliError::file(path, "expected a YAML mapping of keys"));
        }
        Ok(SensorYaml {
            path: path.to_path_buf(),
            text,
            doc,
        })
    }

    /// The file this was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn line_of(&self, key: &str) -> Option<u64> {
        self.text
            .lines()
            .position(|l| {
                let t = l.trim_start();
                t.strip_prefix(key)
                    .is_some_and(|r| r.trim_start().starts_with(':'))
            })
            .map(|i| i as u64 + 1)
    }

    /// The error of a bad value at `key` (its line when known).
    pub fn bad(&self, key: &str, msg: &str) -> CliError {
        match self.line_of(key) {
            Some(line) => CliError::line(&self.path, line, format!("`{key}`: {msg}")),
            None => CliError::file(&self.path, format!("`{key}`: {msg}")),
        }
    }

    fn get(&self, key: &str) -> Result<&Yaml, CliError> {
        match &self.doc[key] {
            Yaml::BadValue | Yaml::Null => {
                Err(CliError::file(&self.path, format!("missing key `{key}`")))
            }
            v => Ok(v),
        }
    }

    /// Whether `key` is present.
    pub fn has(&self, key: &str) -> bool {
        !matches!(self.doc[key], Yaml::BadValue | Yaml::Null)
    }

    /// A finite number (integer or real).
    pub fn f64(&self, key: &str) -> Result<f64, CliError> {
        let v = self.get(key)?;
        let x = number(v).ok_or_else(|| self.bad(key, "expected a number"))?;
        if !x.is_finite() {
            return Err(self.bad(key, "must be finite"));
        }
        Ok(x)
    }

    /// A finite, strictly positive number.
    pub fn positive(&self, key: &str) -> Result<f64, CliError> {
        let x = self.f64(key)?;
        if x <= 0.0 {
            return Err(self.bad(key, "must be positive"));
        }
        Ok(x)
    }

    /// A string (numbers are accepted and printed).
    pub fn string(&self, key: &str) -> Result<String, CliError> {
        match self.get(key)? {
            Yaml::String(s) => Ok(s.clone()),
            Yaml::Integer(i) => Ok(i.to_string()),
            Yaml::Real(r) => Ok(r.clone()),
            _ => Err(self.bad(key, "expected a string")),
        }
    }

    /// The mapping's keys that are strings, in file order.
    pub fn keys(&self) -> Vec<String> {
        self.doc
            .as_hash()
            .map(|h| {
                h.keys()
                    .filter_map(|k| k.as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// A list of strings.
    pub fn strings(&self, key: &str) -> Result<Vec<String>, CliError> {
        self.get(key)?
            .as_vec()
            .and_then(|items| {
                items
                    .iter()
                    .map(|i| i.as_str().map(str::to_owned))
                    .collect::<Option<Vec<String>>>()
            })
            .ok_or_else(|| self.bad(key, "expected a list of strings"))
    }

    /// A list of finite numbers of length `n` (any length when `n` is `None`).
    pub fn numbers(&self, key: &str, n: Option<usize>) -> Result<Vec<f64>, CliError> {
        let v = self.get(key)?;
        list_of_numbers(v, n).ok_or_else(|| match n {
            Some(n) => self.bad(key, &format!("expected a list of {n} finite numbers")),
            None => self.bad(key, "expected a list of finite numbers"),
        })
    }

    /// A 4x4 row-major matrix `{cols: 4, rows: 4, data: [16 numbers]}`.
    pub fn matrix4(&self, key: &str) -> Result<[f32; 16], CliError> {
        let v = self.get(key)?;
        let ok_dims = v["cols"].as_i64() == Some(4) && v["rows"].as_i64() == Some(4);
        let data = list_of_numbers(&v["data"], Some(16));
        match (ok_dims, data) {
            (true, Some(d)) => {
                let mut m = [0f32; 16];
                for (o, x) in m.iter_mut().zip(d) {
                    *o = x as f32;
                }
                Ok(m)
            }
            _ => Err(self.bad(
                key,
                "expected {cols: 4, rows: 4, data: [16 finite numbers]}",
            )),
        }
    }

    /// A mapping of small integer ids to names, e.g. `{0: unknown, 2: wood}`.
    pub fn id_names(&self, key: &str) -> Result<BTreeMap<u8, String>, CliError> {
        let v = self.get(key)?;
        let h = v
            .as_hash()
            .ok_or_else(|| self.bad(key, "expected a mapping id: name"))?;
        let mut out = BTreeMap::new();
        for (k, name) in h {
            let id = k
                .as_i64()
                .and_then(|i| u8::try_from(i).ok())
                .ok_or_else(|| self.bad(key, "class ids must be integers 0..=255"))?;
            let name = match name {
                Yaml::String(s) => s.clone(),
                _ => return Err(self.bad(key, "class names must be strings")),
            };
            out.insert(id, name);
        }
        Ok(out)
    }

    /// A list of small integer ids.
    pub fn ids(&self, key: &str) -> Result<Vec<u8>, CliError> {
        let v = self.get(key)?;
        v.as_vec()
            .and_then(|items| {
                items
                    .iter()
                    .map(|i| i.as_i64().and_then(|i| u8::try_from(i).ok()))
                    .collect::<Option<Vec<u8>>>()
            })
            .ok_or_else(|| self.bad(key, "expected a list of integer ids 0..=255"))
    }
}

fn number(v: &Yaml) -> Option<f64> {
    match v {
        Yaml::Integer(i) => Some(*i as f64),
        Yaml::Real(_) => v.as_f64(),
        _ => None,
    }
}

fn list_of_numbers(v: &Yaml, n: Option<usize>) -> Option<Vec<f64>> {
    let items = v.as_vec()?;
    if n.is_some_and(|n| n != items.len()) {
        return None;
    }
    items
        .iter()
        .map(|i| number(i).filter(|x| x.is_finite()))
        .collect()
}

/// Writes a 4x4 row-major matrix in the ASL layout.
pub fn format_matrix4(key: &str, m: &[f32; 16]) -> String {
    let rows: Vec<String> = m
        .chunks(4)
        .map(|r| {
            r.iter()
                .map(|x| format!("{x:.9}"))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .collect();
    format!(
        "{key}:\n  cols: 4\n  rows: 4\n  data: [{}]\n",
        rows.join(",\n         ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load_str(name: &str, text: &str) -> Result<SensorYaml, CliError> {
        let dir = tempfile::Builder::new()
            .prefix(&format!("host-sim-yaml-{name}-"))
            .tempdir()
            .unwrap();
        let p = dir.path().join("sensor.yaml");
        std::fs::write(&p, text).unwrap();
        SensorYaml::load(&p)
    }

    #[test]
    fn reads_keys_and_ignores_others() {
        let m: [f32; 16] = [
            1., 0., 0., 0.1, 0., 1., 0., 0., 0., 0., 1., 0.03, 0., 0., 0., 1.,
        ];
        let text = format!(
            "%YAML:1.0\n# comment\nsensor_type: flow\nvendor: {{x: 1}}\nrate_hz: 100\nheight: 0.03\n{}intrinsics: [1, 2.5, 3, 4]\nclasses: {{0: unknown, 2: wood}}\nground_classes: [2]\n",
            format_matrix4("T_BS", &m)
        );
        let y = load_str("ok", &text).unwrap();
        assert_eq!(y.f64("rate_hz").unwrap(), 100.0);
        assert_eq!(y.positive("height").unwrap(), 0.03);
        assert_eq!(y.matrix4("T_BS").unwrap(), m);
        assert_eq!(
            y.numbers("intrinsics", Some(4)).unwrap(),
            vec![1.0, 2.5, 3.0, 4.0]
        );
        assert_eq!(
            y.id_names("classes").unwrap().get(&2).map(String::as_str),
            Some("wood")
        );
        assert_eq!(y.ids("ground_classes").unwrap(), vec![2]);
    }

    #[test]
    fn errors_name_file_and_line() {
        let y = load_str("bad", "rate_hz: 100\nheight: -1\nintrinsics: [1, 2]\n").unwrap();
        let e = y.positive("height").unwrap_err().to_string();
        assert!(
            e.ends_with("sensor.yaml:2: `height`: must be positive"),
            "{e}"
        );
        let e = y.numbers("intrinsics", Some(4)).unwrap_err().to_string();
        assert!(e.contains("sensor.yaml:3:"), "{e}");
        let e = y.f64("counts_per_radian").unwrap_err().to_string();
        assert!(
            e.ends_with("sensor.yaml: missing key `counts_per_radian`"),
            "{e}"
        );
        let e = load_str("syntax", "a: [1, 2\nb: 3\n")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("sensor.yaml:"), "{e}");
    }
}
