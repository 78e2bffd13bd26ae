//! From a row in the label map to a distance on the floor, and from the
//! distance to the time the wheels reach an upcoming floor.
//!
//! Pinhole camera at height `h` above a flat floor, optical axis pitched
//! `pitch` below the horizontal. Image row `v` (pixels, in the image the
//! intrinsics `fy`, `cy` refer to) looks `atan((v - cy) / fy)` below the axis,
//! so its ray meets the floor at the horizontal distance
//!
//! `d(v) = h / tan(pitch + atan((v - cy) / fy))`
//!
//! ahead of the camera (Hartley and Zisserman, *Multiple View Geometry*, 2nd
//! ed., 2004, ch. 8: the ground plane seen by a pinhole camera). Rays at or
//! above the horizon never meet the floor. Label maps of another size than the
//! camera image are handled through row fractions. Adding the camera's
//! position ahead of the wheel axle gives the distance the wheels must still
//! travel; at forward speed `v_x` the boundary arrives after `d / v_x`.

use core::fmt;

use vslam_core::Timestamp;
use vslam_core::geometry::{Extrinsics, Vec3};

use super::classes::SurfaceKind;
use super::segmentation::UpcomingSurface;

/// Why a camera geometry was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// Focal length, image height and mounting height must be finite and positive.
    NotPositive,
    /// Principal point, pitch and forward offset must be finite; pitch in `(-pi/2, pi/2)`.
    NonFinite,
    /// The mounting turns the image upside down (rows grow away from the floor).
    UpsideDown,
}

impl fmt::Display for CameraError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CameraError::NotPositive => {
                "focal length, image height and camera height must be positive"
            }
            CameraError::NonFinite => "principal point, pitch and offset must be finite",
            CameraError::UpsideDown => "the camera mounting turns the image upside down",
        })
    }
}

impl core::error::Error for CameraError {}

/// A forward-looking camera over a flat floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundCamera {
    fy: f32,
    cy: f32,
    image_height: f32,
    height: f32,
    pitch_down: f32,
    forward_offset: f32,
}

impl GroundCamera {
    /// Smallest depression angle (rad) counted as hitting the floor: rays
    /// flatter than this meet it too far away to mean anything.
    pub const MIN_DEPRESSION: f32 = 1e-3;

    /// Checks and builds the geometry.
    ///
    /// - `fy`, `cy`: vertical focal length and principal-point row, pixels, of
    ///   an image `image_height` rows high;
    /// - `height`: optical centre above the floor, m;
    /// - `pitch_down`: optical axis below the horizontal, rad;
    /// - `forward_offset`: optical centre ahead of the wheel axle, m.
    pub fn new(
        fy: f32,
        cy: f32,
        image_height: f32,
        height: f32,
        pitch_down: f32,
        forward_offset: f32,
    ) -> Result<Self, CameraError> {
        let pos = |v: f32| v.is_finite() && v > 0.0;
        if !(pos(fy) && pos(image_height) && pos(height)) {
            return Err(CameraError::NotPositive);
        }
        if !(cy.is_finite()
            && forward_offset.is_finite()
            && pitch_down.is_finite()
            && libm::fabsf(pitch_down) < core::f32::consts::FRAC_PI_2)
        {
            return Err(CameraError::NonFinite);
        }
        Ok(GroundCamera {
            fy,
            cy,
            image_height,
            height,
            pitch_down,
            forward_offset,
        })
    }

    /// The geometry of a camera mounted at `mount` (`T_BS`, camera axes: x
    /// right, y down the image, z along the optical axis), with vertical focal
    /// length `fy` and principal-point row `cy`, pixels, in an image
    /// `image_height` rows high. The height is the mount's `z`, the forward
    /// offset its `x`, and the pitch the optical axis's depression below the
    /// body's horizontal plane (the floor's, for a robot standing level).
    pub fn from_mount(
        fy: f32,
        cy: f32,
        image_height: f32,
        mount: &Extrinsics,
    ) -> Result<Self, CameraError> {
        let axis = mount.r_bs() * Vec3::new(0.0, 0.0, 1.0);
        let down = mount.r_bs() * Vec3::new(0.0, 1.0, 0.0);
        // Image rows must grow towards the floor (an upright camera).
        if down.z > 0.0 {
            return Err(CameraError::UpsideDown);
        }
        let horizontal = libm::sqrtf(axis.x * axis.x + axis.y * axis.y);
        let pitch_down = libm::atan2f(-axis.z, horizontal);
        let t = mount.t_bs();
        GroundCamera::new(fy, cy, image_height, t.z, pitch_down, t.x)
    }

