//! `data.csv` reading and writing in the ASL layout: a `#`-prefixed header
//! line naming the columns, then one row per sample whose first column is an
//! integer time stamp in nanoseconds. Any malformed row (a wrong column
//! count, text that is not a number) is an error naming the file and the
//! line. [`read_rows`] also refuses rows that do not strictly increase in
//! time; [`read_rows_any_order`] keeps them, in file order, for a consumer
//! that rejects and counts them itself (a sensor log's duplicated or
//! out-of-order samples reach the estimator as they would on a robot).

use crate::error::CliError;
use std::io::Write;
use std::path::Path;
use vslam_core::Timestamp;

/// One data row: its 1-based line number, time stamp and the other fields.
pub struct Row {
    /// 1-based line number in the file.
    pub line: u64,
    /// The first column.
    pub t: Timestamp,
    /// The whole record as read: the time stamp, then the fields (each
    /// trimmed when it is read, [`Row::field`]).
    record: csv::StringRecord,
}

impl Row {
    /// Field `i` (after the time stamp) parsed as a finite `f64`.
    pub fn f64(&self, path: &Path, i: usize, name: &str) -> Result<f64, CliError> {
        let s = self.field(path, i, name)?;
        let x: f64 = s.parse().map_err(|_| {
            CliError::line(path, self.line, format!("{name}: `{s}` is not a number"))
        })?;
        if !x.is_finite() {
            return Err(CliError::line(
                path,
                self.line,
                format!("{name}: `{s}` is not finite"),
            ));
        }
        Ok(x)
    }

    /// Field `i` parsed as a finite `f32`: text that is finite as `f64` but
    /// out of `f32`'s range is refused like `inf`.
    pub fn f32(&self, path: &Path, i: usize, name: &str) -> Result<f32, CliError> {
        let x = self.f64(path, i, name)? as f32;
        if !x.is_finite() {
            let s = self.field(path, i, name)?;
            return Err(CliError::line(
                path,
                self.line,
                format!("{name}: `{s}` is out of range for f32"),
            ));
        }
        Ok(x)
    }

    /// Field `i` parsed as an `f64`, which may be NaN or infinite (`nan`,
    /// `inf`, `-inf` parse): the value is what the sensor reported, bad or
    /// not; only text that is no number is an error.
    pub fn number(&self, path: &Path, i: usize, name: &str) -> Result<f64, CliError> {
        let s = self.field(path, i, name)?;
        s.parse()
            .map_err(|_| CliError::line(path, self.line, format!("{name}: `{s}` is not a number")))
    }

    /// Field `i` parsed as an integer of type `T`.
    pub fn int<T: std::str::FromStr>(
        &self,
        path: &Path,
        i: usize,
        name: &str,
    ) -> Result<T, CliError> {
        let s = self.field(path, i, name)?;
        s.parse().map_err(|_| {
            CliError::line(
                path,
                self.line,
                format!("{name}: `{s}` is not an integer in range"),
            )
        })
    }

    /// Field `i` as text.
    pub fn field(&self, path: &Path, i: usize, name: &str) -> Result<&str, CliError> {
        i.checked_add(1)
            .and_then(|i| self.record.get(i))
            .map(str::trim)
            .ok_or_else(|| CliError::line(path, self.line, format!("missing column {name}")))
    }
}

/// Reads `path`, checking that every row has `columns` fields (time stamp
/// included) and that time stamps strictly increase.
pub fn read_rows(path: &Path, columns: usize) -> Result<Vec<Row>, CliError> {
    read(path, columns, true)
}

/// Reads `path`, checking that every row has `columns` fields (time stamp
/// included); the rows in file order, whatever their time stamps.
pub fn read_rows_any_order(path: &Path, columns: usize) -> Result<Vec<Row>, CliError> {
    read(path, columns, false)
}

fn read(path: &Path, columns: usize, increasing: bool) -> Result<Vec<Row>, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::file(path, format!("cannot read: {e}")))?;
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(text.as_bytes());
    let mut rows: Vec<Row> = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            CliError::line(path, line, format!("malformed CSV: {e}"))
        })?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        // Fields are trimmed where they are read: most rows have no spaces.
        let first = rec.get(0).unwrap_or("").trim();
        if first.starts_with('#') || (rec.len() == 1 && first.is_empty()) {
            continue;
        }
        if rec.len() != columns {
            return Err(CliError::line(
                path,
                line,
                format!("expected {columns} columns, found {}", rec.len()),
            ));
        }
        let ns: u64 = first.parse().map_err(|_| {
            CliError::line(
                path,
                line,
                format!("timestamp `{first}` is not an integer of nanoseconds"),
            )
        })?;
        let t = Timestamp(ns);
        if let Some(prev) = rows.last().filter(|prev| increasing && t <= prev.t) {
            let what = if t == prev.t {
                "duplicates"
            } else {
                "is earlier than"
            };
            return Err(CliError::line(
                path,
                line,
                format!(
                    "timestamp {ns} {what} the previous row's ({}, line {})",
                    prev.t.0, prev.line
                ),
            ));
        }
        rows.push(Row {
            line,
            t,
            record: rec,
        });
    }
    Ok(rows)
}

