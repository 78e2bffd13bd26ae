//! Label map -> floor fractions: membership, blending, bottom weighting,
//! horizon, and the no-surface statuses.

mod surface_support;

use ego_ekf::surface::{
    NoSurface, SegmentationConfig, SegmentationConfigError, Segmenter, SurfaceKind,
};
use surface_support::*;
use vslam_core::image::LabelView;

fn segmenter() -> Segmenter {
    Segmenter::new(classes(), SegmentationConfig::default())
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn one_ground_class_is_all_of_the_mix() {
    // 40 x 30, horizon at 40 % = row 12; wall above, wood below.
    let m = map(40, 30, |_, y| if y < 12 { WALL } else { WOOD });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 40, 30, 40).unwrap())
        .unwrap();
    assert_eq!(v.mix.fraction(SurfaceKind::Wood), 1.0);
    assert_eq!(v.mix.dominant(), SurfaceKind::Wood);
    assert_eq!(v.coverage, 1.0);
    assert_eq!(v.upcoming, None);
    assert_eq!(v.current_kind(), SurfaceKind::Wood);
}

#[test]
fn two_ground_classes_side_by_side_blend_half_and_half() {
    let m = map(40, 30, |x, _| if x < 20 { WOOD } else { CARPET });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 40, 30, 40).unwrap())
        .unwrap();
    assert!(close(v.mix.fraction(SurfaceKind::Wood), 0.5, 1e-6));
    assert!(close(v.mix.fraction(SurfaceKind::Carpet), 0.5, 1e-6));
    // Both are underfoot: the present mix keeps both.
    let p = v.present_mix();
    assert!(close(p.fraction(SurfaceKind::Carpet), 0.5, 1e-6));
    // A quarter carpet gives a quarter.
    let m = map(40, 30, |x, _| if x < 30 { TILE } else { CARPET });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 40, 30, 40).unwrap())
        .unwrap();
    assert!(close(v.mix.fraction(SurfaceKind::Tile), 0.75, 1e-6));
    assert!(close(v.mix.fraction(SurfaceKind::Carpet), 0.25, 1e-6));
}

#[test]
fn rows_nearer_the_bottom_weigh_more() {
    // Region rows 12..30 (18 rows): carpet in the upper 9, wood in the lower 9.
    let (w, h) = (16, 30);
    let m = map(w, h, |_, y| if y < 21 { CARPET } else { WOOD });
    let v = segmenter()
        .analyze(&LabelView::new(&m, w, h, w).unwrap())
        .unwrap();
    // Expected with the documented weight 1 + 3 t, t = (i + 0.5) / 18.
    let weight = |i: usize| 1.0 + 3.0 * (i as f32 + 0.5) / 18.0;
    let total: f32 = (0..18).map(weight).sum();
    let wood: f32 = (9..18).map(weight).sum();
    let expected = wood / total;
    assert!(expected > 0.6);
    assert!(close(v.mix.fraction(SurfaceKind::Wood), expected, 1e-5));
    // Mirror image: the nearer floor still wins.
    let m = map(w, h, |_, y| if y < 21 { WOOD } else { CARPET });
    let v = segmenter()
        .analyze(&LabelView::new(&m, w, h, w).unwrap())
        .unwrap();
    assert!(close(v.mix.fraction(SurfaceKind::Carpet), expected, 1e-5));
    // Without bottom gain the two halves count equally.
    let flat = SegmentationConfig::new(0.4, 0.0, 1.0 / 3.0, 1.0 / 3.0, 0.02, 0.25).unwrap();
    let v = Segmenter::new(classes(), flat)
        .analyze(&LabelView::new(&m, w, h, w).unwrap())
        .unwrap();
    assert!(close(v.mix.fraction(SurfaceKind::Carpet), 0.5, 1e-6));
}

#[test]
fn floor_above_the_horizon_is_ignored() {
    let m = map(20, 30, |_, y| if y < 12 { CARPET } else { WOOD });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 20, 30, 20).unwrap())
        .unwrap();
    assert_eq!(v.mix.fraction(SurfaceKind::Carpet), 0.0);
    // Moving the horizon to the top lets it in.
    let cfg = SegmentationConfig::new(0.0, 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.02, 0.25).unwrap();
    let v = Segmenter::new(classes(), cfg)
        .analyze(&LabelView::new(&m, 20, 30, 20).unwrap())
        .unwrap();
    assert!(v.mix.fraction(SurfaceKind::Carpet) > 0.1);
}

#[test]
fn unknown_and_walls_lower_coverage_not_fractions() {
    let m = map(20, 30, |x, y| match (x < 10, y < 12) {
        (_, true) => WALL,
        (true, false) => UNKNOWN,
        (false, false) => TILE,
    });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 20, 30, 20).unwrap())
        .unwrap();
    assert_eq!(v.mix.fraction(SurfaceKind::Tile), 1.0);
    assert!(close(v.coverage, 0.5, 1e-6));
}

#[test]
fn maps_without_ground_give_a_status() {
    let s = segmenter();
    let m = map(8, 6, |_, _| UNKNOWN);
    assert_eq!(
        s.analyze(&LabelView::new(&m, 8, 6, 8).unwrap()),
        Err(NoSurface::OnlyUnknown)
    );
    let m = map(8, 6, |x, _| if x % 2 == 0 { UNKNOWN } else { WALL });
    assert_eq!(
        s.analyze(&LabelView::new(&m, 8, 6, 8).unwrap()),
        Err(NoSurface::NoGround)
    );
    // Ground only above the horizon.
    let m = map(8, 10, |_, y| if y < 4 { WOOD } else { WALL });
    assert_eq!(
        s.analyze(&LabelView::new(&m, 8, 10, 8).unwrap()),
        Err(NoSurface::NoGround)
    );
    // One ground pixel in a wall of 600 region pixels.
    let m = map(20, 50, |x, y| if (x, y) == (3, 49) { WOOD } else { WALL });
    assert_eq!(
        s.analyze(&LabelView::new(&m, 20, 50, 20).unwrap()),
        Err(NoSurface::TooLittleGround)
    );
    // An id nobody configured is unknown.
    let m = map(8, 6, |_, _| 200);
    assert_eq!(
        s.analyze(&LabelView::new(&m, 8, 6, 8).unwrap()),
        Err(NoSurface::OnlyUnknown)
    );
}

