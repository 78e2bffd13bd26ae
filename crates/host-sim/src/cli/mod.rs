//! The commands of the `host-sim` program, one module each. Every command is
//! a clap `Args` struct plus `run(args) -> Result<(), CliError>`; the binary
//! only parses the command line and dispatches.
//!
//! This module holds what the commands share: argument parsers, the fixed
//! RANSAC seed, and how estimation errors map onto exit codes.

/// Appends one formatted line to a `String` (the commands build their whole
/// output before writing it, so a failure never leaves half a report).
macro_rules! outln {
    ($s:expr, $($arg:tt)*) => {{
        $s.push_str(&format!($($arg)*));
        $s.push('\n');
    }};
}

pub mod accuracy;
pub mod calibrate;
pub mod homography;
pub mod import;
pub mod run;
pub mod segmenter;
pub mod terrain;
pub mod track;

use crate::error::CliError;
use std::io::Write;
use std::path::Path;
use vslam_core::homography::{Homography, HomographyError};

/// Seed of every RANSAC run of the program: equal inputs give equal outputs.
pub const RANSAC_SEED: u64 = 0x7472_6163_7469_6f6e; // "traction"

/// Writes a finished report to stdout. A closed pipe (`| head`) is not an
/// error; any other write failure is.
pub fn write_stdout(text: &str) -> Result<(), CliError> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(CliError::file(
            Path::new("<stdout>"),
            format!("cannot write: {e}"),
        )),
    }
}

/// Parses `a,b,c,...` into exactly `N` finite numbers (for clap).
pub fn parse_numbers<const N: usize>(s: &str) -> Result<[f32; N], String> {
    let fields: Vec<&str> = s.split(',').map(str::trim).collect();
    if fields.len() != N {
        return Err(format!(
            "expected {N} comma-separated numbers, found {}",
            fields.len()
        ));
    }
    let mut out = [0f32; N];
    for (slot, f) in out.iter_mut().zip(&fields) {
        let x: f32 = f.parse().map_err(|_| format!("`{f}` is not a number"))?;
        if !x.is_finite() {
            return Err(format!("`{f}` is not finite"));
        }
        *slot = x;
    }
    Ok(out)
}

/// Parses a positive, finite pixel threshold (for clap).
pub fn parse_threshold(s: &str) -> Result<f32, String> {
    let x: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("`{s}` must be a positive, finite number of pixels"))
    }
}

/// Maps a RANSAC failure onto the program's errors: not enough evidence on
/// valid input is [`CliError::NoResult`] (exit 1); input the estimator cannot
/// take at all is a usage error (exit 2). `what` names the input.
pub fn ransac_error(what: &str, e: HomographyError) -> CliError {
    match e {
        HomographyError::TooFewPoints { .. }
        | HomographyError::DuplicatePoints
        | HomographyError::Collinear
        | HomographyError::Degenerate
        | HomographyError::NearSingular
        | HomographyError::NoConsensus => {
            CliError::NoResult(format!("no homography from {what}: {e}"))
        }
        HomographyError::TooManyPoints { .. }
        | HomographyError::LengthMismatch
        | HomographyError::NonFinite { .. }
        | HomographyError::InvalidParameter => CliError::Usage(format!("{what}: {e}")),
    }
}

/// The homography as 9 row-major numbers scaled so that `H[2][2] = 1` (the
/// usual published form), or at unit Frobenius norm with `det H > 0` when
/// `H[2][2]` is (nearly) zero.
pub fn homography_row_major(h: &Homography) -> [f32; 9] {
    let m = h.to_row_major();
    let h22 = m[8];
    // The stored H has unit Frobenius norm: entries are at most 1.
    if h22.abs() > 1e-6 {
        m.map(|v| v / h22)
    } else {
        m
    }
}

/// Formats a 3x3 row-major matrix as three indented lines.
pub fn format_matrix(m: &[f32; 9]) -> String {
    m.chunks_exact(3)
        .map(|r| format!("  [{:>13.6e} {:>13.6e} {:>13.6e}]", r[0], r[1], r[2]))
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_parse_and_reject() {
        assert_eq!(
            parse_numbers::<4>("400, 401,160,120.5").unwrap(),
            [400.0, 401.0, 160.0, 120.5]
        );
        assert!(parse_numbers::<4>("1,2,3").is_err());
        assert!(parse_numbers::<4>("1,2,3,x").is_err());
        assert!(parse_numbers::<4>("1,2,3,inf").is_err());
        assert_eq!(parse_threshold("2.5").unwrap(), 2.5);
        assert!(parse_threshold("0").is_err());
        assert!(parse_threshold("-1").is_err());
        assert!(parse_threshold("NaN").is_err());
    }

    #[test]
    fn exit_codes_of_ransac_errors() {
        assert_eq!(
            ransac_error("m", HomographyError::NoConsensus).exit_code(),
            1
        );
        assert_eq!(
            ransac_error("m", HomographyError::TooFewPoints { got: 3 }).exit_code(),
            1
        );
        assert_eq!(
            ransac_error(
                "m",
                HomographyError::TooManyPoints {
                    got: 9,
                    capacity: 4
                }
            )
            .exit_code(),
            2
        );
    }

    #[test]
    fn row_major_is_scaled_to_unit_corner() {
        let h =
            Homography::from_row_major(&[2.0, 0.0, 10.0, 0.0, 2.0, -4.0, 0.0, 0.0, 2.0]).unwrap();
        let m = homography_row_major(&h);
        let want = [1.0, 0.0, 5.0, 0.0, 1.0, -2.0, 0.0, 0.0, 1.0];
        for (a, b) in m.iter().zip(want) {
            assert!((a - b).abs() < 1e-5, "{m:?}");
        }
    }
}
