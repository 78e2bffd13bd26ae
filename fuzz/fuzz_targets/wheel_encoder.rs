//! AS5047P: 16-bit frames, parity and error-flag handling, the pipelined
//! angle + diagnostics read, and the wrapping counter's extension to `i64`;
//! then differential-drive odometry on the counts, and on wheel angular
//! rates (the `wheel0` rates variant's path) read from the same bytes as
//! `(ms step, left f32, right f32)`. Bus answers and failures come from the
//! fuzzer.
#![no_main]

use libfuzzer_sys::fuzz_target;
use traction_fuzz::ScriptedSpi;
use vslam_core::Timestamp;
use vslam_core::sensors::{RawWheelRates, WheelTicks};
use wheel_odom::as5047p::{As5047p, As5047pError, has_even_parity, read_command, with_even_parity};
use wheel_odom::counter::{CounterError, CounterExtender};
use wheel_odom::encoder::{As5047pEncoder, CumulativeEncoder, EncoderError, Polarity};
use wheel_odom::odometry::{DiffDriveOdometry, DiffDriveParams};

fn take<const N: usize>(data: &mut &[u8]) -> Option<[u8; N]> {
    let (head, rest) = data.split_first_chunk::<N>()?;
    *data = rest;
    Some(*head)
}

fuzz_target!(|input: &[u8]| {
    let mut data = input;
    let Some([mode, bits, step_hi, step_lo]) = take::<4>(&mut data) else {
        return;
    };

    // Parity helpers: every frame made even is even, and the command frames too.
    for w in data.chunks_exact(2) {
        let word = u16::from_be_bytes([w[0], w[1]]);
        assert!(has_even_parity(with_even_parity(word)));
        assert!(has_even_parity(read_command(word)));
        assert_eq!(with_even_parity(word) & 0x7FFF, word & 0x7FFF);
    }

    // The counter extender on a raw stream, against its contract: an accepted
    // reading moves the position by at most `max_step`; between refused
    // jumps the position stays congruent to the raw value (the first reading
    // is the origin), and a refused jump of `delta` holds the position while
    // re-anchoring on the new raw value, shifting that residue by `-delta`.
    let bits = 2 + bits % 31;
    if let Ok(ext) = CounterExtender::new(bits) {
        let max_step = u32::from_be_bytes([0, 0, step_hi, step_lo]);
        let mut ext = ext.with_max_step(max_step).unwrap_or(ext);
        let modulus = 1i128 << bits;
        let mut previous: Option<i64> = None;
        let mut residue = 0i128;
        let mut jumps = 0u32;
        for w in data.chunks_exact(4) {
            let raw = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
            let raw = if mode & 1 == 0 { raw & ext.mask() } else { raw };
            match ext.update(raw) {
                Ok(p) => {
                    let r = (i128::from(p) - i128::from(raw)).rem_euclid(modulus);
                    assert_eq!(r, residue, "position {p}, raw {raw}");
                    if let Some(q) = previous {
                        assert!(p.abs_diff(q) <= u64::from(ext.max_step()));
                    }
                    previous = Some(p);
                }
                Err(CounterError::OutOfRange { raw: r }) => assert!(r > ext.mask()),
                Err(CounterError::Jump { delta }) => {
                    jumps += 1;
                    assert!(delta.unsigned_abs() > u64::from(ext.max_step()));
                    residue = (residue - i128::from(delta)).rem_euclid(modulus);
                    assert_eq!(ext.last_raw(), Some(raw));
                }
            }
        }
        assert_eq!(ext.jumps(), jumps);
    }

    // The encoder driver over the scripted bus.
    let polarity = if mode & 2 == 0 {
        Polarity::Normal
    } else {
        Polarity::Reversed
    };
    let max_step = (mode & 4 != 0).then_some(u32::from(step_lo) + 1);
    let Ok(enc) = As5047pEncoder::new(As5047p::new(ScriptedSpi::new(data)), polarity, max_step)
    else {
        return;
    };
    let mut enc = enc.with_magnet_check(mode & 8 != 0);
    let mut counts = Vec::new();
    for i in 0..64u64 {
        match enc.read_count() {
            Ok(c) => {
                assert!(enc.angle_rad().is_finite());
                counts.push(WheelTicks {
                    t: Timestamp(i * 20_000_000),
                    left: c,
                    right: c / 2,
                });
            }
            Err(EncoderError::Source(As5047pError::Parity { frame })) => {
                assert!(!has_even_parity(frame));
            }
            Err(EncoderError::Source(As5047pError::AngleInvalid(d))) => {
                assert!(d.cordic_overflow);
            }
            Err(_) => {}
        }
    }

    // Odometry on those counts: every step finite.
    let Ok(params) = DiffDriveParams::new(16_384, 0.035, 0.0351, 0.23, 3.0, 500_000_000) else {
        return;
    };
    let mut odo = DiffDriveOdometry::new(params);
    for ticks in counts {
        if let Ok(Some(step)) = odo.update(ticks) {
            assert!(step.delta.translation.iter().all(|v| v.is_finite()));
            assert!(step.delta.dyaw.is_finite());
        }
    }

    // Odometry on wheel rates: every accepted step finite, its rates those
    // given and within the rim speed; every sample counted once.
    let mut odo = DiffDriveOdometry::new(params);
    let mut t = 0u64;
    let mut n = 0u32;
    for w in input.chunks_exact(10) {
        t += u64::from(u16::from_le_bytes([w[0], w[1]])) * 1_000_000;
        let left = f32::from_le_bytes([w[2], w[3], w[4], w[5]]);
        let right = f32::from_le_bytes([w[6], w[7], w[8], w[9]]);
        n += 1;
        if let Ok(Some(step)) = odo.update_rates(RawWheelRates { t: Timestamp(t), left, right }) {
            assert!(step.delta.translation.iter().all(|v| v.is_finite()));
            assert!(step.delta.dyaw.is_finite() && step.delta.path_length.is_finite());
            assert_eq!((step.rates.left(), step.rates.right()), (left, right));
            assert!((0.035 * left.abs()).max(0.0351 * right.abs()) <= 3.0 * 1.0001);
        }
    }
    assert_eq!(odo.counts().seen(), n);
});
