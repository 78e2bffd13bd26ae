//! The camera path of the estimator: from two consecutive frames of the
//! upward camera to the camera motion the scale pipeline needs.
//!
//! Per frame: pyramids of the previous and the current frame, pyramidal
//! Lucas-Kanade from the previous frame's features, a RANSAC homography on
//! the tracks, its decomposition with the camera intrinsics, and the
//! selection of the candidate whose plane normal matches the ceiling (the
//! body's up axis seen from the camera).
//!
//! The features: as in the KLT tracker (Shi and Tomasi 1994, "Good features
//! to track"), the inliers of a used frame pair, where they are in its second
//! frame, are tracked on into the next frame. Corners are detected afresh on
//! the first frame, after a gap, after a failed pair, and when fewer than
//! [`FrontEndConfig::redetect_below`] (at least
//! [`FrontEndConfig::min_tracks`]) inliers are left (they are kept if the
//! detector finds fewer than `min_tracks` corners). A carried point is
//! dropped when the tracker loses it (window out of the image, too little
//! texture, too large a residual) or when it disagrees with the homography.
//! Each pair is measured from the patches of its own two frames, but a
//! carried point sits wherever the last pair put it, not on a corner, and at
//! a sub-pixel phase that changes from frame to frame; on the simulated
//! office and slip runs this makes single pairs noisier and the minute-long
//! trajectories more accurate (`benches/README.md`, the re-detection
//! threshold table).
//!
//! A frame with too few corners of its own whose motion fails (black,
//! saturated, uniform, blurred) is refused and the reference kept, so the
//! next good frame is measured against the last good one (at most
//! [`MAX_BRIDGED_FRAMES`] in a row).
//!
//! Memory is the caller's: [`FrontEndBuffers`] borrows one frame copy, two
//! pyramid storages (swapped each frame, so every pyramid is built once) and
//! the corner detector's scratch, sized by [`FrontEndBuffers::sizes`], so
//! firmware can place them in statics and a host in heap vectors. Nothing
//! here allocates.

use heapless::Vec as HVec;
use vslam_core::corners::{Corner, CornerConfig, border_for_window, detect_corners, scratch_len};
use vslam_core::decompose::{
    DecomposeError, HomographyDecomposition, NormalPrior, PinholeIntrinsics, PlaneMotion,
    SelectParams, decompose,
};
use vslam_core::geometry::{Extrinsics, Vec2, Vec3};
use vslam_core::homography::{HomographyError, HomographyRansac, RansacParams, RansacReport};
use vslam_core::image::ImageView;
use vslam_core::lk::{LkConfig, LkError, TrackCounts, TrackResult, Tracker};
use vslam_core::pyramid::{Pyramid, storage_bytes};
use vslam_core::scale::CameraMotion;
use vslam_core::{Reject, SampleClock, SampleCounts, Timestamp};

/// Most features tracked between two frames: the default capacity of
/// [`FrontEnd`]; [`FrontEndConfig::new`] asks for fewer below 320x240
/// ([`features_for_frame`]).
pub const MAX_FEATURES: usize = 200;

/// The smallest feature capacity of a [`FrontEnd`]: the four point pairs a
/// homography needs.
pub const MIN_FEATURES: usize = 4;

/// Points tracked per call of the tracker (the results live on the stack).
const TRACK_BATCH: usize = 16;

/// [`FrontEndConfig::redetect_below`] of [`FrontEndConfig::new`] at 320x240
/// and above ([`redetect_for_frame`]).
pub const REDETECT_BELOW: usize = 100;

/// Most consecutive unusable frames (too few corners of their own, and no
/// motion to the reference) bridged by keeping the reference frame: a black,
/// saturated, uniform or blurred frame then costs one frame pair, not two.
pub const MAX_BRIDGED_FRAMES: u8 = 2;

