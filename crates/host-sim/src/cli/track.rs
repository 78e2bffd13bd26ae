//! `host-sim track IMG1 IMG2`: the two-image vision front end of traction on
//! files. Shi-Tomasi corners on IMG1 ([`vslam_core::corners`]), then the
//! estimator's camera-path stages ([`traction::frontend`]): pyramidal
//! Lucas-Kanade into IMG2 ([`track_pairs`], Bouguet's formulation), a RANSAC
//! homography on the tracked pairs and, given the intrinsics, its
//! decomposition into `{R, t/d, n}` ([`fit_pairs`]), with the positive-depth
//! selection ([`vslam_core::decompose`], Ma et al., *An Invitation to 3-D
//! Vision*, sec. 5.3.3). The options (corner count, window, levels,
//! threshold, normal prior) are this command's; the stages are the library's.

use super::{
    RANSAC_SEED, format_matrix, homography_row_major, parse_numbers, parse_threshold, ransac_error,
    write_stdout,
};
use crate::error::CliError;
use crate::pngio::{GrayImage, load_gray};
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};
use traction::frontend::{FitError, fit_pairs, track_pairs};
use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};
use vslam_core::decompose::{
    HomographyDecomposition, NormalPrior, PinholeIntrinsics, PlaneMotion, SelectError,
    SelectParams, Selection,
};
use vslam_core::geometry::{Vec2, Vec3};
use vslam_core::homography::{HomographyRansac, RansacParams, RansacReport};
use vslam_core::lk::{LkConfig, LostReason, TrackCounts, TrackResult, Tracker};
use vslam_core::pyramid::{Pyramid, storage_bytes};

/// The most corners one run detects and tracks.
pub const MAX_POINTS: usize = 4096;

/// Tracked points of one image, as many as corners.
type Pairs = heapless::Vec<Vec2, MAX_POINTS>;

/// Arguments of `host-sim track`.
#[derive(Debug, Args)]
#[command(
    about = "Track corners from IMG1 to IMG2, fit a homography, decompose it",
    long_about = "Shi-Tomasi corners on IMG1, pyramidal Lucas-Kanade into IMG2, a RANSAC \
                  homography x2 ~ H x1 on the tracked pairs (fixed seed: deterministic), and \
                  with --intrinsics its decomposition into camera motion and plane \
                  {R, t/d, n} (X2 = R X1 + t, plane n.X1 = d in camera 1).\n\n\
                  Without --intrinsics nothing is decomposed: the JSON has \
                  \"decompositions\": [] and \"selected\": null. With them, a candidate is \
                  selected when it alone puts >= 90 % of the inliers in front of both \
                  cameras, or (with --normal) when its normal is the closest to the prior \
                  within --normal-max-angle; otherwise \"selected\" is null.\n\n\
                  --json prints {\"homography\": [9, row-major, H[2][2] = 1], \"tracks\": \
                  [[x1,y1,x2,y2,status],...] (status 1 tracked, 0 lost; x2,y2 are the last \
                  estimate, null if not finite), \"inliers\": N, \"decompositions\": \
                  [{\"R\":[9 row-major],\"t\":[3] (t/d),\"n\":[3]}], \"selected\": index or \
                  null}.\n\n\
                  Both images must be PNGs of the same size (colour is converted to gray). \
                  Exit codes: 0 success; 1 no homography (too few tracks, no consensus); \
                  2 bad input (missing or unreadable file, size mismatch, bad option)."
)]
pub struct TrackArgs {
    /// First image (PNG); corners are detected here.
    pub img1: PathBuf,
    /// Second image (PNG, same size).
    pub img2: PathBuf,
    /// Pinhole intrinsics in pixels, `fu,fv,cu,cv`; enables the decomposition.
    #[arg(long, value_name = "fu,fv,cu,cv", value_parser = parse_numbers::<4>)]
    pub intrinsics: Option<[f32; 4]>,
    /// Most corners to detect (strongest first, at least 10 px apart).
    #[arg(long, value_name = "N", default_value_t = 200,
          value_parser = clap::value_parser!(u32).range(4..=MAX_POINTS as i64))]
    pub points: u32,
    /// Pyramid levels, including the full-resolution one.
    #[arg(long, value_name = "L", default_value_t = 3,
          value_parser = clap::value_parser!(u32).range(1..=8))]
    pub levels: u32,
    /// Lucas-Kanade window side, pixels (odd, 3 to 31).
    #[arg(long, value_name = "W", default_value_t = 21,
          value_parser = clap::value_parser!(u32).range(3..=31))]
    pub window: u32,
    /// Largest transfer error of a homography inlier, pixels.
    #[arg(long, value_name = "PX", default_value_t = 3.0, value_parser = parse_threshold)]
    pub threshold: f32,
    /// Prior plane normal in camera 1, `nx,ny,nz` (e.g. `0,0,1` for a ceiling
    /// above an upward camera); decides between candidates that pass the
    /// depth test.
    #[arg(long, value_name = "nx,ny,nz", value_parser = parse_numbers::<3>,
          requires = "intrinsics")]
    pub normal: Option<[f32; 3]>,
    /// Largest angle between the selected normal and --normal, degrees.
    #[arg(long, value_name = "DEG", default_value_t = 30.0, value_parser = parse_threshold)]
    pub normal_max_angle: f32,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// Everything one run found.
