//! Waypoint routes: the default route of a world, and route files.
//!
//! A route file holds one waypoint a line, `x y` or `x,y` in metres in the
//! world frame (origin where the robot starts, x ahead); blank lines and
//! lines starting with `#` are skipped.

use crate::error::CliError;
use std::path::Path;

/// The office route: over the cable (which the robot must go round), the
/// first threshold strip onto the carpet, the second strip onto the tile, a
/// side step and back over the second strip onto the carpet.
pub const OFFICE_ROUTE: [[f32; 2]; 5] =
    [[3.0, 0.0], [6.0, 0.3], [9.5, 0.3], [9.5, -1.0], [5.0, -1.0]];

/// Parses a route file's text.
pub fn parse(text: &str, path: &Path) -> Result<Vec<[f32; 2]>, CliError> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let v: Vec<f32> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|e| CliError::file(path, format!("line {}: {e}", n + 1)))?;
        match v.as_slice() {
            [x, y] if x.is_finite() && y.is_finite() => out.push([*x, *y]),
            _ => {
                return Err(CliError::file(
                    path,
                    format!("line {}: expected `x y` in metres", n + 1),
                ));
            }
        }
    }
    if out.is_empty() {
        return Err(CliError::file(path, "no waypoints"));
    }
    Ok(out)
}

/// Reads a route file.
pub fn read(path: &Path) -> Result<Vec<[f32; 2]>, CliError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::file(path, format!("cannot read: {e}")))?;
    parse(&text, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn routes_parse_and_bad_lines_are_refused() {
        let p = Path::new("route.txt");
        let r = parse("# office\n1 2\n\n3.5,-1\n", p).unwrap();
        assert_eq!(r, vec![[1.0, 2.0], [3.5, -1.0]]);
        assert!(parse("1 2 3\n", p).is_err());
        assert!(parse("1 x\n", p).is_err());
        assert!(parse("# nothing\n", p).is_err());
        assert!(parse("nan 1\n", p).is_err());
    }
}