/// The tracker's step limit at the coarse pyramid levels in
/// [`FrontEndConfig::new`], level pixels ([`LkConfig::coarse_epsilon`]; the
/// level-0 limit stays OpenCV's 0.01): a coarse level only seeds the next
/// finer one. On the firmware's 160x120 frames it cuts the tracker's
/// Cortex-M4 instructions by about a third (`firmware/README.md`) with the
/// level-0 iterations nearly unchanged.
pub const COARSE_EPSILON: f32 = 0.1;

/// Settings of the camera path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontEndConfig {
    /// Frame width, pixels.
    pub width: usize,
    /// Frame height, pixels.
    pub height: usize,
    /// Pinhole intrinsics.
    pub intrinsics: PinholeIntrinsics,
    /// Camera mounting `T_BC`.
    pub mount: Extrinsics,
    /// Pyramid levels.
    pub levels: usize,
    /// Tracker settings.
    pub lk: LkConfig,
    /// Most corners detected on a frame (and so features tracked from it),
    /// `1..=FEATURES`, the front end's capacity (larger values act as
    /// `FEATURES`, by default [`MAX_FEATURES`]).
    pub max_features: usize,
    /// Corner detector settings.
    pub corners: CornerConfig,
    /// Robust homography settings.
    pub ransac: RansacParams,
    /// Largest angle between a candidate's plane normal and the ceiling, radians.
    pub prior_max_angle_rad: f32,
    /// Fewest tracked features for a frame pair to be used.
    pub min_tracks: usize,
    /// Fewest inliers of a frame pair to be tracked on into the next frame
    /// alone; with fewer (or fewer than `min_tracks`), corners are detected
    /// on the current frame and replace them (unless fewer than `min_tracks`
    /// are found). At `min_tracks` or below, corners are detected only when
    /// a pair fails or keeps fewer than `min_tracks` inliers; above
    /// `max_features`, on every frame.
    pub redetect_below: usize,
    /// Longest accepted gap between frames, nanoseconds.
    pub max_gap_ns: u64,
    /// Largest `|t/d|` of a frame pair taken as a rotation when the ceiling
    /// prior cannot pick a candidate.
    pub rotation_only_baseline: f32,
}

/// The frame area of [`MAX_FEATURES`] and [`REDETECT_BELOW`]: 320x240.
const FULL_AREA: usize = 320 * 240;

/// `full` scaled with the frame's area below 320x240, at least `floor`
/// and at most `full`.
const fn scaled_by_area(full: usize, floor: usize, width: usize, height: usize) -> usize {
    let area = width.saturating_mul(height);
    let n = if area >= FULL_AREA {
        full
    } else {
        full.saturating_mul(area) / FULL_AREA
    };
    if n < floor { floor } else { n }
}

/// The corner count of [`FrontEndConfig::new`] for a `width x height`
/// frame: [`MAX_FEATURES`] (200) at 320x240 and above, scaled with the
/// frame's area below (50 at 160x120), at least 24: the tracker's work
/// grows with the features tracked.
pub const fn features_for_frame(width: usize, height: usize) -> usize {
    scaled_by_area(MAX_FEATURES, 24, width, height)
}

/// The re-detection threshold of [`FrontEndConfig::new`] for a `width x
/// height` frame: [`REDETECT_BELOW`] (100), or 70 % of
/// [`features_for_frame`] when that is fewer (35 at 160x120).
pub const fn redetect_for_frame(width: usize, height: usize) -> usize {
    let share = features_for_frame(width, height).saturating_mul(7) / 10;
    if share < REDETECT_BELOW {
        share
    } else {
        REDETECT_BELOW
    }
}

/// Frames with less than this area use [`SMALL_FRAME_LK_LEVELS`] and
/// [`SMALL_FRAME_EPSILON`] in [`FrontEndConfig::new`]: half of 320x240.
const SMALL_FRAME_AREA: usize = FULL_AREA / 2;