struct Outcome {
    corners: Vec<Corner>,
    results: Vec<TrackResult>,
    counts: TrackCounts,
    report: RansacReport,
    decomposition: Option<HomographyDecomposition>,
    selection: Option<Result<Selection, SelectError>>,
}

#[derive(Serialize)]
struct JsonCandidate {
    #[serde(rename = "R")]
    r: [f32; 9],
    t: [f32; 3],
    n: [f32; 3],
}

#[derive(Serialize)]
struct JsonOutput {
    homography: [f32; 9],
    tracks: Vec<(f32, f32, f32, f32, u8)>,
    inliers: usize,
    decompositions: Vec<JsonCandidate>,
    selected: Option<usize>,
}

/// Reads both images and checks they match.
fn load_pair(args: &TrackArgs) -> Result<(GrayImage, GrayImage), CliError> {
    let a = load_gray(&args.img1)?;
    let b = load_gray(&args.img2)?;
    if (a.width, a.height) != (b.width, b.height) {
        return Err(CliError::file(
            &args.img2,
            format!(
                "is {}x{} but {} is {}x{}: the images must have the same size",
                b.width,
                b.height,
                args.img1.display(),
                a.width,
                a.height
            ),
        ));
    }
    Ok((a, b))
}

fn image_error(path: &Path, e: impl std::fmt::Display) -> CliError {
    CliError::file(path, e.to_string())
}

/// The intrinsics and selection settings, if decomposing; checked before
/// any image is read.
fn calibration(args: &TrackArgs) -> Result<Option<(PinholeIntrinsics, SelectParams)>, CliError> {
    let Some([fu, fv, cu, cv]) = args.intrinsics else {
        return Ok(None);
    };
    let k = PinholeIntrinsics::new(fu, fv, cu, cv)
        .map_err(|e| CliError::Usage(format!("--intrinsics: {e}")))?;
    let prior = match args.normal {
        None => None,
        Some(n) => Some(
            NormalPrior::new(&Vec3::from(n), args.normal_max_angle.to_radians())
                .map_err(|e| CliError::Usage(format!("--normal: {e}")))?,
        ),
    };
    let params = SelectParams {
        prior,
        ..SelectParams::default()
    };
    Ok(Some((k, params)))
}

