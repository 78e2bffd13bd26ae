//! Point-match files for `host-sim homography`: one `x1 y1 x2 y2` per line,
//! separated by spaces or commas; `#` starts a comment; blank lines are skipped.

use crate::error::CliError;
use std::path::Path;

/// One correspondence: a pixel in image 1 and the matching pixel in image 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    /// Pixel in image 1.
    pub p1: [f32; 2],
    /// Pixel in image 2.
    pub p2: [f32; 2],
}

/// Parses the text of a match file; `path` only names the file in errors.
pub fn parse_matches(path: &Path, text: &str) -> Result<Vec<Match>, CliError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i as u64 + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let fields: Vec<&str> = content
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        if fields.len() != 4 {
            return Err(CliError::line(
                path,
                line_no,
                format!("expected 4 numbers `x1 y1 x2 y2`, found {}", fields.len()),
            ));
        }
        let mut v = [0f32; 4];
        for (slot, f) in v.iter_mut().zip(&fields) {
            let x: f32 = f
                .parse()
                .map_err(|_| CliError::line(path, line_no, format!("`{f}` is not a number")))?;
            if !x.is_finite() {
                return Err(CliError::line(
                    path,
                    line_no,
                    format!("`{f}` is not finite"),
                ));
            }
            *slot = x;
        }
        out.push(Match {
            p1: [v[0], v[1]],
            p2: [v[2], v[3]],
        });
    }
    Ok(out)
}

/// Reads and parses a match file.
pub fn read_matches(path: &Path) -> Result<Vec<Match>, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::file(path, format!("cannot read: {e}")))?;
    parse_matches(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_spaces_commas_comments() {
        let p = Path::new("m.txt");
        let m = parse_matches(p, "# header\n1 2 3 4\n\n5,6, 7 ,8 # trailing\n").unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(
            m[1],
            Match {
                p1: [5.0, 6.0],
                p2: [7.0, 8.0]
            }
        );
    }

    #[test]
    fn errors_name_file_and_line() {
        let p = Path::new("m.txt");
        let e = parse_matches(p, "1 2 3 4\n1 2 x 4\n").unwrap_err();
        assert_eq!(e.to_string(), "m.txt:2: `x` is not a number");
        let e = parse_matches(p, "1 2 3\n").unwrap_err();
        assert!(
            e.to_string().starts_with("m.txt:1: expected 4 numbers"),
            "{e}"
        );
        let e = parse_matches(p, "1 2 3 NaN\n").unwrap_err();
        assert!(e.to_string().starts_with("m.txt:1:"), "{e}");
    }
}