/// The tracker's pyramid levels in [`FrontEndConfig::new`] for frames of
/// less than half the area of 320x240 (3, OpenCV's, otherwise): on the
/// simulated office and slip runs at 160x120 two levels track as well as
/// three, and a frame pair costs about a fifth fewer Cortex-M4
/// instructions (`benches/README.md`, the front end at 160x120).
pub const SMALL_FRAME_LK_LEVELS: usize = 2;

/// The tracker's level-0 step limit in [`FrontEndConfig::new`] for frames
/// of less than half the area of 320x240, pixels (OpenCV's 0.01
/// otherwise): fewer level-0 iterations, with the simulated camera paths at
/// 160x120 as accurate (`benches/README.md`, the front end at 160x120).
pub const SMALL_FRAME_EPSILON: f32 = 0.03;

/// The tracker window of [`FrontEndConfig::new`] for a `width x height`
/// frame: the default 21x21 ([`LkConfig::default`], OpenCV's) at 320x240
/// and above; below, the side scaled with the frame's area (not its side),
/// odd, at least 7: 7x7 at 160x120, 11x11 at 240x180. A window of a
/// quarter of the ceiling area at 160x120 fits the tracker's eight lanes
/// in one chunk (11 columns take two): a 160x120 frame pair costs about
/// 0.6 times the Cortex-M4 instructions of an 11x11 window with the same
/// features, with the simulated camera path as accurate
/// (`benches/README.md`, the front end at 160x120).
pub const fn window_for_frame(width: usize, height: usize) -> usize {
    const FULL: usize = 21;
    let scaled = scaled_by_area(FULL, 0, width, height);
    let odd = scaled | 1;
    if odd < 7 {
        7
    } else if odd > FULL {
        FULL
    } else {
        odd
    }
}

impl FrontEndConfig {
    /// Defaults for a `width x height` upward camera: OpenCV's tracker and
    /// corner settings ([`LkConfig::default`], [`CornerConfig::default`]),
    /// with the window of [`window_for_frame`] (and a corner border that
    /// fits it), [`COARSE_EPSILON`] at the coarse levels, the corner count
    /// and re-detection threshold of [`features_for_frame`] and
    /// [`redetect_for_frame`], and below half the area of 320x240
    /// [`SMALL_FRAME_LK_LEVELS`] tracker levels and a level-0 step limit of
    /// [`SMALL_FRAME_EPSILON`] (the pyramids keep `levels`).
    pub fn new(
        width: usize,
        height: usize,
        intrinsics: PinholeIntrinsics,
        mount: Extrinsics,
    ) -> Self {
        let small = width.saturating_mul(height) < SMALL_FRAME_AREA;
        FrontEndConfig {
            width,
            height,
            intrinsics,
            mount,
            levels: 3,
            lk: LkConfig {
                window: window_for_frame(width, height),
                coarse_epsilon: Some(COARSE_EPSILON),
                ..if small {
                    LkConfig {
                        levels: SMALL_FRAME_LK_LEVELS,
                        epsilon: SMALL_FRAME_EPSILON,
                        ..LkConfig::default()
                    }
                } else {
                    LkConfig::default()
                }
            },
            corners: CornerConfig {
                border: border_for_window(window_for_frame(width, height)),
                ..CornerConfig::default()
            },
            max_features: features_for_frame(width, height),
            ransac: RansacParams::default(),
            prior_max_angle_rad: 0.35,
            min_tracks: 12,
            redetect_below: redetect_for_frame(width, height),
            max_gap_ns: 1_000_000_000,
            rotation_only_baseline: 0.01,
        }
    }
}

/// The memory the camera path works in, borrowed from the caller.
pub struct FrontEndBuffers<'b> {
    /// A copy of the previous frame, `width * height` bytes.
    pub previous_frame: &'b mut [u8],
    /// Pyramid storage of the previous frame.
    pub previous_pyramid: &'b mut [u8],
    /// Pyramid storage of the current frame.
    pub current_pyramid: &'b mut [u8],
    /// Corner detector scratch.
    pub corner_scratch: &'b mut [f32],
}

