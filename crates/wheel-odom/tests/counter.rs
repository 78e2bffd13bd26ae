//! Counter extension: random wrap sequences against the true position.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use wheel_odom::{CounterConfigError, CounterError, CounterExtender};

fn wrapped(pos: i64, bits: u32) -> u32 {
    pos.rem_euclid(1i64 << bits) as u32
}

#[test]
fn sixteen_bit_wrap_both_ways() {
    let mut c = CounterExtender::bits16();
    assert_eq!(c.update(65_530), Ok(65_530));
    assert_eq!(c.update(4), Ok(65_540));
    assert_eq!(c.update(65_000), Ok(65_000));
    assert_eq!(c.update(33_000), Ok(33_000));
    assert_eq!(c.update(1_000), Ok(1_000));
    assert_eq!(c.update(65_535), Ok(-1));
    // -33000 is beyond half the range: it aliases to +32536 and is only
    // caught by a tighter max step.
    let mut c = CounterExtender::bits16().with_max_step(20_000).unwrap();
    c.update(65_000).unwrap();
    assert_eq!(c.update(32_000), Err(CounterError::Jump { delta: 32_536 }));
}

#[test]
fn half_range_jump_is_refused_counted_and_reanchored() {
    let mut c = CounterExtender::bits16();
    c.update(0).unwrap();
    assert_eq!(c.update(32_768), Err(CounterError::Jump { delta: -32_768 }));
    assert_eq!(c.jumps(), 1);
    assert_eq!(c.position(), 0);
    // Re-anchored on 32768: the next small step counts from there.
    assert_eq!(c.update(32_770), Ok(2));
}

#[test]
fn configured_max_step() {
    let mut c = CounterExtender::bits32().with_max_step(1000).unwrap();
    c.update(u32::MAX - 10).unwrap();
    assert_eq!(c.update(989), Ok(i64::from(u32::MAX) + 990));
    assert_eq!(c.update(2000), Err(CounterError::Jump { delta: 1011 }));
    assert_eq!(c.jumps(), 1);
    assert_eq!(
        CounterExtender::bits16().with_max_step(32_768),
        Err(CounterConfigError::BadMaxStep)
    );
    assert_eq!(CounterExtender::new(1), Err(CounterConfigError::BadWidth));
    assert_eq!(CounterExtender::new(33), Err(CounterConfigError::BadWidth));
}

#[test]
fn raw_wider_than_the_counter_is_refused() {
    let mut c = CounterExtender::new(14).unwrap();
    assert_eq!(
        c.update(16_384),
        Err(CounterError::OutOfRange { raw: 16_384 })
    );
    assert_eq!(c.last_raw(), None);
}

fn check_width(bits: u32, start: i64, steps: &[i64]) -> Result<(), TestCaseError> {
    let mut c = CounterExtender::new(bits as u8).unwrap();
    let mut truth = start;
    prop_assert_eq!(c.update(wrapped(truth, bits)), Ok(truth));
    for &s in steps {
        truth += s;
        prop_assert_eq!(c.update(wrapped(truth, bits)), Ok(truth));
    }
    prop_assert_eq!(c.jumps(), 0);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { rng_seed: RngSeed::Fixed(1632), cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn extension_16_bit_equals_truth(start in 0i64..65_536,
                                     steps in prop::collection::vec(-32_767i64..=32_767, 0..200)) {
        check_width(16, start, &steps)?;
    }

    #[test]
    fn extension_32_bit_equals_truth(start in 0i64..(1i64 << 32),
                                     steps in prop::collection::vec(-(1i64 << 31) + 1..=(1i64 << 31) - 1, 0..200)) {
        check_width(32, start, &steps)?;
    }

    #[test]
    fn extension_14_bit_equals_truth(start in 0i64..16_384,
                                     steps in prop::collection::vec(-8191i64..=8191, 0..200)) {
        check_width(14, start, &steps)?;
    }

    #[test]
    fn any_raw_sequence_never_panics(bits in 2u8..=32, raws in prop::collection::vec(any::<u32>(), 0..100)) {
        let mut c = CounterExtender::new(bits).unwrap();
        for r in raws {
            let _ = c.update(r);
        }
    }
}
