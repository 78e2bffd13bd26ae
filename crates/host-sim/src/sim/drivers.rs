//! The simulated readings pass through the real drivers: flow reports go
//! into a register-level PAA5100JE simulator and come out of the
//! `flow-sensor` driver's Motion_Burst decoding; wheel angles go into two
//! AS5047P simulators (the right one mounted mirrored) and come out of the
//! `wheel-odom` driver's framing, parity checks and multi-turn unwrapping.

use super::flow_frames::RawFrame;
use crate::chips::as5047p::{EncoderFault, EncoderSim};
use crate::chips::pmw3901::{FlowChipFault, FlowChipSim};
use crate::chips::{NoDelay, Shared};
use crate::error::CliError;
use crate::faults::chip::{ChipSchedule, FailedRead};
use crate::faults::{FaultKind, FaultPlan, FaultSpec, SpoiledSample, Stream};
use std::path::Path;
use traction::flow_sensor::{FlowSensor, Variant};
use traction::vslam_core::Reject;
use traction::vslam_core::sensors::{
    FLOW_FRAME_LEN, FlowFrameSource, FlowSample, FlowSource, WheelEncoderSource, WheelTicks,
};
use traction::wheel_odom::as5047p::{As5047p, As5047pError};
use traction::wheel_odom::encoder::{As5047pEncoder, EncoderError, PairError, Polarity, WheelPair};

/// AS5047P counts per wheel revolution.
pub const ENCODER_COUNTS: f64 = 16_384.0;

fn driver_error(what: &str, e: impl std::fmt::Debug) -> CliError {
    CliError::file(Path::new("<simulated bus>"), format!("{what}: {e:?}"))
}

/// Passes synthesized flow reports through the chip simulator and the driver.
pub fn flow_through_driver(reports: &[FlowSample]) -> Result<Vec<FlowSample>, CliError> {
    flow_through_driver_with(reports, &FaultPlan::none()).map(|r| r.samples)
}

/// What reading a sensor through its driver gave under a fault plan.
#[derive(Clone, Debug, Default)]
pub struct DriverReads<S> {
    /// The samples read.
    pub samples: Vec<S>,
    /// Reads that failed (no sample).
    pub failed: Vec<FailedRead>,
    /// Samples read but spoiled by a chip fault.
    pub spoiled: Vec<SpoiledSample>,
}

/// The real flow-sensor driver on a simulated chip.
type SimFlowSensor = FlowSensor<Shared<FlowChipSim>, NoDelay>;

/// A simulated PAA5100JE behind the real driver, powered up: the chip's
/// handle (to move the floor under it) and the driver.
fn powered_flow_sensor() -> Result<(Shared<FlowChipSim>, SimFlowSensor), CliError> {
    let chip = Shared::new(FlowChipSim::new());
    let handle = chip.handle();
    let mut sensor = FlowSensor::new(chip, NoDelay, Variant::Paa5100je);
    sensor
        .init()
        .map_err(|e| driver_error("flow sensor power-up", e))?;
    Ok((handle, sensor))
}

/// [`flow_through_driver`] with the flow chip faults of `plan` injected into
/// the simulator. The read loop does what firmware does: a failed read is
/// counted with its reason; a burst of all zeros (a running chip never has
/// shutter 0) makes it check the product id, and a wrong id is an integrity
/// failure followed by a power-up reset.
pub fn flow_through_driver_with(
    reports: &[FlowSample],
    plan: &FaultPlan,
) -> Result<DriverReads<FlowSample>, CliError> {
    let (handle, mut sensor) = powered_flow_sensor()?;
    let mut faults = ChipSchedule::new(plan, Stream::Flow);
    let mut out = DriverReads {
        samples: Vec::with_capacity(reports.len()),
        ..DriverReads::default()
    };
    for r in reports {
        {
            let mut c = handle.0.borrow_mut();
            c.add_motion(r.dx as i64, r.dy as i64);
            c.set_quality(r.squal, r.shutter);
            if let Some((_, kind)) = faults.at(r.t) {
                c.inject(match kind {
                    FaultKind::FlowBrownout => FlowChipFault::Brownout,
                    _ => FlowChipFault::BusErrors(1),
                });
            }
        }
        let fault = faults.current();
        let read = sensor.read_flow(r.t).and_then(|s| {
            if s.shutter == 0 && s.squal == 0 {
                let (id, inverse) = sensor.read_product_id()?;
                if (id, inverse) != (0x49, 0xB6) {
                    return Err(traction::flow_sensor::Error::WrongProductId {
                        product_id: id,
                        inverse_product_id: inverse,
                    });
                }
            }
            Ok(s)
        });
        match read {
            Ok(mut s) => {
                if !s.is_valid() {
                    // The log convention: an invalid report carries no counts.
                    s.dx = 0;
                    s.dy = 0;
                }
                out.samples.push(s);
            }
            Err(e) => {
                let (reason, reset) = match e {
                    traction::flow_sensor::Error::Spi(_) => (Reject::Bus, false),
                    _ => (Reject::Integrity, true),
                };
                let Some(fault) = fault else {
                    return Err(driver_error("flow sensor read", e));
                };
                out.failed.push(FailedRead {
                    t: r.t,
                    stream: Stream::Flow,
                    reason,
                    fault,
                });
                if reset {
                    sensor
                        .init()
                        .map_err(|e| driver_error("flow sensor reset", e))?;
                }
            }
        }
    }
    Ok(out)
}

