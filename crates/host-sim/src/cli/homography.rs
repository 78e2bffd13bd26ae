//! `host-sim homography MATCHES`: a robust homography from given point
//! matches (RANSAC with a fixed seed, re-fit and Levenberg-Marquardt
//! refinement on the inliers; Hartley & Zisserman, *Multiple View Geometry*,
//! 2nd ed., Algorithms 4.2 and 4.6), as computed by
//! [`vslam_core::homography::HomographyRansac`].

use super::{
    RANSAC_SEED, format_matrix, homography_row_major, parse_threshold, ransac_error, write_stdout,
};
use crate::error::CliError;
use crate::matches::read_matches;
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;
use vslam_core::geometry::Vec2;
use vslam_core::homography::{HomographyRansac, RansacParams};

/// The most matches one file may hold.
pub const MAX_MATCHES: usize = 8192;

/// Fewest inliers a homography must have (fewer matches than this: all of them).
const MIN_INLIERS: usize = 8;

/// Arguments of `host-sim homography`.
#[derive(Debug, Args)]
#[command(
    about = "Robust homography (RANSAC + refinement) from point matches",
    long_about = "Robust homography x2 ~ H x1 from point matches (RANSAC with a fixed seed, \
                  so the output is deterministic, then a least-squares re-fit and \
                  Levenberg-Marquardt refinement on the inliers).\n\n\
                  MATCHES holds one match `x1 y1 x2 y2` per line (image-1 pixel, image-2 \
                  pixel), separated by spaces or commas; `#` starts a comment.\n\n\
                  A result needs at least 8 inliers (all matches, when there are 4 to 7). \
                  H is printed row-major, scaled so that H[2][2] = 1.\n\n\
                  Exit codes: 0 success; 1 no homography (too few matches, degenerate \
                  geometry, no consensus); 2 bad input (unreadable file, malformed line, \
                  more than 8192 matches)."
)]
pub struct HomographyArgs {
    /// The match file: `x1 y1 x2 y2` per line.
    pub matches: PathBuf,
    /// Largest transfer error ||x2 - H x1|| of an inlier, pixels.
    #[arg(long, value_name = "PX", default_value_t = 3.0, value_parser = parse_threshold)]
    pub threshold: f32,
    /// Print `{"homography": [9 numbers, row-major], "inliers": [0 or 1 per match]}`.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct JsonOutput {
    homography: [f32; 9],
    inliers: Vec<u8>,
}

/// Runs `host-sim homography`.
pub fn run(args: HomographyArgs) -> Result<(), CliError> {
    let matches = read_matches(&args.matches)?;
    let what = args.matches.display().to_string();
    if matches.len() > MAX_MATCHES {
        return Err(CliError::file(
            &args.matches,
            format!(
                "{} matches exceed the maximum of {MAX_MATCHES}",
                matches.len()
            ),
        ));
    }
    let points1: Vec<Vec2> = matches.iter().map(|m| Vec2::from(m.p1)).collect();
    let points2: Vec<Vec2> = matches.iter().map(|m| Vec2::from(m.p2)).collect();
    let params = RansacParams {
        threshold_px: args.threshold,
        min_inliers: MIN_INLIERS.min(matches.len()).max(4),
        seed: RANSAC_SEED,
        ..Default::default()
    };
    // 16 bytes of scratch per match: keep it off the stack.
    let mut ransac =
        Box::new(HomographyRansac::<MAX_MATCHES>::new(params).map_err(|e| ransac_error(&what, e))?);
    let mut mask = vec![false; matches.len()];
    let report = ransac
        .estimate(&points1, &points2, &mut mask)
        .map_err(|e| ransac_error(&what, e))?;
    let h = homography_row_major(&report.homography);
    if args.json {
        let out = JsonOutput {
            homography: h,
            inliers: mask.iter().map(|&m| u8::from(m)).collect(),
        };
        let text = serde_json::to_string(&out)
            .map_err(|e| CliError::Usage(format!("cannot write JSON: {e}")))?;
        write_stdout(&format!("{text}\n"))
    } else {
        let mut s = String::new();
        outln!(
            s,
            "{what}: {} matches, {} inliers (threshold {} px, RMS transfer error {:.3} px, \
             {} RANSAC samples{})",
            report.point_count,
            report.inlier_count,
            args.threshold,
            report.rms_error_px,
            report.iterations,
            if report.refined { ", refined" } else { "" },
        );
        println!(
            "H (image 1 -> image 2, H[2][2] = 1):\n{}",
            format_matrix(&h)
        );
        let outliers: Vec<String> = mask
            .iter()
            .enumerate()
            .filter(|(_, m)| !**m)
            .map(|(i, _)| (i + 1).to_string())
            .collect();
        if !outliers.is_empty() {
            outln!(s, "outliers (match number): {}", outliers.join(" "));
        }
        write_stdout(&s)
    }
}