impl FrontEndBuffers<'_> {
    /// Lengths of `[previous_frame, previous_pyramid, current_pyramid, corner_scratch]`.
    pub const fn sizes(
        width: usize,
        height: usize,
        levels: usize,
        block_size: usize,
    ) -> [usize; 4] {
        let pyr = storage_bytes(width, height, levels);
        [
            width.saturating_mul(height),
            pyr,
            pyr,
            scratch_len(width, height, block_size),
        ]
    }
}

/// Why the front end was built wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrontEndError {
    /// A buffer is shorter than [`FrontEndBuffers::sizes`] asks.
    BufferTooSmall,
    /// Tracker, corner or RANSAC settings were refused.
    BadConfig,
}

impl core::fmt::Display for FrontEndError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FrontEndError::BufferTooSmall => "a front-end buffer is smaller than required",
            FrontEndError::BadConfig => "front-end settings were refused",
        })
    }
}

impl core::error::Error for FrontEndError {}

/// What one frame pair gave, for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Features tracked from the previous frame.
    pub tracked: u16,
    /// RANSAC inliers among them.
    pub inliers: u16,
    /// RMS transfer error of the inliers, pixels.
    pub rms_px: f32,
    /// The decomposition was a pure rotation.
    pub pure_rotation: bool,
}

/// The camera path, for up to `FEATURES` features per frame (default
/// [`MAX_FEATURES`], at least [`MIN_FEATURES`], and at least the
/// configuration's `min_tracks`, checked by [`FrontEnd::with_capacity`]): its feature
/// list and RANSAC scratch, and the corners and point pairs on the stack of
/// [`FrontEnd::process`], are that long. A smaller capacity does not compile:
///
/// ```compile_fail
/// use traction::frontend::FrontEnd;
/// let _ = FrontEnd::<'static, 3>::CAPACITY;
/// ```
///
/// ```
/// use traction::frontend::FrontEnd;
/// assert_eq!(FrontEnd::<'static, 4>::CAPACITY, 4);
/// ```
pub struct FrontEnd<'b, const FEATURES: usize = MAX_FEATURES> {
    config: FrontEndConfig,
    buffers: FrontEndBuffers<'b>,
    tracker: Tracker,
    ransac: HomographyRansac<FEATURES>,
    prior: NormalPrior,
    clock: SampleClock,
    /// The reference frame's features; after a used pair, its inliers
    /// where they are in the pair's second frame.
    points: HVec<Vec2, FEATURES>,
    /// Frames whose corners were detected.
    detections: u32,
    counts: SampleCounts,
    last: Option<FrameStats>,
    /// `previous_pyramid` holds the levels of `previous_frame`.
    previous_pyramid_ready: bool,
    /// `current_pyramid` holds the levels of the frame being processed.
    current_pyramid_built: bool,
    /// When the reference frame (`previous_frame`) was taken.
    reference_t: Option<Timestamp>,
    /// Unusable frames bridged since the reference was taken.
    bridged: u8,
}

impl<'b> FrontEnd<'b> {
    /// Checks the buffers and the settings: a front end of the default
    /// capacity, [`MAX_FEATURES`] ([`FrontEnd::with_capacity`] for another).
    pub fn new(
        config: FrontEndConfig,
        buffers: FrontEndBuffers<'b>,
    ) -> Result<Self, FrontEndError> {
        Self::with_capacity(config, buffers)
    }
}

impl<'b, const FEATURES: usize> FrontEnd<'b, FEATURES> {
    /// The feature capacity, `FEATURES`; using a front end (or this) with
    /// less than [`MIN_FEATURES`] does not compile.
    pub const CAPACITY: usize = {
        assert!(
            FEATURES >= MIN_FEATURES,
            "front-end feature capacity below MIN_FEATURES"
        );
        FEATURES
    };

