//! Unit tests of the parent module.
use super::*;

#[test]
fn the_table_gives_the_documented_layout() {
    assert_eq!(
        [P, V, TH, BA, BG, G, KG, CL, CR, RB, RAD, CP, CTH],
        [0, 3, 6, 9, 12, 15, 18, 19, 22, 25, 28, 30, 33]
    );
    assert_eq!((DIM, IMU_DIM, REST_DIM), (36, 19, 17));
    assert_eq!(CLONE, 30..36);
    assert_eq!(ROTATIONS, [TH, RB, CTH]);
    assert_eq!(part_range(Part::Robot), 19..30);
}

#[test]
fn blocks_follow_each_other_without_gaps() {
    let mut end = 0;
    for b in BLOCKS {
        assert_eq!(b.start, end, "{}", b.name);
        end = b.range().end;
    }
    assert_eq!(end, DIM);
    assert_eq!(block("q_rb").kind, Kind::Rotation);
    assert_eq!(block("radii").range(), RAD_L..RAD_R + 1);
}

#[test]
fn columns_list_the_named_blocks_in_order() {
    const NAMES: [&str; 2] = ["radii", "q_wb"];
    const C: [usize; columns_len(&NAMES)] = columns(&NAMES);
    assert_eq!(C, [RAD, RAD + 1, TH, TH + 1, TH + 2]);
}

#[test]
fn layout_fills_in_the_starts_of_a_new_table() {
    let t = layout([
        Block::new("a", 4, Kind::Vector, Part::Imu, Drive::Zero, Prior::Copied),
        Block::new(
            "b",
            3,
            Kind::Rotation,
            Part::Robot,
            Drive::Zero,
            Prior::Copied,
        ),
        Block::new(
            "c",
            1,
            Kind::Vector,
            Part::Robot,
            Drive::Zero,
            Prior::Copied,
        ),
        Block::new(
            "d",
            3,
            Kind::Rotation,
            Part::Clone,
            Drive::Zero,
            Prior::Copied,
        ),
    ]);
    assert_eq!(t.map(|b| b.start), [0, 4, 7, 8]);
}

#[test]
#[should_panic(expected = "the IMU blocks come first")]
fn layout_refuses_a_clone_before_the_robot() {
    let _ = layout([
        Block::new("a", 3, Kind::Vector, Part::Imu, Drive::Zero, Prior::Copied),
        Block::new(
            "b",
            3,
            Kind::Vector,
            Part::Clone,
            Drive::Zero,
            Prior::Copied,
        ),
        Block::new(
            "c",
            3,
            Kind::Vector,
            Part::Robot,
            Drive::Zero,
            Prior::Copied,
        ),
    ]);
}

#[test]
#[should_panic(expected = "a rotation block has three components")]
fn layout_refuses_a_rotation_of_two_components() {
    let _ = layout([Block::new(
        "a",
        2,
        Kind::Rotation,
        Part::Imu,
        Drive::Zero,
        Prior::Copied,
    )]);
}
