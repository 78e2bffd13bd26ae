//! Wheel pairs as `WheelEncoderSource`: two AS5047P (multi-turn unwrapping)
//! and two hardware counters.

mod common;

use common::{Frames, parity};
use std::collections::VecDeque;
use vslam_core::Timestamp;
use vslam_core::sensors::{WheelEncoderSource, WheelTicks};
use wheel_odom::{
    As5047p, As5047pEncoder, As5047pError, CounterEncoder, CounterError, CounterExtender,
    CumulativeEncoder, EncoderError, PairError, Polarity, QuadratureDecoder, RawCounter, WheelPair,
};

const READ_ANGLECOM: u16 = 0xFFFF;

fn angles(values: &[u16]) -> Frames {
    values
        .iter()
        .fold(Frames::new(), |f, &a| f.read(READ_ANGLECOM, parity(a)))
}

#[test]
fn two_as5047p_unwrap_across_the_zero_crossing() {
    let mut left_bus = angles(&[16_000, 100, 300]).mock();
    let mut right_bus = angles(&[100, 16_000, 15_800]).mock();
    let left = As5047pEncoder::new(As5047p::new(left_bus.clone()), Polarity::Normal, None).unwrap();
    let right =
        As5047pEncoder::new(As5047p::new(right_bus.clone()), Polarity::Reversed, None).unwrap();
    let mut pair = WheelPair::new(left, right);
    let expect = [(16_000, -100), (16_484, 384), (16_684, 584)];
    for (i, (l, r)) in expect.into_iter().enumerate() {
        let t = Timestamp(i as u64 * 1_000_000);
        assert_eq!(
            pair.read_ticks(t),
            Ok(WheelTicks {
                t,
                left: l,
                right: r
            })
        );
    }
    // 16684 counts of 16384 per turn.
    let turns = pair.left.angle_rad() / std::f32::consts::TAU;
    assert!((turns - 16_684.0 / 16_384.0).abs() < 1e-6);
    left_bus.done();
    right_bus.done();
}

#[test]
fn as5047p_impossible_jump_is_a_typed_error() {
    let mut left_bus = angles(&[0, 5_000, 5_100]).mock();
    // Read on every pair read, the left's failure included.
    let mut right_bus = angles(&[0, 3_000, 6_000]).mock();
    let left = As5047pEncoder::new(
        As5047p::new(left_bus.clone()),
        Polarity::Normal,
        Some(1_000),
    )
    .unwrap();
    let right = As5047pEncoder::new(
        As5047p::new(right_bus.clone()),
        Polarity::Normal,
        Some(4_096),
    )
    .unwrap();
    let mut pair = WheelPair::new(left, right);
    pair.read_ticks(Timestamp(0)).unwrap();
    assert_eq!(
        pair.read_ticks(Timestamp(1)),
        Err(PairError::Left(EncoderError::Counter(CounterError::Jump {
            delta: 5_000
        })))
    );
    assert_eq!(pair.left.extender().jumps(), 1);
    // The left re-anchored on 5000: +100. The right kept step through the
    // left's failure: 6000 counts from its start in two steps of 3000 (one
    // of 6000 would have been refused as a jump).
    assert_eq!(
        pair.read_ticks(Timestamp(2)),
        Ok(WheelTicks {
            t: Timestamp(2),
            left: 100,
            right: 6_000
        })
    );
    assert_eq!(pair.right.extender().jumps(), 0);
    left_bus.done();
    right_bus.done();
}

#[test]
fn as5047p_parity_error_reaches_the_pair() {
    let mut left_bus = angles(&[10]).mock();
    let mut right_bus = Frames::new().read(READ_ANGLECOM, 0x0001).mock();
    let left = As5047pEncoder::new(As5047p::new(left_bus.clone()), Polarity::Normal, None).unwrap();
    let right =
        As5047pEncoder::new(As5047p::new(right_bus.clone()), Polarity::Normal, None).unwrap();
    let mut pair = WheelPair::new(left, right);
    assert_eq!(
        pair.read_ticks(Timestamp(0)),
        Err(PairError::Right(EncoderError::Source(
            As5047pError::Parity { frame: 0x0001 }
        )))
    );
    left_bus.done();
    right_bus.done();
}