    /// Checks the buffers and the settings (`min_tracks` at most `FEATURES`).
    pub fn with_capacity(
        config: FrontEndConfig,
        buffers: FrontEndBuffers<'b>,
    ) -> Result<Self, FrontEndError> {
        if config.min_tracks > Self::CAPACITY {
            return Err(FrontEndError::BadConfig);
        }
        let need = FrontEndBuffers::sizes(
            config.width,
            config.height,
            config.levels,
            config.corners.block_size,
        );
        let have = [
            buffers.previous_frame.len(),
            buffers.previous_pyramid.len(),
            buffers.current_pyramid.len(),
            buffers.corner_scratch.len(),
        ];
        if have.iter().zip(need.iter()).any(|(h, n)| h < n) {
            return Err(FrontEndError::BufferTooSmall);
        }
        let tracker = Tracker::new(config.lk).map_err(|_| FrontEndError::BadConfig)?;
        let ransac = HomographyRansac::new(config.ransac).map_err(|_| FrontEndError::BadConfig)?;
        // The ceiling is straight above: the body's +z, seen from the camera.
        let prior = NormalPrior::from_body(&config.mount, &Vec3::z(), config.prior_max_angle_rad)
            .map_err(|_| FrontEndError::BadConfig)?;
        Ok(FrontEnd {
            config,
            buffers,
            tracker,
            ransac,
            prior,
            clock: SampleClock::new(config.max_gap_ns),
            points: HVec::new(),
            detections: 0,
            counts: SampleCounts::new(),
            last: None,
            previous_pyramid_ready: false,
            current_pyramid_built: false,
            reference_t: None,
            bridged: 0,
        })
    }

    /// Frames used and refused, by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Frames on which corners were detected (whether or not they were kept:
    /// a bridged frame's are not, nor too few to track after a used pair).
    /// The other frames used took their features from the pair before them.
    pub fn corner_detections(&self) -> u32 {
        self.detections
    }

    /// The features (pixel positions in the reference frame) the next frame
    /// is tracked from.
    pub fn features(&self) -> &[Vec2] {
        &self.points
    }

    /// What the last used frame pair gave.
    pub fn last_stats(&self) -> Option<FrameStats> {
        self.last
    }

    /// Processes one frame taken at `t`. The first frame (and the first after
    /// a gap) gives `Ok(None)`; later frames give the camera motion since the
    /// previous frame, or a counted rejection.
    pub fn process(
        &mut self,
        t: Timestamp,
        image: &ImageView<'_>,
    ) -> Result<Option<CameraMotion>, Reject> {
        self.current_pyramid_built = false;
        let outcome = self.process_inner(t, image);
        match outcome {
            Ok(Some(_)) => self.counts.fused_one(),
            Ok(None) => {}
            Err(r) => self.counts.rejected_one(r),
        }
        outcome
    }

    fn process_inner(
        &mut self,
        t: Timestamp,
        image: &ImageView<'_>,
    ) -> Result<Option<CameraMotion>, Reject> {
        if image.width() != self.config.width || image.height() != self.config.height {
            return Err(Reject::OutOfRange);
        }
        let first = match self.clock.accept(t) {
            Ok(dt) => dt.is_none(),
            Err(Reject::Gap) => {
                // Too long since the last frame: start over from this one.
                let mut corners = [Corner::default(); FEATURES];
                let n = self.corners_of(image, &mut corners);
                self.remember(t, image);
                self.set_corners(corners.get(..n).unwrap_or(&[]));
                return Err(Reject::Gap);
            }
            Err(r) => return Err(r),
        };
        let motion = match (first, self.reference_t) {
            (false, Some(t0)) => self.motion_since(t0, t, image),
            _ => Ok(None),
        };
        // After a used pair (`Ok(Some)`), `points` holds its inliers in this
        // frame, which every branch below makes the reference.
        let used = matches!(motion, Ok(Some(_)));
        let enough = self.config.redetect_below.max(self.config.min_tracks);
        if used && self.points.len() >= enough {
            // Enough inliers to go on with: they are this frame's features.
            self.remember(t, image);
            return motion;
        }
        let mut corners = [Corner::default(); FEATURES];
        let n = self.corners_of(image, &mut corners);
        if motion.is_err() && self.bridges(t, n) {
            // An unusable frame: the reference stays, and the next good frame
            // is measured against it.
            self.bridged += 1;
            return motion;
        }
        self.remember(t, image);
        // Fresh corners replace the inliers, unless the detector found too few
        // to track (a frame with little texture that still tracked).
        if !(used && n < self.config.min_tracks) {
            self.set_corners(corners.get(..n).unwrap_or(&[]));
        }
        motion
    }

