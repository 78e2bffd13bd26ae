//! Shutdown and wake as bus scripts: shutdown is Shutdown (0x3B) <- 0xB6,
//! the chip is left alone while shut down, and waking is the whole power-up
//! again (PMW3901MB datasheet, shutdown section). Values restated here.

mod common;

use common::{FaultySpi, PMW3901_WRITES, Script};
use embedded_hal::spi::ErrorKind;
use embedded_hal_mock::eh1::delay::NoopDelay;
use flow_sensor::{Error, FlowSensor, Mode, Variant};
use vslam_core::Timestamp;
use vslam_core::sensors::FlowSource;

/// The PMW3901 power-up: reset, identity, motion reads, table, readback, motion reads.
fn power_up(s: Script) -> Script {
    s.reset_and_id()
        .clear_motion()
        .ws(PMW3901_WRITES)
        .r(0x5B, 0xA0)
        .clear_motion()
}

const BURST: [u8; 12] = [
    0x80, 0xBF, 0x05, 0x00, 0xFD, 0xFF, 0x40, 0x55, 0xF0, 0x10, 0x01, 0x23,
];

#[test]
fn shutdown_is_one_write_and_the_bus_stays_quiet() {
    let mut spi = power_up(Script::new()).w(0x3B, 0xB6).mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    s.init().unwrap();
    s.shutdown().unwrap();
    assert_eq!(s.mode(), Mode::Shutdown);
    assert!(s.is_shut_down());
    // Reads, a second shutdown and a frame grab do not touch the bus.
    assert_eq!(s.read_flow(Timestamp(1)), Err(Error::Shutdown));
    s.shutdown().unwrap();
    let mut frame = [0u8; 35 * 35];
    assert_eq!(s.capture_frame(&mut frame), Err(Error::Shutdown));
    spi.done();
}

#[test]
fn wake_runs_the_power_up_again_and_motion_resumes() {
    let mut spi = power_up(Script::new())
        .burst(BURST)
        .w(0x3B, 0xB6)
        .then(power_up)
        .burst(BURST)
        .mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    s.init().unwrap();
    assert_eq!(s.read_flow(Timestamp(1)).unwrap().dx, 5);
    s.shutdown().unwrap();
    s.wake().unwrap();
    assert_eq!(s.mode(), Mode::Motion);
    let after = s.read_flow(Timestamp(2)).unwrap();
    assert_eq!((after.dx, after.dy), (5, -3));
    spi.done();
}

#[test]
fn a_failed_shutdown_write_leaves_the_chip_running() {
    let mut mock = power_up(Script::new()).burst(BURST).mock();
    // init is 87 transactions (see motion.rs); the shutdown write is the 88th.
    let mut s = FlowSensor::new(
        FaultySpi::new(mock.clone(), 87),
        NoopDelay::new(),
        Variant::Pmw3901,
    );
    s.init().unwrap();
    assert_eq!(s.shutdown(), Err(Error::Spi(ErrorKind::Other)));
    assert_eq!(s.mode(), Mode::Motion);
    assert!(s.read_flow(Timestamp(1)).is_ok());
    mock.done();
}

#[test]
fn a_wake_that_finds_the_wrong_chip_is_an_error() {
    let mut spi = power_up(Script::new())
        .w(0x3B, 0xB6)
        .w(0x3A, 0x5A)
        .r(0x00, 0x00)
        .r(0x5F, 0x00)
        .mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    s.init().unwrap();
    s.shutdown().unwrap();
    assert_eq!(
        s.wake(),
        Err(Error::WrongProductId {
            product_id: 0x00,
            inverse_product_id: 0x00
        })
    );
    assert_eq!(s.mode(), Mode::Uninitialised);
    assert_eq!(s.read_flow(Timestamp(1)), Err(Error::NotInMotionMode));
    spi.done();
}