/// The flow sensor's raw frames through the chip simulator's frame-grab
/// registers (RawData_Grab, RawData_Grab_Status) and the driver's
/// [`FlowFrameSource::grab_frame`]. A chip of its own: the counting reports
/// of [`flow_through_driver`] come from another simulated chip, as a grab
/// leaves the chip in raw-data mode until the next power-up.
pub struct FrameGrabber {
    chip: std::rc::Rc<std::cell::RefCell<FlowChipSim>>,
    sensor: SimFlowSensor,
}

impl FrameGrabber {
    /// A powered-up sensor.
    pub fn new() -> Result<Self, CliError> {
        let (handle, sensor) = powered_flow_sensor()?;
        Ok(FrameGrabber {
            chip: handle.0,
            sensor,
        })
    }

    /// Puts `frame` in front of the chip and grabs it through the driver.
    pub fn grab(&mut self, frame: &RawFrame) -> Result<[u8; FLOW_FRAME_LEN], CliError> {
        self.chip.borrow_mut().set_frame(&frame.pixels);
        let mut out = [0u8; FLOW_FRAME_LEN];
        self.sensor
            .grab_frame(&mut out)
            .map_err(|e| driver_error("flow frame grab", e))?;
        Ok(out)
    }
}

/// Reads cumulative counts from two simulated AS5047P encoders at each of
/// `samples` (time, left angle, right angle in radians).
pub fn wheels_through_driver(
    samples: &[(traction::vslam_core::Timestamp, f64, f64)],
) -> Result<Vec<WheelTicks>, CliError> {
    wheels_through_driver_with(samples, &FaultPlan::none()).map(|r| r.samples)
}

/// The largest count step between two encoder reads the firmware accepts:
/// a quarter turn (11 m/s at 50 Hz on 35 mm wheels, far above any robot
/// vacuum), well inside the 14-bit angle's half-turn aliasing limit, so the
/// counter extension refuses an aliased read as a jump.
pub const MAX_COUNTS_PER_READ: u32 = 4096;

/// Turns per read a free-spinning wheel adds in a [`FaultKind::WheelWrap`]:
/// more than half a turn, so the 14-bit angle aliases backwards.
pub const WRAP_TURNS_PER_READ: f64 = 0.6;