    /// Whether a frame at `t` with `corners` corners of its own, whose motion
    /// from the reference failed, is bridged (the reference kept).
    fn bridges(&self, t: Timestamp, corners: usize) -> bool {
        let reference_fresh = self
            .reference_t
            .and_then(|t0| t.nanos_since(t0))
            .is_some_and(|age| age <= self.config.max_gap_ns);
        corners < self.config.min_tracks
            && self.points.len() >= self.config.min_tracks
            && self.bridged < MAX_BRIDGED_FRAMES
            && reference_fresh
    }

    /// Corners of `image` into `out` (at most
    /// [`FrontEndConfig::max_features`]), strongest first; 0 when it has none.
    fn corners_of(&mut self, image: &ImageView<'_>, out: &mut [Corner]) -> usize {
        self.detections = self.detections.saturating_add(1);
        let cap = self.config.max_features.clamp(1, out.len().max(1));
        let Some(out) = out.get_mut(..cap) else {
            return 0;
        };
        detect_corners(
            image,
            &self.config.corners,
            self.buffers.corner_scratch,
            out,
        )
        .unwrap_or(0)
    }

    fn motion_since(
        &mut self,
        t0: Timestamp,
        t1: Timestamp,
        image: &ImageView<'_>,
    ) -> Result<Option<CameraMotion>, Reject> {
        let (w, h, levels) = (self.config.width, self.config.height, self.config.levels);
        if self.points.len() < self.config.min_tracks {
            return Err(Reject::LowQuality);
        }
        let mut p1: HVec<Vec2, FEATURES> = HVec::new();
        let mut p2: HVec<Vec2, FEATURES> = HVec::new();
        {
            let prev_view = ImageView::packed(self.buffers.previous_frame, w, h)
                .map_err(|_| Reject::OutOfRange)?;
            // The previous frame's levels were built when it was the current
            // frame; they are rebuilt only when that did not happen.
            let prev = if self.previous_pyramid_ready {
                Pyramid::from_storage(&prev_view, levels, self.buffers.previous_pyramid)
            } else {
                Pyramid::build_in(&prev_view, levels, self.buffers.previous_pyramid)
            }
            .map_err(|_| Reject::OutOfRange)?;
            let next = Pyramid::build_in(image, levels, self.buffers.current_pyramid)
                .map_err(|_| Reject::OutOfRange)?;
            self.current_pyramid_built = true;
            track_pairs(
                &self.tracker,
                &prev,
                &next,
                &self.points,
                (&mut p1, &mut p2),
                |_| {},
            )
            .map_err(|_| Reject::Degenerate)?;
        }
        if p1.len() < self.config.min_tracks {
            return Err(Reject::LowQuality);
        }
        let mut mask = [false; FEATURES];
        let mask = mask.get_mut(..p1.len()).ok_or(Reject::Degenerate)?;
        let (report, dec) = fit_pairs(
            &mut self.ransac,
            &p1,
            &p2,
            mask,
            Some(&self.config.intrinsics),
        )
        .map_err(|_| Reject::Degenerate)?;
        let dec = dec.ok_or(Reject::Degenerate)?;
        let stats = FrameStats {
            tracked: p1.len() as u16,
            inliers: report.inlier_count as u16,
            rms_px: report.rms_error_px,
            pure_rotation: dec.is_pure_rotation(),
        };
        let chosen = if dec.is_pure_rotation() {
            dec.candidates().first().copied()
        } else {
            let params = SelectParams {
                prior: Some(self.prior),
                ..SelectParams::default()
            };
            match dec.select(&p1, mask, &params) {
                Ok(sel) => dec.selected(&sel).copied(),
                // Near a pure rotation the plane normal is unobservable and the
                // selection fails, but every candidate agrees on R: keep the
                // rotation of the smallest-baseline candidate with no translation,
                // so a turn in place is never lost. The scale pipeline then
                // reports a too-small baseline for this pair.
                Err(_) => dec
                    .candidates()
                    .iter()
                    .filter(|c| {
                        c.translation_over_distance.norm() < self.config.rotation_only_baseline
                    })
                    .min_by(|a, b| {
                        a.translation_over_distance
                            .norm()
                            .total_cmp(&b.translation_over_distance.norm())
                    })
                    .map(|c| PlaneMotion {
                        translation_over_distance: Vec3::zeros(),
                        normal: Vec3::zeros(),
                        ..*c
                    }),
            }
        };
        let chosen = chosen.ok_or(Reject::Degenerate)?;
        self.last = Some(stats);
        let motion = CameraMotion::from_point_transfer(
            t0,
            t1,
            chosen.rotation,
            chosen.translation_over_distance,
            stats.inliers,
            report.inlier_ratio(),
            report.rms_error_px,
        )
        .map_err(|_| Reject::Degenerate)?;
        // The pair is used: its inliers, where they are in this frame, are
        // the features to carry on (until then `points` stayed the
        // reference's, for a failed pair that is bridged).
        self.points.clear();
        for (p, _) in p2.iter().zip(mask.iter()).filter(|(_, inlier)| **inlier) {
            // As many places as points: this cannot fail.
            let _ = self.points.push(*p);
        }
        Ok(Some(motion))
    }