#[test]
fn a_pair_reports_the_failure_that_breaks_the_count() {
    // The left's answer fails its parity check (its count continues: the
    // unwrapping never saw it) while the right's extension refuses a jump
    // (its count is held): the pair reports the right's, so that the
    // odometry anchors afresh instead of stepping across.
    let mut left_bus = angles(&[0])
        .read(READ_ANGLECOM, 0x0001)
        .read(READ_ANGLECOM, parity(200))
        .mock();
    let mut right_bus = angles(&[0, 5_000, 5_100]).mock();
    let left = As5047pEncoder::new(As5047p::new(left_bus.clone()), Polarity::Normal, None).unwrap();
    let right = As5047pEncoder::new(
        As5047p::new(right_bus.clone()),
        Polarity::Normal,
        Some(1_000),
    )
    .unwrap();
    let mut pair = WheelPair::new(left, right);
    pair.read_ticks(Timestamp(0)).unwrap();
    let e = pair.read_ticks(Timestamp(1)).unwrap_err();
    assert_eq!(
        e,
        PairError::Right(EncoderError::Counter(CounterError::Jump { delta: 5_000 }))
    );
    assert_eq!(
        pair.read_ticks(Timestamp(2)),
        Ok(WheelTicks {
            t: Timestamp(2),
            left: 200,
            right: 100
        })
    );
    left_bus.done();
    right_bus.done();
}

/// A timer register fed from a list.
struct FakeTimer(VecDeque<Result<u32, &'static str>>);

impl RawCounter for FakeTimer {
    type Error = &'static str;
    fn read_raw(&mut self) -> Result<u32, Self::Error> {
        self.0.pop_front().unwrap_or(Err("empty"))
    }
}

fn timer(values: &[Result<u32, &'static str>]) -> FakeTimer {
    FakeTimer(values.iter().copied().collect())
}

#[test]
fn two_hardware_counters() {
    let left = CounterEncoder::new(
        timer(&[Ok(65_500), Ok(30), Err("bus")]),
        CounterExtender::bits16(),
        Polarity::Normal,
    );
    let right = CounterEncoder::new(
        timer(&[Ok(10), Ok(65_530)]),
        CounterExtender::bits16(),
        Polarity::Reversed,
    );
    let mut pair = WheelPair::new(left, right);
    assert_eq!(
        pair.read_ticks(Timestamp(5)),
        Ok(WheelTicks {
            t: Timestamp(5),
            left: 65_500,
            right: -10
        })
    );
    assert_eq!(
        pair.read_ticks(Timestamp(6)),
        Ok(WheelTicks {
            t: Timestamp(6),
            left: 65_566,
            right: 6
        })
    );
    assert_eq!(
        pair.read_ticks(Timestamp(7)),
        Err(PairError::Left(EncoderError::Source("bus")))
    );
}

#[test]
fn software_decoder_as_a_wheel() {
    let mut l = QuadratureDecoder::new();
    for (a, b) in [(false, false), (true, false), (true, true)] {
        l.update(a, b);
    }
    let mut pair = WheelPair::new(l, QuadratureDecoder::new());
    let ticks = pair.read_ticks(Timestamp(1)).unwrap();
    assert_eq!((ticks.left, ticks.right), (2, 0));
}

#[test]
fn magnet_check_keeps_the_warnings() {
    const READ_DIAAGC: u16 = 0xFFFC;
    // MAGH warning (0x0400) with LF: the angle is still valid.
    let mut bus = Frames::new()
        .f(READ_DIAAGC, 0)
        .f(READ_ANGLECOM, parity(0x0500))
        .f(0x0000, parity(1_000))
        .mock();
    let mut enc = As5047pEncoder::new(As5047p::new(bus.clone()), Polarity::Normal, None)
        .unwrap()
        .with_magnet_check(true);
    assert_eq!(enc.read_count(), Ok(1_000));
    let d = enc.last_diagnostics().unwrap();
    assert!(d.field_too_strong && !d.is_healthy());
    bus.done();
}
