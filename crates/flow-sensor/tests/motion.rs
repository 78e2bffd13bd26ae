//! Motion_Burst decoding (golden vectors written from the datasheet's burst
//! table), orientation, rotation and the `FlowSource` trait.

mod common;

use common::{FaultySpi, PMW3901_WRITES, Script};
use embedded_hal::spi::ErrorKind;
use embedded_hal_mock::eh1::delay::NoopDelay;
use flow_sensor::{Error, FlowSensor, MotionBurst, Orientation, Rotation, Variant};
use vslam_core::Timestamp;
use vslam_core::sensors::{FlowSample, FlowSource};

fn init_script() -> Script {
    Script::new()
        .reset_and_id()
        .clear_motion()
        .ws(PMW3901_WRITES)
        .r(0x5B, 0xA0)
        .clear_motion()
}

// Motion, Observation, DX_L, DX_H, DY_L, DY_H, SQUAL, RawSum, Max, Min, Shutter_Upper, Shutter_Lower
const GOLDEN: [u8; 12] = [
    0x80, 0xBF, 0x34, 0x12, 0xFE, 0xFF, 0x40, 0x55, 0xF0, 0x10, 0x01, 0x23,
];

#[test]
fn burst_golden_vector_decodes_by_the_datasheet_layout() {
    let b = MotionBurst::from_bytes(&GOLDEN);
    assert!(b.has_motion());
    assert_eq!(b.motion, 0x80);
    assert_eq!(b.observation, 0xBF);
    assert_eq!(b.delta_x, 4660); // 0x1234, low byte first
    assert_eq!(b.delta_y, -2); // 0xFFFE
    assert_eq!(b.squal, 64);
    assert_eq!(b.raw_data_sum, 0x55);
    assert_eq!(b.max_raw_data, 0xF0);
    assert_eq!(b.min_raw_data, 0x10);
    assert_eq!(b.shutter, 291); // 0x0123: upper byte first
    assert!(b.is_valid());
}

#[test]
fn low_quality_is_a_value_not_an_error() {
    // No motion, SQUAL 0x18 < 0x19 with Shutter_Upper 0x1F: invalid by the rule.
    let bytes = [0x00, 0, 0x00, 0x80, 0xFF, 0x7F, 0x18, 1, 2, 3, 0x1F, 0xFF];
    let b = MotionBurst::from_bytes(&bytes);
    assert!(!b.has_motion());
    assert_eq!(b.delta_x, i16::MIN);
    assert_eq!(b.delta_y, i16::MAX);
    assert_eq!(b.shutter, 0x1FFF);
    assert!(!b.is_valid());
    let s = b.to_sample(Timestamp(9));
    assert!(s.is_saturated());
    assert!(!s.is_valid());
    assert!(!s.motion);
}

#[test]
fn read_flow_reads_one_burst_and_stamps_it() {
    let mut spi = init_script().burst(GOLDEN).mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    s.init().unwrap();
    let sample = s.read_flow(Timestamp(1_000)).unwrap();
    assert_eq!(
        sample,
        FlowSample {
            t: Timestamp(1_000),
            dx: 4660,
            dy: -2,
            squal: 64,
            shutter: 291,
            raw_sum: 0x55,
            raw_max: 0xF0,
            raw_min: 0x10,
            motion: true,
        }
    );
    spi.done();
}

#[test]
fn software_rotation_turns_the_vector() {
    let mut spi = init_script().burst(GOLDEN).burst(GOLDEN).mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    s.init().unwrap();
    s.set_rotation(Rotation::Deg90);
    let a = s.read_flow(Timestamp(1)).unwrap();
    assert_eq!((a.dx, a.dy), (2, 4660));
    s.set_rotation(Rotation::Deg270);
    let b = s.read_flow(Timestamp(2)).unwrap();
    assert_eq!((b.dx, b.dy), (-2, -4660));
    spi.done();
}

#[test]
fn reading_before_init_touches_no_bus() {
    let mut spi = Script::new().mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Paa5100je);
    assert_eq!(s.read_flow(Timestamp(1)), Err(Error::NotInMotionMode));
    spi.done();
}

#[test]
fn orientation_register_bits() {
    let mut spi = init_script()
        .w(0x5B, 0b1010_0000)
        .w(0x5B, 0b0100_0000)
        .r(0x5B, 0b1110_0000)
        .mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    s.init().unwrap();
    s.set_orientation(Orientation {
        swap_xy: true,
        invert_x: true,
        invert_y: false,
    })
    .unwrap();
    s.set_orientation(Orientation {
        swap_xy: false,
        invert_x: false,
        invert_y: true,
    })
    .unwrap();
    assert_eq!(
        s.read_orientation().unwrap(),
        Orientation {
            swap_xy: true,
            invert_x: true,
            invert_y: true
        }
    );
    spi.done();
}

#[test]
fn bus_error_during_a_burst() {
    let mut mock = init_script().mock();
    // init is 1 + 2 + 5 + 73 + 1 + 5 = 87 transactions; the burst is the 88th.
    let mut s = FlowSensor::new(
        FaultySpi::new(mock.clone(), 87),
        NoopDelay::new(),
        Variant::Pmw3901,
    );
    s.init().unwrap();
    assert_eq!(s.read_flow(Timestamp(5)), Err(Error::Spi(ErrorKind::Other)));
    mock.done();
}

#[test]
fn rotation_from_degrees() {
    assert_eq!(Rotation::from_degrees(-90), Some(Rotation::Deg270));
    assert_eq!(Rotation::from_degrees(450), Some(Rotation::Deg90));
    assert_eq!(Rotation::from_degrees(45), None);
}

mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED), ..ProptestConfig::default() })]

        #[test]
        fn burst_encoding_round_trips(dx in any::<i16>(), dy in any::<i16>(), shutter in any::<u16>(),
                                      squal in any::<u8>(), m in any::<u8>()) {
            let x = dx.to_le_bytes();
            let y = dy.to_le_bytes();
            let sh = shutter.to_be_bytes();
            let bytes = [m, 0, x[0], x[1], y[0], y[1], squal, 0, 0, 0, sh[0], sh[1]];
            let b = MotionBurst::from_bytes(&bytes);
            prop_assert_eq!((b.delta_x, b.delta_y, b.shutter, b.squal), (dx, dy, shutter, squal));
            prop_assert_eq!(b.has_motion(), m >= 0x80);
            prop_assert_eq!(b.is_valid(), !(squal < 0x19 && sh[0] == 0x1F));
        }

        #[test]
        fn four_quarter_turns_are_the_identity(x in -32767i16..=32767, y in -32767i16..=32767) {
            let mut v = (x, y);
            for _ in 0..4 {
                v = Rotation::Deg90.apply(v.0, v.1);
            }
            prop_assert_eq!(v, (x, y));
            prop_assert_eq!(Rotation::Deg180.apply(x, y), Rotation::Deg90.apply(-y, x));
        }

        #[test]
        fn rotation_never_panics(x in any::<i16>(), y in any::<i16>()) {
            for r in [Rotation::Deg0, Rotation::Deg90, Rotation::Deg180, Rotation::Deg270] {
                let _ = r.apply(x, y);
            }
        }
    }
}