    /// Keeps `image`, taken at `t`, as the reference frame (its features are
    /// set apart).
    fn remember(&mut self, t: Timestamp, image: &ImageView<'_>) {
        self.reference_t = Some(t);
        self.bridged = 0;
        // This frame's levels become the previous frame's: swap the storages.
        if self.current_pyramid_built {
            core::mem::swap(
                &mut self.buffers.previous_pyramid,
                &mut self.buffers.current_pyramid,
            );
        }
        self.previous_pyramid_ready = self.current_pyramid_built;
        let w = self.config.width;
        for (y, dst) in self
            .buffers
            .previous_frame
            .chunks_exact_mut(w)
            .take(self.config.height)
            .enumerate()
        {
            if let Some(src) = image.row(y) {
                dst.copy_from_slice(src);
            }
        }
    }

    /// The reference frame's features: its detected `corners`.
    fn set_corners(&mut self, corners: &[Corner]) {
        self.points.clear();
        for c in corners {
            let _ = self.points.push(c.position());
        }
    }
}

/// The camera path's tracking stage: tracks `points` from `prev` into
/// `next`, `TRACK_BATCH` (16) at a time (points are tracked independently; a few
/// at a time keeps the results off the stack: all 200 at once took about
/// 6 KB), and appends each tracked point's pair to `(from, to)`: `from[i]`
/// in `prev` went to `to[i]` in `next` (pairs past the capacity `N` are
/// dropped). `each` sees every point's result in order, tracked or lost.
/// Returns the counts by status.
pub fn track_pairs<const N: usize>(
    tracker: &Tracker,
    prev: &Pyramid<'_>,
    next: &Pyramid<'_>,
    points: &[Vec2],
    (from, to): (&mut HVec<Vec2, N>, &mut HVec<Vec2, N>),
    mut each: impl FnMut(&TrackResult),
) -> Result<TrackCounts, LkError> {
    let mut counts = TrackCounts::default();
    let mut results = [TrackResult::EMPTY; TRACK_BATCH];
    for batch in points.chunks(TRACK_BATCH) {
        let results = results
            .get_mut(..batch.len())
            .ok_or(LkError::OutputTooSmall {
                points: batch.len(),
                results: TRACK_BATCH,
            })?;
        tracker.track(prev, next, batch, results)?;
        for (p, r) in batch.iter().zip(results.iter()) {
            counts.record(r.status);
            each(r);
            if r.is_tracked() && !from.is_full() && !to.is_full() {
                let _ = from.push(*p);
                let _ = to.push(r.position);
            }
        }
    }
    Ok(counts)
}

