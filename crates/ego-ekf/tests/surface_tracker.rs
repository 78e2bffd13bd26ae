//! The floor between maps: keeping the last floor, staleness, anticipation of
//! an approaching change, and the surface model's grip parameters.

mod surface_support;

use ego_ekf::surface::{
    CameraError, GroundCamera, MapError, NoSurface, SurfaceConfig, SurfaceKind, SurfaceModel,
    TrackerConfig, WheelType,
};
use surface_support::*;
use vslam_core::image::LabelView;
use vslam_core::{Reject, Timestamp};

const S: u64 = 1_000_000_000;
const W: usize = 32;
const H: usize = 48;

fn at(seconds: f64) -> Timestamp {
    Timestamp((seconds * 1e9).round() as u64)
}

fn model(tracker: TrackerConfig) -> SurfaceModel {
    let mut c = SurfaceConfig::new(WheelType::HardRubber, classes());
    c.camera = camera();
    c.tracker = tracker;
    SurfaceModel::new(c)
}

fn floor(id: u8) -> Vec<u8> {
    map(W, H, |_, y| if y < 19 { WALL } else { id })
}

fn feed(m: &mut SurfaceModel, t: Timestamp, labels: &[u8], speed: f32) -> Result<(), MapError> {
    m.on_segmentation(t, &LabelView::new(labels, W, H, W).unwrap(), speed)
        .map(|_| ())
}

#[test]
fn before_any_map_the_conservative_default_holds() {
    let m = model(TrackerConfig::default());
    let s = m.state_at(at(1.0));
    assert_eq!(s.mix, None);
    assert!(s.is_stale());
    assert_eq!(m.grip_params(at(1.0)), SurfaceConfig::conservative_params());
    assert_eq!(
        m.clone_learner_and_observe(),
        Err(Reject::NotReady),
        "no learning without a floor"
    );
}

trait Probe {
    fn clone_learner_and_observe(&self) -> Result<(), Reject>;
}

impl Probe for SurfaceModel {
    fn clone_learner_and_observe(&self) -> Result<(), Reject> {
        let mut c = *self;
        c.on_wheel_innovation(at(1.0), 0.01, 1e-4, false)
    }
}

#[test]
fn keeps_the_last_floor_through_maps_without_ground() {
    let mut m = model(TrackerConfig::default());
    feed(&mut m, at(0.0), &floor(CARPET), 0.2).unwrap();
    let carpet = m.grip_params(at(0.1));
    let blind = map(W, H, |_, _| UNKNOWN);
    assert_eq!(
        feed(&mut m, at(0.25), &blind, 0.2),
        Err(MapError::NoSurface(NoSurface::OnlyUnknown))
    );
    let walls = map(W, H, |_, _| WALL);
    assert_eq!(
        feed(&mut m, at(0.5), &walls, 0.2),
        Err(MapError::NoSurface(NoSurface::NoGround))
    );
    let s = m.state_at(at(0.6));
    assert_eq!(s.dominant(), Some(SurfaceKind::Carpet));
    // Its age runs from the last map with ground.
    assert!((s.age_s.unwrap() - 0.6).abs() < 1e-6);
    assert_eq!(m.grip_params(at(0.6)), carpet);
    assert_eq!(m.tracker().counts().rejected(Reject::LowQuality), 2);
    assert_eq!(m.tracker().last_no_surface(), Some(NoSurface::NoGround));
    // A new floor replaces it.
    feed(&mut m, at(0.75), &floor(TILE), 0.2).unwrap();
    assert_eq!(m.state_at(at(0.8)).dominant(), Some(SurfaceKind::Tile));
    // Maps out of order or repeated are refused and change nothing.
    assert_eq!(
        feed(&mut m, at(0.7), &floor(WOOD), 0.2),
        Err(MapError::Rejected(Reject::OutOfOrder))
    );
    assert_eq!(
        feed(&mut m, at(0.75), &floor(WOOD), 0.2),
        Err(MapError::Rejected(Reject::Duplicate))
    );
    assert_eq!(m.state_at(at(0.8)).dominant(), Some(SurfaceKind::Tile));
}