/// Runs the pipeline; nothing is printed here.
fn estimate(args: &TrackArgs) -> Result<Outcome, CliError> {
    let calibration = calibration(args)?;
    let (img1, img2) = load_pair(args)?;
    let view1 = img1.view().map_err(|e| image_error(&args.img1, e))?;
    let view2 = img2.view().map_err(|e| image_error(&args.img2, e))?;
    let (w, h) = (img1.width, img1.height);
    let levels = args.levels as usize;
    let max_levels = Pyramid::max_levels(w, h);
    if levels > max_levels {
        return Err(CliError::Usage(format!(
            "--levels {levels}: a {w}x{h} image allows at most {max_levels}"
        )));
    }
    let window = args.window as usize;
    if window.is_multiple_of(2) {
        return Err(CliError::Usage(format!("--window {window} must be odd")));
    }

    // Corners keep half a window plus the one-pixel gradient frame and the
    // bilinear neighbour from the edges, so their level-0 templates fit.
    let corner_config = CornerConfig {
        border: window / 2 + 2,
        ..CornerConfig::default()
    };
    let mut scratch = vec![0f32; scratch_len(w, h, corner_config.block_size)];
    let mut corners = vec![Corner::default(); args.points as usize];
    let found = detect_corners(&view1, &corner_config, &mut scratch, &mut corners)
        .map_err(|e| CliError::Usage(format!("corner detection: {e}")))?;
    corners.truncate(found);
    if found < 4 {
        return Err(CliError::NoResult(format!(
            "{}: only {found} corners found (the image is too uniform); a homography needs 4",
            args.img1.display()
        )));
    }

    let bytes = storage_bytes(w, h, levels);
    let (mut store1, mut store2) = (vec![0u8; bytes], vec![0u8; bytes]);
    let pyr1 =
        Pyramid::build_in(&view1, levels, &mut store1).map_err(|e| image_error(&args.img1, e))?;
    let pyr2 =
        Pyramid::build_in(&view2, levels, &mut store2).map_err(|e| image_error(&args.img2, e))?;
    let tracker = Tracker::new(LkConfig {
        window,
        levels,
        ..LkConfig::default()
    })
    .map_err(|e| CliError::Usage(e.to_string()))?;
    let points: Vec<Vec2> = corners.iter().map(Corner::position).collect();
    let mut results = Vec::with_capacity(points.len());
    let (mut p1, mut p2) = (Box::new(Pairs::new()), Box::new(Pairs::new()));
    let counts = track_pairs(&tracker, &pyr1, &pyr2, &points, (&mut p1, &mut p2), |r| {
        results.push(*r)
    })
    .map_err(|e| CliError::Usage(format!("tracking: {e}")))?;

    let what = format!("{} tracked points", p1.len());
    let mut ransac = Box::new(
        HomographyRansac::<MAX_POINTS>::new(RansacParams {
            threshold_px: args.threshold,
            seed: RANSAC_SEED,
            ..RansacParams::default()
        })
        .map_err(|e| ransac_error(&what, e))?,
    );
    let mut mask = vec![false; p1.len()];
    let (report, decomposition) = fit_pairs(
        &mut ransac,
        &p1,
        &p2,
        &mut mask,
        calibration.as_ref().map(|(k, _)| k),
    )
    .map_err(|e| match e {
        FitError::Homography(e) => ransac_error(&what, e),
        FitError::Decomposition(e) => {
            CliError::NoResult(format!("the homography cannot be decomposed: {e}"))
        }
    })?;
    let selection = match (&decomposition, &calibration) {
        (Some(d), Some((_, params))) => Some(d.select(&p1, &mask, params)),
        _ => None,
    };
    Ok(Outcome {
        corners,
        results,
        counts,
        report,
        decomposition,
        selection,
    })
}

fn rotation_row_major(c: &PlaneMotion) -> [f32; 9] {
    let m = c.rotation.matrix();
    core::array::from_fn(|i| m[(i / 3, i % 3)])
}

fn json_output(o: &Outcome) -> JsonOutput {
    let tracks = o
        .corners
        .iter()
        .zip(&o.results)
        .map(|(c, r)| {
            let p = c.position();
            (
                p.x,
                p.y,
                r.position.x,
                r.position.y,
                u8::from(r.is_tracked()),
            )
        })
        .collect();
    let decompositions = o
        .decomposition
        .iter()
        .flat_map(|d| d.candidates())
        .map(|c| JsonCandidate {
            r: rotation_row_major(c),
            t: c.translation_over_distance.into(),
            n: c.normal.into(),
        })
        .collect();
    JsonOutput {
        homography: homography_row_major(&o.report.homography),
        tracks,
        inliers: o.report.inlier_count,
        decompositions,
        selected: match &o.selection {
            Some(Ok(s)) => Some(s.index),
            _ => None,
        },
    }
}