/// Why [`fit_pairs`] found nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FitError {
    /// No homography: too few or degenerate pairs, no consensus.
    Homography(HomographyError),
    /// The homography has no decomposition.
    Decomposition(DecomposeError),
}

impl core::fmt::Display for FitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FitError::Homography(e) => write!(f, "no homography: {e}"),
            FitError::Decomposition(e) => write!(f, "no decomposition: {e}"),
        }
    }
}

impl core::error::Error for FitError {}

/// The camera path's fitting stage: the RANSAC homography `to ~ H from`
/// (inliers marked in `mask`) and, given the `intrinsics`, its
/// decomposition into `{R, t/d, n}` candidates.
pub fn fit_pairs<const N: usize>(
    ransac: &mut HomographyRansac<N>,
    from: &[Vec2],
    to: &[Vec2],
    mask: &mut [bool],
    intrinsics: Option<&PinholeIntrinsics>,
) -> Result<(RansacReport, Option<HomographyDecomposition>), FitError> {
    let report = ransac
        .estimate(from, to, mask)
        .map_err(FitError::Homography)?;
    let decomposition = match intrinsics {
        Some(k) => Some(decompose(&report.homography, k).map_err(FitError::Decomposition)?),
        None => None,
    };
    Ok((report, decomposition))
}

#[cfg(test)]
mod tests {
    use super::{
        MAX_FEATURES, REDETECT_BELOW, features_for_frame, redetect_for_frame, window_for_frame,
    };

    #[test]
    fn features_and_redetection_scale_with_the_frame_area_below_320x240() {
        assert_eq!(features_for_frame(320, 240), MAX_FEATURES);
        assert_eq!(features_for_frame(1280, 960), MAX_FEATURES);
        assert_eq!(features_for_frame(160, 120), 50);
        assert_eq!(features_for_frame(10, 10), 24);
        assert_eq!(redetect_for_frame(320, 240), REDETECT_BELOW);
        assert_eq!(redetect_for_frame(160, 120), 35);
        assert_eq!(redetect_for_frame(0, 0), 16);
        for (w, h) in [
            (100, 75),
            (200, 150),
            (1, 1),
            (usize::MAX, 3),
            (usize::MAX, usize::MAX),
        ] {
            let (f, r) = (features_for_frame(w, h), redetect_for_frame(w, h));
            assert!((24..=MAX_FEATURES).contains(&f), "{w}x{h}: {f}");
            assert!((16..=REDETECT_BELOW).contains(&r) && r < f, "{w}x{h}: {r}");
        }
    }

    #[test]
    fn the_window_scales_with_the_frame_area_below_320x240() {
        assert_eq!(window_for_frame(320, 240), 21);
        assert_eq!(window_for_frame(640, 480), 21);
        assert_eq!(window_for_frame(240, 180), 11);
        assert_eq!(window_for_frame(160, 120), 7);
        assert_eq!(window_for_frame(320, 120), 11);
        assert_eq!(window_for_frame(80, 60), 7);
        assert_eq!(window_for_frame(0, 0), 7);
        for (w, h) in [(100, 75), (200, 150), (240, 180), (1, 1), (usize::MAX, 3)] {
            let n = window_for_frame(w, h);
            assert!(n % 2 == 1 && (7..=21).contains(&n), "{w}x{h}: {n}");
        }
    }
}