/// The first line of `path` (its header, in an ASL `data.csv`); empty for
/// an empty file.
pub fn first_line(path: &Path) -> Result<String, CliError> {
    use std::io::BufRead;
    let file =
        std::fs::File::open(path).map_err(|e| CliError::file(path, format!("cannot read: {e}")))?;
    let mut line = Vec::new();
    std::io::BufReader::new(file)
        .read_until(b'\n', &mut line)
        .map_err(|e| CliError::file(path, format!("cannot read: {e}")))?;
    Ok(String::from_utf8_lossy(&line).into_owned())
}

/// Writes a header line and rows (each row already formatted without the newline).
pub fn write_rows(
    path: &Path,
    header: &str,
    rows: impl IntoIterator<Item = String>,
) -> Result<(), CliError> {
    let file = std::fs::File::create(path)
        .map_err(|e| CliError::file(path, format!("cannot create: {e}")))?;
    let mut w = std::io::BufWriter::new(file);
    let io = |e: std::io::Error| CliError::file(path, format!("cannot write: {e}"));
    writeln!(w, "{header}").map_err(io)?;
    for r in rows {
        writeln!(w, "{r}").map_err(io)?;
    }
    w.flush().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `text` as `data.csv` in a scratch folder, removed when the returned
    /// guard is dropped.
    fn write(name: &str, text: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::Builder::new()
            .prefix(&format!("host-sim-csv-{name}-"))
            .tempdir()
            .unwrap();
        let p = dir.path().join("data.csv");
        std::fs::write(&p, text).unwrap();
        (dir, p)
    }

    #[test]
    fn reads_rows_with_header_and_spaces() {
        let (_dir, p) = write(
            "ok",
            "#timestamp [ns],left [ticks],right [ticks]\n100, 1,2\n200,3 ,-4\n  300 ,\t5 , 6 \n",
        );
        let rows = read_rows(&p, 3).unwrap();
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[2].t, Timestamp(300));
        assert_eq!(rows[2].int::<i64>(&p, 0, "left").unwrap(), 5);
        assert_eq!(rows[2].f64(&p, 1, "right").unwrap(), 6.0);
        assert_eq!(rows[1].t, Timestamp(200));
        assert_eq!(rows[1].int::<i64>(&p, 1, "right").unwrap(), -4);
        assert_eq!(rows[1].line, 3);
    }

    #[test]
    fn errors_name_file_and_line() {
        let (_dir, p) = write("order", "#t,a\n100,1\n90,2\n");
        let e = read_rows(&p, 2).err().unwrap().to_string();
        assert!(
            e.contains("data.csv:3: timestamp 90 is earlier than"),
            "{e}"
        );
        let (_dir, p) = write("dup", "#t,a\n100,1\n100,2\n");
        let e = read_rows(&p, 2).err().unwrap().to_string();
        assert!(e.contains("data.csv:3: timestamp 100 duplicates"), "{e}");
        let (_dir, p) = write("cols", "#t,a\n100,1,5\n");
        let e = read_rows(&p, 2).err().unwrap().to_string();
        assert!(e.contains("data.csv:2: expected 2 columns, found 3"), "{e}");
        let (_dir, p) = write("ts", "#t,a\n1.5e9,1\n");
        let e = read_rows(&p, 2).err().unwrap().to_string();
        assert!(e.contains("data.csv:2: timestamp `1.5e9`"), "{e}");
        let (_dir, p) = write("num", "#t,a\n100,abc\n");
        let rows = read_rows(&p, 2).unwrap();
        let e = rows[0].f64(&p, 0, "a").unwrap_err().to_string();
        assert!(e.contains("data.csv:2: a: `abc` is not a number"), "{e}");
        let e = rows[0].number(&p, 0, "a").unwrap_err().to_string();
        assert!(e.contains("data.csv:2: a: `abc` is not a number"), "{e}");
    }

    #[test]
    fn a_value_beyond_f32_is_refused_as_f32_but_not_as_f64() {
        let (_dir, p) = write("f32range", "#t,a\n100,5.4512e51\n");
        let rows = read_rows(&p, 2).unwrap();
        assert_eq!(rows[0].f64(&p, 0, "a").unwrap(), 5.4512e51);
        let e = rows[0].f32(&p, 0, "a").unwrap_err().to_string();
        assert!(
            e.contains("data.csv:2: a: `5.4512e51` is out of range for f32"),
            "{e}"
        );
        assert_eq!(rows[0].f32(&p, 0, "a").ok(), None);
    }

    #[test]
    fn any_order_keeps_bad_values_and_times_but_not_bad_syntax() {
        let (_dir, p) = write("any", "#t,a\n100,nan\n100,inf\n90,-inf\n95,1.5\n");
        assert!(read_rows(&p, 2).is_err());
        let rows = read_rows_any_order(&p, 2).unwrap();
        let t: Vec<u64> = rows.iter().map(|r| r.t.0).collect();
        assert_eq!(t, [100, 100, 90, 95]);
        assert!(rows[0].number(&p, 0, "a").unwrap().is_nan());
        assert_eq!(rows[1].number(&p, 0, "a").unwrap(), f64::INFINITY);
        assert_eq!(rows[2].number(&p, 0, "a").unwrap(), f64::NEG_INFINITY);
        let e = rows[0].f64(&p, 0, "a").unwrap_err().to_string();
        assert!(e.contains("data.csv:2: a: `nan` is not finite"), "{e}");
        let (_dir, p) = write("any-cols", "#t,a\n100,1\n90,2,3\n");
        let e = read_rows_any_order(&p, 2).err().unwrap().to_string();
        assert!(e.contains("data.csv:3: expected 2 columns, found 3"), "{e}");
    }
}
