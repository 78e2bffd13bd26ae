//! Raw 35x35 frame grab: the register sequence of Pimoroni's
//! `frame_capture`, pixel reassembly from tagged halves, bounded polls.

mod common;

use common::{PMW3901_WRITES, Script};
use embedded_hal_mock::eh1::delay::NoopDelay;
use flow_sensor::{Error, FlowSensor, Mode, Variant};
use vslam_core::Timestamp;
use vslam_core::sensors::FlowFrameSource;

const PIXELS: usize = 35 * 35;

fn init_script() -> Script {
    Script::new()
        .reset_and_id()
        .clear_motion()
        .ws(PMW3901_WRITES)
        .r(0x5B, 0xA0)
        .clear_motion()
}

fn setup(s: Script) -> Script {
    s.ws(&[
        (0x7F, 0x07),
        (0x4C, 0x00),
        (0x7F, 0x08),
        (0x6A, 0x38),
        (0x7F, 0x00),
        (0x55, 0x04),
        (0x40, 0x80),
        (0x4D, 0x11),
        (0x7F, 0x00),
    ])
    .w(0x58, 0xFF)
}

fn pixel(i: usize) -> u8 {
    (i * 37 % 251) as u8
}

#[test]
fn frame_capture_reassembles_every_pixel() {
    let mut s = setup(init_script())
        .r(0x59, 0x00)
        .r(0x59, 0x00)
        .r(0x59, 0x80)
        .w(0x58, 0x00);
    for i in 0..PIXELS {
        let p = pixel(i);
        if i % 100 == 0 {
            // not-ready bytes (tags 00 and 11) are skipped
            s = s.r(0x58, 0x00).r(0x58, 0xFF);
        }
        s = s.r(0x58, 0x40 | (p >> 2)).r(0x58, 0x80 | ((p & 0b11) << 2));
    }
    let mut spi = s.mock();
    let mut drv = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    drv.init().unwrap();
    let mut frame = [0u8; PIXELS];
    drv.grab_frame(&mut frame).unwrap();
    for (i, &p) in frame.iter().enumerate() {
        assert_eq!(p, pixel(i), "pixel {i}");
    }
    assert_eq!(drv.mode(), Mode::RawFrame);
    // Motion registers are meaningless in raw-data mode: refused, no bus traffic.
    use vslam_core::sensors::FlowSource;
    assert_eq!(drv.read_flow(Timestamp(3)), Err(Error::NotInMotionMode));
    spi.done();
}

#[test]
fn grab_status_that_never_becomes_ready_times_out() {
    let mut s = setup(init_script());
    for _ in 0..10_000 {
        s = s.r(0x59, 0x3F);
    }
    let mut spi = s.mock();
    let mut drv = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    drv.init().unwrap();
    let mut frame = [0u8; PIXELS];
    assert_eq!(drv.capture_frame(&mut frame), Err(Error::FrameNotReady));
    spi.done();
}

#[test]
fn a_stalled_pixel_stream_times_out_with_the_count() {
    let mut s = setup(init_script()).r(0x59, 0x40).w(0x58, 0x00);
    // Three good pixels, then only not-ready bytes until the read budget
    // (35 * 35 * 2 * 4 reads) is spent.
    let budget = PIXELS * 2 * 4;
    for _ in 0..3 {
        s = s.r(0x58, 0x40 | 0x3F).r(0x58, 0x80 | 0x0C);
    }
    for _ in 0..budget - 6 {
        s = s.r(0x58, 0xC0);
    }
    let mut spi = s.mock();
    let mut drv = FlowSensor::new(spi.clone(), NoopDelay::new(), Variant::Pmw3901);
    drv.init().unwrap();
    let mut frame = [0u8; PIXELS];
    assert_eq!(
        drv.capture_frame(&mut frame),
        Err(Error::FrameTimeout { pixels: 3 })
    );
    assert_eq!(&frame[..4], &[0xFF, 0xFF, 0xFF, 0x00]);
    spi.done();
}
