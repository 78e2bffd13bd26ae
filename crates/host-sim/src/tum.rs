//! TUM trajectory text: `timestamp tx ty tz qx qy qz qw`, one pose per line,
//! time stamps in seconds (written exactly from integer nanoseconds), so
//! `evo` and the usual tools read it.

use crate::asl::GroundTruth;
use crate::error::CliError;
use std::io::Write;
use std::path::Path;
use vslam_core::Timestamp;

/// One pose: position and Hamilton quaternion `x, y, z, w`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TumPose {
    /// Time stamp.
    pub t: Timestamp,
    /// Position, metres.
    pub p: [f64; 3],
    /// Orientation, `qx qy qz qw`.
    pub q_xyzw: [f64; 4],
}

/// Ground truth as poses (the EuRoC rows' position and attitude).
pub fn truth_poses(gt: &[GroundTruth]) -> Vec<TumPose> {
    gt.iter()
        .map(|g| {
            let [w, x, y, z] = g.q_wxyz;
            TumPose {
                t: g.t,
                p: g.p,
                q_xyzw: [x, y, z, w],
            }
        })
        .collect()
}

/// Formats a nanosecond time stamp as seconds with nine decimals.
pub fn format_seconds(t: Timestamp) -> String {
    format!("{}.{:09}", t.0 / 1_000_000_000, t.0 % 1_000_000_000)
}

/// Writes a trajectory file; an empty trajectory writes none (and removes
/// a file of that name left by an earlier run), so every trajectory file
/// has poses.
pub fn write_tum(path: &Path, poses: &[TumPose]) -> Result<(), CliError> {
    if poses.is_empty() {
        return match std::fs::remove_file(path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(CliError::file(path, format!("cannot remove: {e}")))
            }
            _ => Ok(()),
        };
    }
    let file = std::fs::File::create(path)
        .map_err(|e| CliError::file(path, format!("cannot create: {e}")))?;
    let mut w = std::io::BufWriter::new(file);
    let io = |e: std::io::Error| CliError::file(path, format!("cannot write: {e}"));
    for p in poses {
        let [x, y, z] = p.p;
        let [qx, qy, qz, qw] = p.q_xyzw;
        writeln!(
            w,
            "{} {x:.6} {y:.6} {z:.6} {qx:.9} {qy:.9} {qz:.9} {qw:.9}",
            format_seconds(p.t)
        )
        .map_err(io)?;
    }
    w.flush().map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_empty_trajectory_writes_no_file() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let path = dir.join("empty.tum");
        let one = TumPose {
            t: Timestamp(1_500_000_000),
            p: [1.0, 2.0, 3.0],
            q_xyzw: [0.0, 0.0, 0.0, 1.0],
        };
        write_tum(&path, &[one]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "1.500000000 1.000000 2.000000 3.000000 0.000000000 0.000000000 0.000000000 1.000000000\n"
        );
        write_tum(&path, &[]).unwrap();
        assert!(!path.exists(), "an empty trajectory left a file");
        write_tum(&path, &[]).unwrap();
    }

    #[test]
    fn seconds_are_exact() {
        assert_eq!(
            format_seconds(Timestamp(1_403_636_579_758_555_392)),
            "1403636579.758555392"
        );
        assert_eq!(format_seconds(Timestamp(5)), "0.000000005");
    }
}
