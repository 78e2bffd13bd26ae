//! The camera path over frame sequences.
//!
//! It bridges unusable frames: a black, saturated or uniform frame between
//! two good ones costs one frame pair, not two, because the reference frame
//! is kept and the next good frame is measured against it. And it carries the
//! inliers of a pair into the next one, detecting corners afresh only when
//! too few are left, with the same motion as when it detects on every frame.
//! Frames are 320x240 crops of a real photograph (`data/images/gravel.png`,
//! CC0), shifted by a few pixels between frames.

use host_sim::pngio::load_gray;
use std::path::Path;
use traction::frontend::{
    FrontEnd, FrontEndBuffers, FrontEndConfig, MAX_BRIDGED_FRAMES, MAX_FEATURES,
};
use vslam_core::decompose::PinholeIntrinsics;
use vslam_core::geometry::Extrinsics;
use vslam_core::geometry::Vec2;
use vslam_core::image::ImageView;
use vslam_core::scale::CameraMotion;
use vslam_core::{Reject, Timestamp};

const W: usize = 320;
const H: usize = 240;

fn crop(dx: usize, dy: usize) -> Vec<u8> {
    let img =
        load_gray(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/images/gravel.png"))
            .expect("the test photograph");
    assert!(img.width >= W + 40 && img.height >= H + 40);
    let mut out = Vec::with_capacity(W * H);
    for y in 0..H {
        let row = (y + 20 + dy) * img.width + 20 + dx;
        out.extend_from_slice(&img.data[row..row + W]);
    }
    out
}

struct Buffers {
    frame: Vec<u8>,
    pyr_a: Vec<u8>,
    pyr_b: Vec<u8>,
    scratch: Vec<f32>,
}

fn config() -> FrontEndConfig {
    let k = PinholeIntrinsics::new(260.0, 260.0, 160.0, 120.0).unwrap();
    FrontEndConfig::new(W, H, k, Extrinsics::identity())
}

fn buffers(c: &FrontEndConfig) -> Buffers {
    let [f, p, q, s] = FrontEndBuffers::sizes(W, H, c.levels, c.corners.block_size);
    Buffers {
        frame: vec![0; f],
        pyr_a: vec![0; p],
        pyr_b: vec![0; q],
        scratch: vec![0.0; s],
    }
}

fn ms(t: u64) -> Timestamp {
    Timestamp(t * 1_000_000)
}

/// Runs `frames` (time in ms, pixels) and returns every outcome.
fn run(frames: &[(u64, Vec<u8>)]) -> Vec<Result<Option<(Timestamp, Timestamp)>, Reject>> {
    run_with(config(), frames)
        .into_iter()
        .map(|f| f.outcome.map(|m| m.map(|m| (m.t0(), m.t1()))))
        .collect()
}

/// One processed frame.
struct Frame {
    outcome: Result<Option<CameraMotion>, Reject>,
    /// Corners were detected on this frame.
    detected: bool,
    /// Inliers of the pair that ended at this frame.
    inliers: Option<u16>,
    /// The features the next frame is tracked from.
    features: Vec<Vec2>,
}

/// Runs `frames` with `c` and returns what each gave.
fn run_with(c: FrontEndConfig, frames: &[(u64, Vec<u8>)]) -> Vec<Frame> {
    let mut b = buffers(&c);
    let mut fe = FrontEnd::new(
        c,
        FrontEndBuffers {
            previous_frame: &mut b.frame,
            previous_pyramid: &mut b.pyr_a,
            current_pyramid: &mut b.pyr_b,
            corner_scratch: &mut b.scratch,
        },
    )
    .unwrap();
    let out: Vec<_> = frames
        .iter()
        .map(|(t, px)| {
            let view = ImageView::packed(px, W, H).unwrap();
            let before = fe.corner_detections();
            let outcome = fe.process(ms(*t), &view);
            Frame {
                inliers: outcome
                    .as_ref()
                    .ok()
                    .and_then(|m| m.as_ref())
                    .and_then(|_| fe.last_stats())
                    .map(|s| s.inliers),
                outcome,
                detected: fe.corner_detections() > before,
                features: fe.features().to_vec(),
            }
        })
        .collect();
    let fused = out
        .iter()
        .filter(|f| matches!(f.outcome, Ok(Some(_))))
        .count() as u32;
    assert_eq!(fe.counts().fused(), fused, "every frame pair counted once");
    out
}

#[test]
fn one_black_frame_costs_one_pair() {
    let frames = vec![
        (0, crop(0, 0)),
        (100, crop(2, 1)),
        (200, vec![0u8; W * H]),
        (300, crop(6, 3)),
        (400, crop(8, 4)),
    ];
    let out = run(&frames);
    assert_eq!(out[0], Ok(None));
    assert_eq!(out[1], Ok(Some((ms(0), ms(100)))));
    assert_eq!(out[2], Err(Reject::LowQuality));
    // Measured against the frame before the black one.
    assert_eq!(out[3], Ok(Some((ms(100), ms(300)))));
    assert_eq!(out[4], Ok(Some((ms(300), ms(400)))));
}

#[test]
fn saturated_and_uniform_frames_are_bridged_too() {
    let frames = vec![
        (0, crop(0, 0)),
        (100, vec![255u8; W * H]),
        (200, vec![128u8; W * H]),
        (300, crop(5, 2)),
    ];
    let out = run(&frames);
    assert_eq!(out[1], Err(Reject::LowQuality));
    assert_eq!(out[2], Err(Reject::LowQuality));
    assert_eq!(out[3], Ok(Some((ms(0), ms(300)))));
}

#[test]
fn a_long_run_of_bad_frames_starts_over() {
    let mut frames = vec![(0, crop(0, 0))];
    let bad = u64::from(MAX_BRIDGED_FRAMES) + 1;
    for i in 1..=bad {
        frames.push((i * 100, vec![0u8; W * H]));
    }
    frames.push(((bad + 1) * 100, crop(4, 2)));
    frames.push(((bad + 2) * 100, crop(6, 3)));
    let out = run(&frames);
    for o in &out[1..=bad as usize] {
        assert_eq!(*o, Err(Reject::LowQuality));
    }
    // The last bad frame became the reference: nothing to track from it.
    assert_eq!(out[bad as usize + 1], Err(Reject::LowQuality));
    assert_eq!(
        out[bad as usize + 2],
        Ok(Some((ms((bad + 1) * 100), ms((bad + 2) * 100))))
    );
}

#[test]
fn a_good_frame_that_cannot_be_tracked_becomes_the_reference() {
    // A different part of the photograph: plenty of corners, no overlap.
    let far = {
        let img =
            load_gray(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/images/brick.png"))
                .unwrap();
        let mut out = Vec::with_capacity(W * H);
        for y in 0..H {
            out.extend_from_slice(&img.data[y * img.width..y * img.width + W]);
        }
        out
    };
    let frames = vec![(0, crop(0, 0)), (100, far.clone()), (200, far)];
    let out = run(&frames);
    assert!(out[1].is_err(), "{:?}", out[1]);
    assert_eq!(out[2], Ok(Some((ms(100), ms(200)))));
}

/// Crops shifted by (8, 3) px per frame: some corners leave the window.
fn drifting(frames: u64) -> Vec<(u64, Vec<u8>)> {
    (0..frames)
        .map(|i| (i * 100, crop(8 * i as usize, 3 * i as usize)))
        .collect()
}

#[test]
fn inliers_are_carried_and_corners_detected_only_when_too_few_are_left() {
    let frames = drifting(12);
    // Between the per-pair inlier counts of this sequence (about 140 to 200),
    // so that both branches are taken.
    let mut c = config();
    c.redetect_below = 175;
    let out = run_with(c, &frames);
    assert!(out[0].detected, "the first frame has nothing to carry");
    let mut carried = 0;
    for (i, f) in out.iter().enumerate().skip(1) {
        let inliers = f
            .inliers
            .unwrap_or_else(|| panic!("frame {i}: {:?}", f.outcome));
        assert_eq!(
            f.detected,
            usize::from(inliers) < c.redetect_below,
            "frame {i}: {inliers} inliers"
        );
        carried += usize::from(!f.detected);
    }
    assert!(
        carried > 0 && carried < out.len() - 1,
        "carried on {carried} frames"
    );
}

#[test]
fn redetect_below_bounds_select_every_frame_or_the_first_only() {
    let frames = drifting(6);
    let mut c = config();
    c.redetect_below = MAX_FEATURES + 1;
    assert!(run_with(c, &frames).iter().all(|f| f.detected));
    c.redetect_below = 0;
    let out = run_with(c, &frames);
    assert!(out[0].detected);
    assert!(
        out[1..]
            .iter()
            .all(|f| !f.detected && matches!(f.outcome, Ok(Some(_))))
    );
}

#[test]
fn carried_tracks_give_the_motion_of_fresh_corners() {
    let frames = drifting(10);
    let mut every = config();
    every.redetect_below = MAX_FEATURES + 1;
    let mut never = config();
    never.redetect_below = 0;
    let (a, b) = (run_with(every, &frames), run_with(never, &frames));
    for (i, (a, b)) in a.iter().zip(&b).enumerate().skip(1) {
        let (Ok(Some(a)), Ok(Some(b))) = (&a.outcome, &b.outcome) else {
            panic!("frame {i}: {:?} / {:?}", a.outcome, b.outcome);
        };
        let dt = (a.t_over_d() - b.t_over_d()).norm();
        // Frobenius norm of the difference: about the angle between them.
        let dr = (a.r().matrix() - b.r().matrix()).norm();
        assert!(dt < 2e-5, "frame {i}: t/d differs by {dt}");
        assert!(dr < 2e-5, "frame {i}: rotations differ by {dr}");
        // sqrt(8² + 3²) px at f = 260 px.
        let expected = 73f32.sqrt() / 260.0;
        assert!(
            (a.t_over_d().norm() - expected).abs() < 5e-4,
            "frame {i}: {}",
            a.t_over_d()
        );
    }
}

#[test]
fn carried_features_are_where_the_last_pair_tracked_them_to() {
    let frames = drifting(8);
    let out = run_with(config(), &frames);
    let mut carried = 0;
    for (k, pair) in out.windows(2).enumerate() {
        let [before, now] = pair else { unreachable!() };
        if now.detected {
            continue;
        }
        carried += 1;
        // One per inlier, each the image of a feature of the frame before:
        // the content moves by (-8, -3) px from crop to crop.
        assert_eq!(now.features.len(), usize::from(now.inliers.unwrap()));
        for f in &now.features {
            let nearest = before
                .features
                .iter()
                .map(|g| (f - (g - Vec2::new(8.0, 3.0))).norm())
                .fold(f32::INFINITY, f32::min);
            assert!(nearest < 0.05, "frame {}: {f} is {nearest} px off", k + 1);
        }
    }
    assert!(carried >= 5, "carried on {carried} of 7 pairs");
}