#[test]
fn any_size_and_stride_work() {
    let s = segmenter();
    let one = [CARPET];
    let v = s.analyze(&LabelView::new(&one, 1, 1, 1).unwrap()).unwrap();
    assert_eq!(v.mix.dominant(), SurfaceKind::Carpet);
    let column = [WALL, WALL, WOOD];
    let v = s
        .analyze(&LabelView::new(&column, 1, 3, 1).unwrap())
        .unwrap();
    assert_eq!(v.mix.fraction(SurfaceKind::Wood), 1.0);
    // Padding bytes beyond the width (carpet) are not pixels.
    let (w, h, stride) = (4, 10, 6);
    let mut buf = vec![CARPET; stride * h];
    for y in 0..h {
        for x in 0..w {
            buf[y * stride + x] = WOOD;
        }
    }
    let v = s
        .analyze(&LabelView::new(&buf, w, h, stride).unwrap())
        .unwrap();
    assert_eq!(v.mix.fraction(SurfaceKind::Carpet), 0.0);
}

#[test]
fn a_different_floor_in_the_ahead_band_is_announced() {
    // 48 rows: region 19..48, ahead band 28..38, near band 38..48.
    let cfg = SegmentationConfig::default();
    assert_eq!(cfg.rows(48), (19, 28, 38));
    let m = map(24, 48, |_, y| match y {
        0..19 => WALL,
        19..33 => CARPET,
        _ => WOOD,
    });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 24, 48, 24).unwrap())
        .unwrap();
    assert_eq!(v.current_kind(), SurfaceKind::Wood);
    let up = v.upcoming.expect("carpet ahead");
    assert_eq!(up.kind, SurfaceKind::Carpet);
    assert!(close(up.fraction, 0.5, 1e-6));
    // Nearest carpet row is 32: its lower edge is at 33 / 48.
    assert!(close(up.row_fraction, 33.0 / 48.0, 1e-6));
    // The floor underfoot is wood only: carpet is ahead, not under the robot.
    assert_eq!(v.present_mix().fraction(SurfaceKind::Wood), 1.0);
    assert!(v.mix.fraction(SurfaceKind::Carpet) > 0.2);
    // Carpet only in the far band: nothing announced yet.
    let m = map(24, 48, |_, y| match y {
        0..19 => WALL,
        19..25 => CARPET,
        _ => WOOD,
    });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 24, 48, 24).unwrap())
        .unwrap();
    assert_eq!(v.upcoming, None);
    // A sliver below the change fraction is not announced either.
    let m = map(40, 48, |x, y| match (x, y) {
        (_, 0..19) => WALL,
        (0..4, 28..38) => CARPET,
        _ => WOOD,
    });
    let v = segmenter()
        .analyze(&LabelView::new(&m, 40, 48, 40).unwrap())
        .unwrap();
    assert_eq!(v.upcoming, None);
}

#[test]
fn config_is_checked() {
    use SegmentationConfigError as E;
    assert_eq!(
        SegmentationConfig::new(1.0, 3.0, 0.3, 0.3, 0.0, 0.2),
        Err(E::Horizon)
    );
    assert_eq!(
        SegmentationConfig::new(f32::NAN, 3.0, 0.3, 0.3, 0.0, 0.2),
        Err(E::Horizon)
    );
    assert_eq!(
        SegmentationConfig::new(0.4, -1.0, 0.3, 0.3, 0.0, 0.2),
        Err(E::BottomGain)
    );
    assert_eq!(
        SegmentationConfig::new(0.4, 3.0, 0.7, 0.7, 0.0, 0.2),
        Err(E::Bands)
    );
    assert_eq!(
        SegmentationConfig::new(0.4, 3.0, 0.3, 0.3, 1.5, 0.2),
        Err(E::Fraction)
    );
}

#[test]
fn class_table_lists_its_ground_ids() {
    use ego_ekf::surface::{ClassConfig, ClassRole};
    let c = classes();
    let ground: Vec<(u8, SurfaceKind)> = c.ground_ids().collect();
    assert_eq!(
        ground,
        vec![
            (WOOD, SurfaceKind::Wood),
            (CARPET, SurfaceKind::Carpet),
            (TILE, SurfaceKind::Tile),
            (CONCRETE, SurfaceKind::Concrete),
            (STRIP, SurfaceKind::Threshold),
        ]
    );
    assert_eq!(c.role(WALL), ClassRole::NotGround);
    assert_eq!(c.role(UNKNOWN), ClassRole::Unknown);
    assert_eq!(c.role(255), ClassRole::Unknown);
    assert_eq!(c.ground_kind(WALL), None);
    // A later entry for the same id wins; builders agree with lists.
    let c = ClassConfig::new()
        .with_ground(7, SurfaceKind::Tile)
        .with_not_ground(7)
        .with_ground(255, SurfaceKind::Carpet);
    assert_eq!(c.role(7), ClassRole::NotGround);
    assert_eq!(c.ground_kind(255), Some(SurfaceKind::Carpet));
    assert_eq!(c.ground_ids().count(), 1);
}