/// [`wheels_through_driver`] with the encoder faults of `plan` injected into
/// the left encoder's simulator. A failed read is counted with its reason
/// (SPI: bus; parity or error flag: integrity) and leaves no sample.
pub fn wheels_through_driver_with(
    samples: &[(traction::vslam_core::Timestamp, f64, f64)],
    plan: &FaultPlan,
) -> Result<DriverReads<WheelTicks>, CliError> {
    let left = Shared::new(EncoderSim::new());
    let right = Shared::new(EncoderSim::new());
    let (lh, rh) = (left.handle(), right.handle());
    let enc = |spi, polarity| {
        As5047pEncoder::new(As5047p::new(spi), polarity, Some(MAX_COUNTS_PER_READ))
            .map_err(|e| driver_error("encoder setup", e))
    };
    let mut pair = WheelPair::new(
        enc(left, Polarity::Normal)?,
        enc(right, Polarity::Reversed)?,
    );
    let mut faults = ChipSchedule::new(plan, Stream::Wheel);
    let wraps: Vec<(usize, FaultSpec)> = plan
        .select(|f| f.kind == FaultKind::WheelWrap)
        .map(|(i, f)| (i, *f))
        .collect();
    let mut extra_turns = 0.0f64;
    let mut out = DriverReads {
        samples: Vec::with_capacity(samples.len()),
        ..DriverReads::default()
    };
    // The wrap fault of the previous read: the read right after a wrap
    // window still sees its last jump.
    let mut previous_wrap: Option<usize> = None;
    for (t, l, r) in samples {
        let wrapping = wraps.iter().find(|(_, f)| f.covers(t.0)).map(|(i, _)| *i);
        let spill = previous_wrap.filter(|_| wrapping.is_none());
        previous_wrap = wrapping;
        if wrapping.is_some() {
            extra_turns += WRAP_TURNS_PER_READ;
        }
        lh.0.borrow_mut()
            .set_angle_radians(*l + extra_turns * std::f64::consts::TAU);
        // Mounted mirrored: the right encoder turns backwards when the wheel rolls forward.
        rh.0.borrow_mut().set_angle_radians(-*r);
        if let Some((_, kind)) = faults.at(*t) {
            lh.0.borrow_mut().inject(match kind {
                FaultKind::WheelParity => EncoderFault::CorruptAnswer,
                FaultKind::WheelErrorFlag => EncoderFault::FramingError,
                _ => EncoderFault::BusErrors(1),
            });
        }
        let fault = faults.current();
        match pair.read_ticks(*t) {
            Ok(ticks) => {
                if let Some(f) = wrapping {
                    // A read the counter extension let through with the alias.
                    out.spoiled.push(SpoiledSample {
                        fault: f,
                        t: *t,
                        delivery: out.samples.len(),
                    });
                }
                out.samples.push(ticks);
            }
            Err(e) => {
                let source = match &e {
                    PairError::Left(EncoderError::Source(s))
                    | PairError::Right(EncoderError::Source(s)) => Some(s),
                    _ => None,
                };
                // SPI: bus; parity, error flag: integrity; a refused jump of
                // the counter extension: out of range.
                let reason = match source {
                    Some(As5047pError::Spi(_)) => Reject::Bus,
                    Some(_) => Reject::Integrity,
                    None => Reject::OutOfRange,
                };
                let Some(fault) = fault.or(wrapping).or(spill) else {
                    return Err(driver_error("encoder read", e));
                };
                out.failed.push(FailedRead {
                    t: *t,
                    stream: Stream::Wheel,
                    reason,
                    fault,
                });
            }
        }
    }
    Ok(out)
}

/// The two encoders read one sample at a time, through the driver as in
/// [`wheels_through_driver`] (no faults): for a closed loop, where the wheel
/// angles of the next read depend on what the last ones made the robot do.
pub struct Encoders {
    left: std::rc::Rc<std::cell::RefCell<EncoderSim>>,
    right: std::rc::Rc<std::cell::RefCell<EncoderSim>>,
    pair: WheelPair<As5047pEncoder<Shared<EncoderSim>>, As5047pEncoder<Shared<EncoderSim>>>,
}

impl Encoders {
    /// Both encoders powered up.
    pub fn new() -> Result<Self, CliError> {
        let left = Shared::new(EncoderSim::new());
        let right = Shared::new(EncoderSim::new());
        let (lh, rh) = (left.handle(), right.handle());
        let enc = |spi, polarity| {
            As5047pEncoder::new(As5047p::new(spi), polarity, Some(MAX_COUNTS_PER_READ))
                .map_err(|e| driver_error("encoder setup", e))
        };
        Ok(Encoders {
            left: lh.0,
            right: rh.0,
            pair: WheelPair::new(
                enc(left, Polarity::Normal)?,
                enc(right, Polarity::Reversed)?,
            ),
        })
    }

    /// Reads both encoders at `t` with the wheels at angles `l`, `r` (radians).
    pub fn read(
        &mut self,
        t: traction::vslam_core::Timestamp,
        l: f64,
        r: f64,
    ) -> Result<WheelTicks, CliError> {
        self.left.borrow_mut().set_angle_radians(l);
        // Mounted mirrored: the right encoder turns backwards when the wheel rolls forward.
        self.right.borrow_mut().set_angle_radians(-r);
        self.pair
            .read_ticks(t)
            .map_err(|e| driver_error("encoder read", e))
    }
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