#[test]
fn a_stale_floor_falls_back_towards_the_conservative_default() {
    let cfg = TrackerConfig::new(S, 2 * S, S / 4, 0.02, 10 * S).unwrap();
    let mut m = model(cfg);
    feed(&mut m, at(0.0), &floor(WOOD), 0.2).unwrap();
    let wood = m.grip_params(at(0.5));
    let fallback = SurfaceConfig::conservative_params();
    assert_eq!(m.grip_params(at(1.0)), wood, "fresh up to the limit");
    assert!(!m.state_at(at(1.0)).is_stale());
    let half = m.grip_params(at(2.0));
    let s = m.state_at(at(2.0));
    assert!(s.is_stale());
    assert!((s.fallback_weight - 0.5).abs() < 1e-6);
    assert!(
        (half.forward_std() - 0.5 * (wood.forward_std() + fallback.forward_std())).abs() < 1e-6
    );
    assert!(half.forward_gate() > wood.forward_gate());
    assert_eq!(m.grip_params(at(3.0)), fallback);
    assert_eq!(m.grip_params(at(100.0)), fallback);
    // No learning on a stale floor.
    assert_eq!(
        m.on_wheel_innovation(at(2.0), 0.01, 1e-4, false),
        Err(Reject::NotReady)
    );
    assert!(m.on_wheel_innovation(at(0.5), 0.01, 1e-4, false).is_ok());
    // A fresh map restores the floor's own parameters.
    feed(&mut m, at(5.0), &floor(WOOD), 0.2).unwrap();
    assert_eq!(m.grip_params(at(5.1)), wood);
}

#[test]
fn two_floors_in_view_blend_the_grip() {
    let mut m = model(TrackerConfig::default());
    let half = map(W, H, |x, y| match (x < W / 2, y < 19) {
        (_, true) => WALL,
        (true, _) => WOOD,
        (false, _) => CARPET,
    });
    feed(&mut m, at(0.0), &half, 0.2).unwrap();
    let t = m.table();
    let wood = t.params(SurfaceKind::Wood, WheelType::HardRubber, 1.0);
    let carpet = t.params(SurfaceKind::Carpet, WheelType::HardRubber, 1.0);
    let p = m.grip_params(at(0.1));
    assert!((p.grip() - 0.5 * (wood.grip() + carpet.grip())).abs() < 1e-6);
    assert!(p.forward_std() > wood.forward_std() && p.forward_std() < carpet.forward_std());
}

#[test]
fn camera_rows_give_floor_distances() {
    let cam = camera();
    for d in [0.25, 0.3, 0.4, 0.6, 1.0, 2.0] {
        let est = cam
            .ground_distance(row_fraction_of_distance(d) as f32)
            .unwrap();
        assert!((est as f64 - d).abs() < 1e-3 * d.max(1.0), "{d}: {est}");
    }
    // Rows at or above the horizon do not meet the floor.
    let horizon = (CY - FY * PITCH.tan()) / IMAGE_H;
    assert_eq!(cam.ground_distance(horizon as f32 - 0.01), None);
    assert_eq!(cam.ground_distance(0.0), None);
    assert_eq!(cam.ground_distance(f32::NAN), None);
    assert_eq!(
        GroundCamera::new(0.0, 240.0, 480.0, 0.1, 0.1, 0.0),
        Err(CameraError::NotPositive)
    );
    assert_eq!(
        GroundCamera::new(400.0, 240.0, 480.0, 0.1, 2.0, 0.0),
        Err(CameraError::NonFinite)
    );
}

#[test]
fn an_approaching_floor_is_announced_and_taken_over_on_arrival() {
    // Wood up to 0.40 m ahead of the axle, carpet beyond; robot at 0.2 m/s:
    // the wheels reach the carpet 2 s after the map.
    let cfg = TrackerConfig::new(5 * S, 2 * S, 300_000_000, 0.02, 10 * S).unwrap();
    let mut m = model(cfg);
    let labels = boundary_map(W, H, 0.4, 0.40, WOOD, CARPET);
    let t0 = at(10.0);
    feed(&mut m, t0, &labels, 0.2).unwrap();
    let s = m.state_at(t0);
    let a = s.anticipation.expect("carpet announced");
    assert_eq!(a.kind, SurfaceKind::Carpet);
    // One label row is ~1.5 cm of floor here.
    assert!((a.distance - 0.40).abs() < 0.02, "distance {}", a.distance);
    let eta = a.arrival.unwrap().seconds_since(t0).unwrap();
    assert!((eta - 2.0).abs() < 0.1, "arrival after {eta} s");
    // Before the arrival the floor underfoot is wood, and the parameters are wood's.
    let t = m.table();
    let wood = t.params(SurfaceKind::Wood, WheelType::HardRubber, 1.0);
    let carpet = t.params(SurfaceKind::Carpet, WheelType::HardRubber, 1.0);
    assert_eq!(s.mix.unwrap().fraction(SurfaceKind::Wood), 1.0);
    assert_eq!(m.grip_params(at(11.0)), wood);
    assert_eq!(m.jolt_context(at(11.0), 0.2).next_crossing, a.arrival);
    // Around the arrival the grip blends over, and after it is carpet's.
    let mid = m.grip_params(a.arrival.unwrap());
    assert!(mid.grip() < wood.grip() && mid.grip() > carpet.grip());
    let after = at(10.0 + eta as f64 + 0.2);
    assert_eq!(m.state_at(after).dominant(), Some(SurfaceKind::Carpet));
    let p = m.grip_params(after);
    assert!((p.grip() - carpet.grip()).abs() < 1e-6);
    assert!((p.jolt_threshold() - carpet.jolt_threshold()).abs() < 1e-5);
    // The passed arrival is remembered as a boundary crossing.
    assert_eq!(m.tracker().last_crossing(after), a.arrival);
}