    /// Where the floor's horizon lies in the image, as a row fraction (0 top,
    /// 1 bottom), clamped to `[0, 1)`: rows below it see the floor, rows
    /// above it never do. A camera pitched down further than half its
    /// vertical field of view sees floor in every row (0).
    pub fn horizon_fraction(&self) -> f32 {
        let v = self.cy - self.fy * libm::tanf(self.pitch_down - Self::MIN_DEPRESSION);
        let f = v / self.image_height;
        if f.is_finite() {
            f.clamp(0.0, 0.999)
        } else {
            0.0
        }
    }

    /// Horizontal distance from the wheel axle to where the image row at
    /// `row_fraction` (0 top, 1 bottom) meets the floor, m; `None` at or above
    /// the horizon or for a non-finite fraction.
    pub fn ground_distance(&self, row_fraction: f32) -> Option<f32> {
        if !row_fraction.is_finite() {
            return None;
        }
        let v = row_fraction * self.image_height;
        let depression = self.pitch_down + libm::atan2f(v - self.cy, self.fy);
        if depression < Self::MIN_DEPRESSION {
            return None;
        }
        let d = self.height / libm::tanf(depression) + self.forward_offset;
        d.is_finite().then_some(d)
    }
}

impl Default for GroundCamera {
    /// A 480-row VGA camera (fy 400 px, cy 240), 8 cm above the floor,
    /// pitched 20 degrees down, 15 cm ahead of the wheel axle.
    fn default() -> Self {
        GroundCamera {
            fy: 400.0,
            cy: 240.0,
            image_height: 480.0,
            height: 0.08,
            pitch_down: 0.349,
            forward_offset: 0.15,
        }
    }
}

/// An upcoming floor change and when the wheels reach it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anticipation {
    /// The floor ahead.
    pub kind: SurfaceKind,
    /// Distance from the wheel axle to its nearest edge, m.
    pub distance: f32,
    /// When the wheels reach it (`None` when the robot is not moving towards it).
    pub arrival: Option<Timestamp>,
}

impl Anticipation {
    /// The anticipation of `upcoming`, seen in a map taken at `t`, with the
    /// robot moving forward at `forward_speed` m/s. No arrival time if the
    /// speed is below `min_speed` or the arrival lies beyond `horizon_ns`.
    /// `None` if the boundary row does not meet the floor.
    pub fn from_upcoming(
        upcoming: &UpcomingSurface,
        camera: &GroundCamera,
        t: Timestamp,
        forward_speed: f32,
        min_speed: f32,
        horizon_ns: u64,
    ) -> Option<Anticipation> {
        let distance = camera.ground_distance(upcoming.row_fraction)?.max(0.0);
        let arrival =
            if forward_speed.is_finite() && forward_speed >= min_speed && forward_speed > 0.0 {
                let tta_s = distance / forward_speed;
                let tta_ns = tta_s * 1e9;
                if tta_ns.is_finite() && tta_ns <= horizon_ns as f32 {
                    t.checked_add_nanos(tta_ns as u64)
                } else {
                    None
                }
            } else {
                None
            };
        Some(Anticipation {
            kind: upcoming.kind,
            distance,
            arrival,
        })
    }

    /// How far the floor under the wheels has turned into the upcoming one at
    /// `t`: 0 until half a `transition_ns` before the arrival, 1 from half a
    /// transition after it, linear in between; 0 without an arrival time.
    pub fn weight_at(&self, t: Timestamp, transition_ns: u64) -> f32 {
        let Some(arrival) = self.arrival else {
            return 0.0;
        };
        let half = transition_ns / 2;
        let start = arrival.as_nanos().saturating_sub(half);
        if t.as_nanos() <= start {
            return 0.0;
        }
        let into = t.as_nanos() - start;
        if transition_ns == 0 || into >= transition_ns {
            return 1.0;
        }
        into as f32 / transition_ns as f32
    }
}
