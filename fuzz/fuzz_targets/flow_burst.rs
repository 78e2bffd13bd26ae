//! PMW3901MB / PAA5100JE: Motion_Burst decoding, and the driver (power-up,
//! motion reports with every rotation, raw frame grab) over a bus whose
//! answers, and failures, come from the fuzzer.
#![no_main]

use flow_sensor::{Error, FlowSensor, Mode, MotionBurst, Rotation, Variant};
use libfuzzer_sys::fuzz_target;
use traction_fuzz::{NoDelay, ScriptedSpi};
use vslam_core::Timestamp;
use vslam_core::sensors::FLOW_FRAME_LEN;

fuzz_target!(|data: &[u8]| {
    // The decoder on every 12-byte window, against the datasheet's table
    // (restated here: deltas low byte first, shutter high byte first).
    for chunk in data.chunks_exact(12) {
        let Ok(b) = <&[u8; 12]>::try_from(chunk) else {
            return;
        };
        let m = MotionBurst::from_bytes(b);
        assert_eq!(m.motion, b[0]);
        assert_eq!(m.delta_x, i16::from_le_bytes([b[2], b[3]]));
        assert_eq!(m.delta_y, i16::from_le_bytes([b[4], b[5]]));
        assert_eq!(m.squal, b[6]);
        assert_eq!(m.shutter, u16::from_be_bytes([b[10], b[11]]));
        let s = m.to_sample(Timestamp(7));
        assert_eq!(
            (s.dx, s.dy, s.motion),
            (m.delta_x, m.delta_y, b[0] & 0x80 != 0)
        );
        assert_eq!(m.is_valid(), s.is_valid());
        for r in [
            Rotation::Deg0,
            Rotation::Deg90,
            Rotation::Deg180,
            Rotation::Deg270,
        ] {
            let (x, y) = r.apply(s.dx, s.dy);
            // A quarter turn keeps the length, up to i16::MIN negated to
            // i16::MAX (32768^2 - 32767^2 = 65535 per component).
            let len = |a: i16, b: i16| i64::from(a).pow(2) + i64::from(b).pow(2);
            assert!((len(x, y) - len(s.dx, s.dy)).abs() <= 2 * 65535);
            assert_eq!(
                x.unsigned_abs().max(y.unsigned_abs()) >= 32767,
                s.dx.unsigned_abs().max(s.dy.unsigned_abs()) >= 32767
            );
        }
    }

    // The driver over the scripted bus.
    let Some((&head, script)) = data.split_first() else {
        return;
    };
    let variant = if head & 1 == 0 {
        Variant::Pmw3901
    } else {
        Variant::Paa5100je
    };
    let rotation = [
        Rotation::Deg0,
        Rotation::Deg90,
        Rotation::Deg180,
        Rotation::Deg270,
    ][usize::from(head >> 1) & 3];
    let reports = usize::from(head >> 3);
    let mut sensor = FlowSensor::new(ScriptedSpi::new(script), NoDelay, variant);
    sensor.set_rotation(rotation);
    assert!(matches!(
        sensor.read_sample(Timestamp(0)),
        Err(Error::NotInMotionMode)
    ));
    match sensor.init() {
        Ok(()) => assert_eq!(sensor.mode(), Mode::Motion),
        Err(_) => {
            assert_eq!(sensor.mode(), Mode::Uninitialised);
            assert!(matches!(
                sensor.read_sample(Timestamp(0)),
                Err(Error::NotInMotionMode)
            ));
            return;
        }
    }
    for i in 0..reports {
        let t = Timestamp(i as u64 * 10_000_000);
        match sensor.read_sample(t) {
            Ok(s) => assert_eq!(s.t, t),
            Err(Error::Spi(_)) => {}
            Err(e) => panic!("a motion read can only fail on the bus: {e:?}"),
        }
    }
    let mut frame = [0u8; FLOW_FRAME_LEN];
    let grabbed = sensor.capture_frame(&mut frame);
    if let Err(Error::FrameTimeout { pixels }) = grabbed {
        assert!(usize::from(pixels) < FLOW_FRAME_LEN);
    }
    if sensor.mode() == Mode::RawFrame {
        assert!(matches!(
            sensor.read_sample(Timestamp(1)),
            Err(Error::NotInMotionMode)
        ));
    }
});