#[test]
fn the_announced_floor_waits_for_the_wheels_when_it_fills_the_view() {
    // Maps at 4 Hz while driving towards carpet at 0.2 m/s (boundary 0.5 m
    // ahead at t = 0, so the wheels reach it at 2.5 s). Once the boundary
    // leaves the ahead band the camera sees mostly carpet, yet the wheels are
    // still on wood until the announced arrival.
    let cfg = TrackerConfig::new(5 * S, 2 * S, 200_000_000, 0.02, 10 * S).unwrap();
    let mut m = model(cfg);
    let speed = 0.2;
    let mut announced = false;
    for i in 0..16 {
        let t = i as f64 * 0.25;
        let boundary = 0.5 - speed * t;
        let labels = boundary_map(W, H, 0.4, boundary, WOOD, CARPET);
        feed(&mut m, at(t), &labels, speed as f32).unwrap();
        let s = m.state_at(at(t));
        announced |= s.anticipation.is_some();
        let expected = if t < 2.4 {
            SurfaceKind::Wood
        } else if t > 2.6 {
            SurfaceKind::Carpet
        } else {
            continue;
        };
        assert_eq!(s.dominant(), Some(expected), "t {t}, boundary {boundary}");
    }
    assert!(announced);
    let crossing = m.tracker().last_crossing(at(4.0)).unwrap();
    let c = crossing.seconds_since(Timestamp(0)).unwrap();
    assert!((c - 2.5).abs() < 0.15, "crossing at {c}");
}

#[test]
fn a_standing_robot_gets_no_arrival_time() {
    let mut m = model(TrackerConfig::default());
    let labels = boundary_map(W, H, 0.4, 0.40, WOOD, CARPET);
    feed(&mut m, at(0.0), &labels, 0.0).unwrap();
    let s = m.state_at(at(1.0));
    let a = s.anticipation.unwrap();
    assert_eq!(a.arrival, None);
    assert_eq!(s.anticipation_weight, 0.0);
    assert_eq!(s.dominant(), Some(SurfaceKind::Wood));
    // Reversing is no approach either.
    feed(&mut m, at(0.25), &labels, -0.2).unwrap();
    assert_eq!(m.state_at(at(0.5)).anticipation.unwrap().arrival, None);
}

#[test]
fn a_dominant_floor_change_without_announcement_is_a_crossing() {
    let mut m = model(TrackerConfig::default());
    feed(&mut m, at(0.0), &floor(WOOD), 0.0).unwrap();
    assert_eq!(m.tracker().last_crossing(at(0.5)), None);
    feed(&mut m, at(0.5), &floor(TILE), 0.0).unwrap();
    assert_eq!(m.tracker().last_crossing(at(0.6)), Some(at(0.5)));
    let ctx = m.jolt_context(at(0.6), 0.1);
    assert_eq!(ctx.last_crossing, Some(at(0.5)));
    assert_eq!(ctx.surface, Some(SurfaceKind::Tile));
}

