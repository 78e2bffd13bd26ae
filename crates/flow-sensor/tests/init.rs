//! Power-up bus scripts for both variants, and the ways power-up fails.

mod common;

use common::{FaultySpi, PAA5100_WRITES, PMW3901_WRITES, Script};
use embedded_hal::spi::ErrorKind;
use embedded_hal_mock::eh1::delay::NoopDelay;
use flow_sensor::{Error, FlowSensor, Mode, Variant};

fn pmw3901_init_script() -> Script {
    Script::new()
        .reset_and_id()
        .clear_motion()
        .ws(PMW3901_WRITES)
        .r(0x5B, 0xA0)
        .clear_motion()
}

#[test]
fn pmw3901_init_follows_the_datasheet_sequence() {
    let mut spi = pmw3901_init_script().mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    assert_eq!(s.mode(), Mode::Uninitialised);
    s.init().unwrap();
    assert_eq!(s.mode(), Mode::Motion);
    spi.done();
}

#[test]
fn paa5100_init_adjusts_the_trims_when_0x73_reads_zero() {
    let script = Script::new()
        .reset_and_id()
        .clear_motion()
        // calibration prologue, part 1
        .ws(&[
            (0x7F, 0x00),
            (0x55, 0x01),
            (0x50, 0x07),
            (0x7F, 0x0E),
            (0x43, 0x10),
        ])
        .r(0x67, 0x80)
        .w(0x48, 0x04)
        .ws(&[
            (0x7F, 0x00),
            (0x51, 0x7B),
            (0x50, 0x00),
            (0x55, 0x00),
            (0x7F, 0x0E),
        ])
        .r(0x73, 0x00)
        .r(0x70, 20)
        .r(0x71, 100)
        .ws(&[(0x7F, 0x00), (0x61, 0xAD), (0x51, 0x70), (0x7F, 0x0E)])
        // C1 = 20 + 14, C2 = 100 * 45 / 100
        .w(0x70, 34)
        .w(0x71, 45)
        .ws(PAA5100_WRITES)
        .r(0x5B, 0xA0)
        .r(0x4E, 0xA8)
        .clear_motion();
    let mut spi = script.mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Paa5100je);
    s.init().unwrap();
    spi.done();
}

#[test]
fn paa5100_init_keeps_the_trims_when_0x73_is_set() {
    let script = Script::new()
        .reset_and_id()
        .clear_motion()
        .ws(&[
            (0x7F, 0x00),
            (0x55, 0x01),
            (0x50, 0x07),
            (0x7F, 0x0E),
            (0x43, 0x10),
        ])
        .r(0x67, 0x00)
        .w(0x48, 0x02)
        .ws(&[
            (0x7F, 0x00),
            (0x51, 0x7B),
            (0x50, 0x00),
            (0x55, 0x00),
            (0x7F, 0x0E),
        ])
        .r(0x73, 0x01)
        .ws(PAA5100_WRITES)
        .r(0x5B, 0xA0)
        .r(0x4E, 0xA8)
        .clear_motion();
    let mut spi = script.mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Paa5100je);
    s.init().unwrap();
    spi.done();
}

#[test]
fn wrong_product_id_stops_power_up() {
    let mut spi = Script::new()
        .w(0x3A, 0x5A)
        .r(0x00, 0x49)
        .r(0x5F, 0x00)
        .mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    assert_eq!(
        s.init(),
        Err(Error::WrongProductId {
            product_id: 0x49,
            inverse_product_id: 0x00
        })
    );
    assert_eq!(s.mode(), Mode::Uninitialised);
    spi.done();
}

#[test]
fn a_dead_bus_reads_as_wrong_id() {
    let mut spi = Script::new()
        .w(0x3A, 0x5A)
        .r(0x00, 0xFF)
        .r(0x5F, 0xFF)
        .mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Paa5100je);
    assert!(matches!(
        s.init(),
        Err(Error::WrongProductId {
            product_id: 0xFF,
            ..
        })
    ));
    spi.done();
}

#[test]
fn configuration_readback_mismatch_is_reported() {
    let mut spi = Script::new()
        .reset_and_id()
        .clear_motion()
        .ws(PMW3901_WRITES)
        .r(0x5B, 0x00)
        .mock();
    let mut s = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    assert_eq!(
        s.init(),
        Err(Error::ConfigMismatch {
            register: 0x5B,
            expected: 0xA0,
            read: 0x00
        })
    );
    assert!(s.read_motion_burst().is_err());
    spi.done();
}

#[test]
fn bus_error_on_the_reset_write() {
    let mut mock = Script::new().mock();
    let mut s = FlowSensor::new(
        FaultySpi::new(mock.clone(), 0),
        NoopDelay::new(),
        Variant::Pmw3901,
    );
    assert_eq!(s.init(), Err(Error::Spi(ErrorKind::Other)));
    mock.done();
}

#[test]
fn bus_error_in_the_middle_of_the_table() {
    // Reset, two id reads, five motion reads, then 10 table writes succeed;
    // the 11th table write fails.
    let ok = Script::new()
        .reset_and_id()
        .clear_motion()
        .ws(&PMW3901_WRITES[..10]);
    let mut mock = ok.mock();
    let spi = FaultySpi::new(mock.clone(), 1 + 2 + 5 + 10);
    let mut s = FlowSensor::new(spi, NoopDelay::new(), Variant::Pmw3901);
    assert_eq!(s.init(), Err(Error::Spi(ErrorKind::Other)));
    assert_eq!(s.mode(), Mode::Uninitialised);
    mock.done();
}

#[test]
fn errors_display() {
    let e: Error<ErrorKind> = Error::WrongProductId {
        product_id: 1,
        inverse_product_id: 2,
    };
    assert!(format!("{e}").contains("0x01"));
    let e: Error<ErrorKind> = Error::FrameTimeout { pixels: 7 };
    assert!(format!("{e}").contains('7'));
}

#[test]
fn power_up_waits_through_the_delay_provider() {
    use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as D};
    // PMW3901: 5 ms after reset, 100 ms inside the table.
    let mut spi = pmw3901_init_script().mock();
    let mut delay = CheckedDelay::new(&[D::delay_ms(5), D::delay_ms(100)]);
    let mut s = FlowSensor::new(spi.clone(), delay.clone(), Variant::Pmw3901);
    s.init().unwrap();
    spi.done();
    delay.done();
}

#[test]
fn paa5100_waits_through_the_delay_provider() {
    use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as D};
    let script = Script::new()
        .reset_and_id()
        .clear_motion()
        .ws(&[
            (0x7F, 0x00),
            (0x55, 0x01),
            (0x50, 0x07),
            (0x7F, 0x0E),
            (0x43, 0x10),
        ])
        .r(0x67, 0x00)
        .w(0x48, 0x02)
        .ws(&[
            (0x7F, 0x00),
            (0x51, 0x7B),
            (0x50, 0x00),
            (0x55, 0x00),
            (0x7F, 0x0E),
        ])
        .r(0x73, 0x01)
        .ws(PAA5100_WRITES)
        .r(0x5B, 0xA0)
        .r(0x4E, 0xA8)
        .clear_motion();
    let mut spi = script.mock();
    // 5 ms after reset, then the table's two 10 ms waits.
    let mut delay = CheckedDelay::new(&[D::delay_ms(5), D::delay_ms(10), D::delay_ms(10)]);
    let mut s = FlowSensor::new(spi.clone(), delay.clone(), Variant::Paa5100je);
    s.init().unwrap();
    spi.done();
    delay.done();
}