fn vec3(v: &Vec3) -> String {
    format!("({:+.4}, {:+.4}, {:+.4})", v.x, v.y, v.z)
}

fn summary(args: &TrackArgs, o: &Outcome) -> String {
    let mut s = String::new();
    outln!(
        s,
        "{} -> {}: {} corners, {} tracked ({} levels, {} px window)",
        args.img1.display(),
        args.img2.display(),
        o.corners.len(),
        o.counts.tracked,
        args.levels,
        args.window
    );
    let lost: Vec<String> = LostReason::ALL
        .iter()
        .filter(|r| o.counts.lost_for(**r) > 0)
        .map(|r| format!("{} {}", r.name(), o.counts.lost_for(*r)))
        .collect();
    if !lost.is_empty() {
        outln!(s, "lost: {}", lost.join(", "));
    }
    let r = &o.report;
    outln!(
        s,
        "homography: {} inliers of {} tracked (threshold {} px, RMS transfer error {:.3} px, \
         {} RANSAC samples)",
        r.inlier_count,
        r.point_count,
        args.threshold,
        r.rms_error_px,
        r.iterations
    );
    outln!(
        s,
        "H (IMG1 -> IMG2, H[2][2] = 1):\n{}",
        format_matrix(&homography_row_major(&r.homography))
    );
    let Some(d) = &o.decomposition else {
        outln!(
            s,
            "decomposition: not computed (give --intrinsics fu,fv,cu,cv)"
        );
        return s;
    };
    let sv = d.singular_values();
    outln!(
        s,
        "decomposition: {} candidate(s){}, singular values {:.5} {:.5} {:.5}",
        d.candidates().len(),
        if d.is_pure_rotation() {
            " (pure rotation: t/d = 0, plane undefined)"
        } else {
            ""
        },
        sv[0],
        sv[1],
        sv[2]
    );
    let chosen = match &o.selection {
        Some(Ok(sel)) => Some(sel.index),
        _ => None,
    };
    for (i, c) in d.candidates().iter().enumerate() {
        // Angle-axis; nalgebra gives no axis for the identity.
        let rotation = match c.rotation.axis_angle() {
            Some((axis, angle)) if angle > 1e-6 => format!(
                "{:.3} deg about {}",
                angle.to_degrees(),
                vec3(&axis.into_inner())
            ),
            _ => "identity".to_owned(),
        };
        outln!(
            s,
            "  #{i}{} R: {rotation}  t/d: {}  n: {}",
            if chosen == Some(i) { "*" } else { " " },
            vec3(&c.translation_over_distance),
            vec3(&c.normal)
        );
    }
    match &o.selection {
        Some(Ok(sel)) => {
            let prior = sel
                .prior_angle_rad
                .map(|a| format!(", normal {:.1} deg from the prior", a.to_degrees()))
                .unwrap_or_default();
            outln!(
                s,
                "selected: #{} ({} of {} candidates pass the depth test; {} of {} inliers in \
                 front of both cameras{prior})",
                sel.index,
                sel.passing,
                d.candidates().len(),
                sel.in_front,
                sel.points
            );
        }
        Some(Err(e)) => {
            let hint = match e {
                SelectError::Ambiguous { .. } if args.normal.is_none() => {
                    " (give --normal nx,ny,nz to decide)"
                }
                _ => "",
            };
            outln!(s, "selected: none: {e}{hint}");
        }
        None => {}
    }
    s
}

/// Runs `host-sim track`.
pub fn run(args: TrackArgs) -> Result<(), CliError> {
    let outcome = estimate(&args)?;
    if args.json {
        let text = serde_json::to_string(&json_output(&outcome))
            .map_err(|e| CliError::Usage(format!("cannot write JSON: {e}")))?;
        write_stdout(&format!("{text}\n"))
    } else {
        write_stdout(&summary(&args, &outcome))
    }
}
