//! No input panics: a crude register-file chip answers the driver with
//! arbitrary Motion_Burst and RawData_Grab bytes.

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::delay::NoopDelay;
use flow_sensor::{Error, FlowSensor, Variant};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use vslam_core::Timestamp;
use vslam_core::sensors::{FlowFrameSource, FlowSource};

/// Registers as a flat file (banks folded together), identity fixed,
/// bursts and grab bytes drawn from `noise`.
struct RegisterFileChip {
    regs: [u8; 128],
    noise: Vec<u8>,
    next: usize,
    address: Option<u8>,
}

impl RegisterFileChip {
    fn new(noise: Vec<u8>) -> Self {
        RegisterFileChip {
            regs: [0; 128],
            noise,
            next: 0,
            address: None,
        }
    }
    fn noise(&mut self) -> u8 {
        if self.noise.is_empty() {
            return 0;
        }
        let b = self.noise[self.next % self.noise.len()];
        self.next += 1;
        b
    }
    fn read(&mut self, reg: u8) -> u8 {
        match reg {
            0x00 => 0x49,
            0x5F => 0xB6,
            0x16 | 0x58 | 0x59 => self.noise(),
            r => self.regs[usize::from(r & 0x7F)],
        }
    }
}

impl ErrorType for RegisterFileChip {
    type Error = ErrorKind;
}

impl SpiDevice for RegisterFileChip {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        self.address = None;
        for op in ops {
            match op {
                Operation::Write(bytes) => match (bytes.first(), bytes.get(1)) {
                    (Some(&a), Some(&v)) if a & 0x80 != 0 => self.regs[usize::from(a & 0x7F)] = v,
                    (Some(&a), None) => self.address = Some(a),
                    _ => return Err(ErrorKind::Other),
                },
                Operation::TransferInPlace(buf) | Operation::Read(buf) => {
                    let reg = self.address.ok_or(ErrorKind::Other)?;
                    for b in buf.iter_mut() {
                        *b = self.read(reg);
                    }
                }
                Operation::DelayNs(_) => {}
                Operation::Transfer(_, _) => return Err(ErrorKind::Other),
            }
        }
        Ok(())
    }
}

proptest! {
    #![proptest_config(ProptestConfig { rng_seed: RngSeed::Fixed(3901), cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_chip_answers_never_panic(noise in prop::collection::vec(any::<u8>(), 0..64),
                                          paa in any::<bool>()) {
        let variant = if paa { Variant::Paa5100je } else { Variant::Pmw3901 };
        let mut s = FlowSensor::new(RegisterFileChip::new(noise), NoopDelay::new(), variant);
        s.init().unwrap();
        for i in 0..8 {
            let sample = s.read_flow(Timestamp(i)).unwrap();
            prop_assert_eq!(sample.t, Timestamp(i));
        }
        let mut frame = [0u8; 1225];
        match s.grab_frame(&mut frame) {
            Ok(()) | Err(Error::FrameNotReady) | Err(Error::FrameTimeout { .. }) => {}
            Err(e) => prop_assert!(false, "unexpected {e:?}"),
        }
    }
}
