//! Quadrature decoding: random valid sequences against the true count,
//! corrupted ones against the number of illegal transitions.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use wheel_odom::{QuadStep, QuadratureDecoder};

/// (A, B) for a position, A leading B when counting up: 00, 10, 11, 01.
fn levels(pos: i64) -> (bool, bool) {
    match pos.rem_euclid(4) {
        0 => (false, false),
        1 => (true, false),
        2 => (true, true),
        _ => (false, true),
    }
}

#[test]
fn one_forward_cycle_is_four_counts() {
    let mut q = QuadratureDecoder::new();
    assert_eq!(q.update(false, false), QuadStep::Idle);
    assert_eq!(q.update(true, false), QuadStep::Forward);
    assert_eq!(q.update(true, true), QuadStep::Forward);
    assert_eq!(q.update(false, true), QuadStep::Forward);
    assert_eq!(q.update(false, false), QuadStep::Forward);
    assert_eq!(q.count(), 4);
    assert_eq!(q.update(false, true), QuadStep::Backward);
    assert_eq!(q.update(false, true), QuadStep::Idle);
    assert_eq!(q.count(), 3);
    // Both bits change: 01 -> 10.
    assert_eq!(q.update(true, false), QuadStep::Illegal);
    assert_eq!(q.count(), 3);
    assert_eq!(q.illegal_transitions(), 1);
    q.reset();
    assert_eq!(q.count(), 0);
    assert_eq!(q.illegal_transitions(), 0);
}

proptest! {
    #![proptest_config(ProptestConfig { rng_seed: RngSeed::Fixed(4), cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn valid_sequences_decode_to_the_true_count(start in any::<i8>(),
                                                steps in prop::collection::vec(-1i64..=1, 0..500)) {
        let mut q = QuadratureDecoder::new();
        let mut pos = i64::from(start);
        let (a, b) = levels(pos);
        q.update(a, b);
        for s in &steps {
            pos += s;
            let (a, b) = levels(pos);
            q.update(a, b);
        }
        prop_assert_eq!(q.count(), steps.iter().sum::<i64>());
        prop_assert_eq!(q.illegal_transitions(), 0);
    }

    #[test]
    fn double_steps_are_counted_as_illegal_not_guessed(
        steps in prop::collection::vec(prop_oneof![4 => -1i64..=1, 1 => Just(2i64), 1 => Just(-2i64)], 0..500)) {
        let mut q = QuadratureDecoder::new();
        let mut pos = 0i64;
        q.update(false, false);
        for s in &steps {
            pos += s;
            let (a, b) = levels(pos);
            q.update(a, b);
        }
        let legal: i64 = steps.iter().filter(|s| s.abs() <= 1).sum();
        let illegal = steps.iter().filter(|s| s.abs() == 2).count() as u32;
        prop_assert_eq!(q.count(), legal);
        prop_assert_eq!(q.illegal_transitions(), illegal);
    }

    #[test]
    fn any_levels_never_panic(levels in prop::collection::vec(any::<(bool, bool)>(), 0..200)) {
        let mut q = QuadratureDecoder::new();
        for (a, b) in levels {
            q.update(a, b);
        }
        prop_assert!(q.count().unsigned_abs() <= 200);
    }
}