#[test]
fn a_camera_geometry_from_its_mount() {
    // The test camera as `T_BS` (row-major, as in a `sensor.yaml`): camera x
    // = body -y, camera y = (-sin p, 0, -cos p), optical axis (cos p, 0, -sin p).
    let (s, c) = (PITCH as f32).sin_cos();
    let (x, z) = (OFFSET as f32, CAM_HEIGHT as f32);
    let mount = vslam_core::geometry::Extrinsics::from_row_major(&[
        0.0, -s, c, x, -1.0, 0.0, 0.0, 0.0, 0.0, -c, -s, z, 0.0, 0.0, 0.0, 1.0,
    ])
    .unwrap();
    let cam = GroundCamera::from_mount(FY as f32, CY as f32, IMAGE_H as f32, &mount).unwrap();
    for d in [0.25, 0.4, 1.0] {
        let est = cam
            .ground_distance(row_fraction_of_distance(d) as f32)
            .unwrap();
        assert!((est as f64 - d).abs() < 1e-3, "{d}: {est}");
    }
    // The horizon row: rays through it are parallel to the floor.
    let horizon = (CY - FY * PITCH.tan()) / IMAGE_H;
    assert!((cam.horizon_fraction() as f64 - horizon).abs() < 1e-2);
    // Pitched down by more than half the vertical field of view: floor everywhere.
    let steep = GroundCamera::new(60.0, 29.5, 60.0, 0.08, 0.61, 0.15).unwrap();
    assert_eq!(steep.horizon_fraction(), 0.0);
    // Mounted upside down, rows grow away from the floor.
    let flipped = vslam_core::geometry::Extrinsics::from_row_major(&[
        0.0, s, c, x, 1.0, 0.0, 0.0, 0.0, 0.0, c, -s, z, 0.0, 0.0, 0.0, 1.0,
    ])
    .unwrap();
    assert_eq!(
        GroundCamera::from_mount(FY as f32, CY as f32, IMAGE_H as f32, &flipped),
        Err(CameraError::UpsideDown)
    );
}

/// Carpet up to a 4 cm threshold strip whose near edge is `edge` metres
/// ahead of the axle, tile beyond; walls above the camera's horizon.
fn carpet_strip_tile(edge: f64) -> Vec<u8> {
    let row = |d: f64| {
        if d > OFFSET + 1e-6 {
            row_fraction_of_distance(d)
        } else {
            f64::INFINITY
        }
    };
    let (lower, upper) = (row(edge), row(edge + 0.04));
    let horizon = (CY - FY * PITCH.tan()) / IMAGE_H + 0.01;
    map(W, H, |_, y| {
        let centre = (y as f64 + 0.5) / H as f64;
        if centre < horizon {
            WALL
        } else if centre > lower {
            CARPET
        } else if centre >= upper {
            STRIP
        } else {
            TILE
        }
    })
}

#[test]
fn a_strip_and_the_floor_behind_it_wait_for_the_wheels() {
    // Driving at 0.4 m/s towards a strip 0.40 m ahead: the wheels reach it at
    // 1.0 s. At 0.5 s the strip is at the bottom of the view and tile is the
    // nearest floor there, at 0.9 s the view is all tile; the wheels are on
    // carpet throughout, and the crossing is the strip's, not a map's time.
    let mut c = SurfaceConfig::for_camera(WheelType::HardRubber, classes(), camera());
    c.tracker = TrackerConfig::new(5 * S, 2 * S, 200_000_000, 0.02, 10 * S).unwrap();
    let mut m = SurfaceModel::new(c);
    let speed = 0.4;
    for t in [0.0, 0.5, 0.9] {
        let labels = carpet_strip_tile(0.40 - speed * t);
        feed(&mut m, at(t), &labels, speed as f32).unwrap();
        let s = m.state_at(at(t));
        assert_eq!(s.dominant(), Some(SurfaceKind::Carpet), "at {t} s");
        assert_eq!(m.tracker().last_crossing(at(t)), None, "at {t} s");
        let a = s.anticipation.expect("the strip stays announced");
        assert_eq!(a.kind, SurfaceKind::Threshold);
        let eta = a.arrival.unwrap().seconds_since(Timestamp(0)).unwrap();
        assert!((eta - 1.0).abs() < 0.05, "arrival at {eta} s");
    }
    feed(
        &mut m,
        at(1.3),
        &carpet_strip_tile(0.40 - speed * 1.3),
        speed as f32,
    )
    .unwrap();
    assert_eq!(m.state_at(at(1.3)).dominant(), Some(SurfaceKind::Tile));
    let crossing = m.tracker().last_crossing(at(1.3)).unwrap();
    let c = crossing.seconds_since(Timestamp(0)).unwrap();
    assert!((c - 1.0).abs() < 0.05, "crossing at {c} s");
}
