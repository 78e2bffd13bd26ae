//! The simulated readings pass through the real drivers: flow reports go
//! into a register-level PAA5100JE simulator and come out of the
//! `flow-sensor` driver's Motion_Burst decoding; wheel angles go into two
//! AS5047P simulators (the right one mounted mirrored) and come out of the
//! `wheel-odom` driver's framing, parity checks and multi-turn unwrapping.

use crate::chips::as5047p::EncoderSim;
use crate::chips::pmw3901::FlowChipSim;
use crate::chips::{NoDelay, Shared};
use crate::error::CliError;
use std::path::Path;
use traction::flow_sensor::{FlowSensor, Variant};
use traction::vslam_core::sensors::{FlowSample, FlowSource, WheelEncoderSource, WheelTicks};
use traction::wheel_odom::as5047p::As5047p;
use traction::wheel_odom::encoder::{As5047pEncoder, Polarity, WheelPair};

/// AS5047P counts per wheel revolution.
pub const ENCODER_COUNTS: f64 = 16_384.0;

fn driver_error(what: &str, e: impl std::fmt::Debug) -> CliError {
    CliError::file(Path::new("<simulated bus>"), format!("{what}: {e:?}"))
}

/// Passes synthesized flow reports through the chip simulator and the driver.
pub fn flow_through_driver(reports: &[FlowSample]) -> Result<Vec<FlowSample>, CliError> {
    let chip = Shared::new(FlowChipSim::new());
    let handle = chip.handle();
    let mut sensor = FlowSensor::new(chip, NoDelay, Variant::Paa5100je);
    sensor
        .init()
        .map_err(|e| driver_error("flow sensor power-up", e))?;
    let mut out = Vec::with_capacity(reports.len());
    for r in reports {
        {
            let mut c = handle.0.borrow_mut();
            c.add_motion(r.dx as i64, r.dy as i64);
            c.set_quality(r.squal, r.shutter);
        }
        let mut s = sensor
            .read_flow(r.t)
            .map_err(|e| driver_error("flow sensor read", e))?;
        if !s.is_valid() {
            // The log convention: an invalid report carries no counts.
            s.dx = 0;
            s.dy = 0;
        }
        out.push(s);
    }
    Ok(out)
}

/// Reads cumulative counts from two simulated AS5047P encoders at each of
/// `samples` (time, left angle, right angle in radians).
pub fn wheels_through_driver(
    samples: &[(traction::vslam_core::Timestamp, f64, f64)],
) -> Result<Vec<WheelTicks>, CliError> {
    let left = Shared::new(EncoderSim::new());
    let right = Shared::new(EncoderSim::new());
    let (lh, rh) = (left.handle(), right.handle());
    let enc = |spi, polarity| {
        As5047pEncoder::new(As5047p::new(spi), polarity, None)
            .map_err(|e| driver_error("encoder setup", e))
    };
    let mut pair = WheelPair::new(
        enc(left, Polarity::Normal)?,
        enc(right, Polarity::Reversed)?,
    );
    let mut out = Vec::with_capacity(samples.len());
    for (t, l, r) in samples {
        lh.0.borrow_mut().set_angle_radians(*l);
        // Mounted mirrored: the right encoder turns backwards when the wheel rolls forward.
        rh.0.borrow_mut().set_angle_radians(-*r);
        out.push(
            pair.read_ticks(*t)
                .map_err(|e| driver_error("encoder read", e))?,
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use traction::vslam_core::Timestamp;

    #[test]
    fn encoders_unwrap_turns_through_the_driver() {
        let tau = std::f64::consts::TAU;
        // 3.3 turns forward on both wheels in 40 reads of a twelfth of a turn.
        let samples: Vec<_> = (0..=40)
            .map(|i| {
                (
                    Timestamp(i * 20_000_000),
                    i as f64 * tau / 12.0,
                    i as f64 * tau / 12.0,
                )
            })
            .collect();
        let ticks = wheels_through_driver(&samples).unwrap();
        let last = ticks.last().unwrap();
        let expected = (40.0 / 12.0 * ENCODER_COUNTS).floor() as i64;
        assert!((last.left - expected).abs() <= 1, "{last:?} vs {expected}");
        assert!((last.right - expected).abs() <= 2, "{last:?} vs {expected}");
    }

    #[test]
    fn flow_reports_survive_the_driver() {
        let reports: Vec<FlowSample> = (1..=5)
            .map(|i| FlowSample {
                t: traction::vslam_core::Timestamp(i * 10_000_000),
                dx: 3 * i as i16,
                dy: -(i as i16),
                squal: 90,
                shutter: 0x0200,
                motion: true,
                ..FlowSample::default()
            })
            .collect();
        let out = flow_through_driver(&reports).unwrap();
        for (a, b) in reports.iter().zip(&out) {
            assert_eq!(
                (a.t, a.dx, a.dy, a.squal, a.shutter),
                (b.t, b.dx, b.dy, b.squal, b.shutter)
            );
        }
    }
}
