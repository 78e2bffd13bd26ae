//! When wheel samples dead-reckon an IMU gap: which samples are taken, which
//! are refused (and why, counted), and when the result is used.
//!
//! The filter offers every wheel sample. One counts as *during a gap* when
//! its time stamp lies more than the IMU's longest step
//! (`ImuConfig::max_dt_ns`) after the filter's latest IMU time: the
//! IMU is late. The first such sample anchors the integration at that IMU
//! time (its rates are the average over the interval ending at it, which
//! covers the anchor); later ones extend it. Refused, counted in
//! [`GapOdometry::counts`], and left out of the integration:
//!
//! - rates whose integration overflows ([`Reject::NonFinite`]; the rates
//!   themselves are finite by type);
//! - a time stamp not after the previous integrated one
//!   ([`Reject::OutOfOrder`], [`Reject::Duplicate`]);
//! - a wheel speed above `GapConfig::max_wheel_speed`
//!   ([`Reject::OutOfRange`]); the next good sample covers its interval;
//! - an interval longer than `WheelConfig::max_dt_ns` ([`Reject::Gap`]):
//!   the wheels were silent too, and the gap is bridged without them;
//! - wheel geometry the filter cannot use (non-positive radius or track,
//!   [`Reject::Degenerate`]).
//!
//! Wheels that spin (or skid) measure a distance the robot did not drive.
//! When the flow sensor, recent and precise, sees a forward speed that the
//! sample's disagrees with (beyond three standard deviations of both, and
//! above 5 cm/s), the sample's rates are scaled to the flow's speed (a
//! symmetric spin inflates the yaw rate by the same factor) and its noise
//! becomes the flow's; counted in [`GapOdometry::slips`].
//!
//! When the IMU returns, [`GapOdometry::take`] hands over the motion if it
//! started at the gap's start and was never broken, after extrapolating the
//! last rates to the IMU's return (at most `WheelConfig::max_dt_ns`); otherwise
//! nothing, and the filter falls back to the constant-velocity bridge
//! ([`crate::gap::bridge_gap`]).

use vslam_core::kinematics::rim;
use vslam_core::scale::disagreement;
use vslam_core::sensors::WheelRates;
use vslam_core::time::nanos_to_seconds;
use vslam_core::{Reject, SampleCounts, Timestamp};

use crate::config::FilterConfig;
use crate::gap::dead_reckoning::{DeadReckoning, WheelGeometry};

/// A forward speed seen by another sensor (the flow), to check the wheels
/// against.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedWitness {
    /// Forward speed of the robot origin, m/s.
    pub speed: f32,
    /// Its standard deviation, m/s.
    pub std: f32,
}

/// Chi-square gate (1 DOF, three standard deviations) of the wheel-flow check.
const SLIP_GATE: f32 = 9.0;
/// Below this wheel speed, m/s, the wheels are not checked (turning in place).
const SLIP_MIN_SPEED: f32 = 0.05;

/// Wheel dead reckoning while the IMU is silent; see the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapOdometry {
    /// The IMU time the integration started from.
    anchor: Option<Timestamp>,
    /// Time of the latest integrated sample.
    last: Timestamp,
    /// Its rates `(left, right)`, rad/s.
    last_rates: (f32, f32),
    motion: DeadReckoning,
    samples: u32,
    broken: bool,
    counts: SampleCounts,
    slips: u32,
}

impl Default for GapOdometry {
    fn default() -> Self {
        Self::new()
    }
}

impl GapOdometry {
    /// Nothing integrated.
    pub const fn new() -> Self {
        GapOdometry {
            anchor: None,
            last: Timestamp(0),
            last_rates: (0.0, 0.0),
            motion: DeadReckoning::ZERO,
            samples: 0,
            broken: false,
            counts: SampleCounts::new(),
            slips: 0,
        }
    }

    /// Wheel samples integrated over gaps and refused by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Gap samples whose wheels disagreed with the flow and were scaled to it.
    pub fn slips(&self) -> u32 {
        self.slips
    }

    /// The motion integrated since the gap starting at `imu_last`, if any.
    pub fn motion_since(&self, imu_last: Timestamp) -> Option<&DeadReckoning> {
        (self.anchor == Some(imu_last) && self.samples > 0).then_some(&self.motion)
    }

    /// Whether a wheel sample at `t` counts as during a gap after the
    /// filter's latest IMU time `imu_last` (see the module docs), so that
    /// [`GapOdometry::offer`] would take it: the filter asks first and
    /// builds the geometry and the speed witness only then.
    pub fn during_gap(imu_last: Timestamp, t: Timestamp, config: &FilterConfig) -> bool {
        config.gap.wheels
            && t.nanos_since(imu_last)
                .is_some_and(|ahead| ahead > config.imu.max_dt_ns)
    }

    /// Offers a wheel sample, with the filter's latest IMU time and, if
    /// there is one, a witness of the forward speed. Returns `None` when the
    /// sample is not during a gap (nothing counted, see
    /// [`GapOdometry::during_gap`]), else the outcome (counted).
    pub fn offer(
        &mut self,
        imu_last: Timestamp,
        rates: &WheelRates,
        geometry: &WheelGeometry,
        witness: Option<SpeedWitness>,
        config: &FilterConfig,
    ) -> Option<Result<(), Reject>> {
        if !Self::during_gap(imu_last, rates.t(), config) {
            return None;
        }
        if self.anchor != Some(imu_last) {
            *self = GapOdometry {
                anchor: Some(imu_last),
                last: imu_last,
                counts: self.counts,
                slips: self.slips,
                ..GapOdometry::new()
            };
        }
        let outcome = self.integrate(rates, geometry, witness, config);
        self.counts.record(outcome);
        Some(outcome)
    }

    fn integrate(
        &mut self,
        rates: &WheelRates,
        geometry: &WheelGeometry,
        witness: Option<SpeedWitness>,
        config: &FilterConfig,
    ) -> Result<(), Reject> {
        let dt_ns = match rates.t().nanos_since(self.last) {
            None => return Err(Reject::OutOfOrder),
            Some(0) => return Err(Reject::Duplicate),
            Some(d) => d,
        };
        if !geometry.is_valid() {
            return Err(Reject::Degenerate);
        }
        let max = config.gap.max_wheel_speed;
        let wheel_speeds = [
            rim(geometry.radius_left, rates.left()),
            rim(geometry.radius_right, rates.right()),
        ];
        if wheel_speeds.iter().any(|v| libm::fabsf(*v) > max) {
            return Err(Reject::OutOfRange);
        }
        if dt_ns > config.wheel.max_dt_ns {
            self.broken = true;
            return Err(Reject::Gap);
        }
        let (mut left, mut right, mut geometry) = (rates.left(), rates.right(), *geometry);
        let (speed, _) = geometry.motion(left, right);
        if let Some(w) = witness.filter(|w| w.speed.is_finite() && w.std.is_finite()) {
            let wheel_var = 0.5 * geometry.forward_std * geometry.forward_std;
            if libm::fabsf(speed) > SLIP_MIN_SPEED
                && disagreement(speed, wheel_var, w.speed, w.std * w.std) > SLIP_GATE
            {
                let scale = w.speed / speed;
                left *= scale;
                right *= scale;
                geometry.forward_std = geometry.forward_std.max(w.std * libm::sqrtf(2.0));
                self.slips = self.slips.saturating_add(1);
            }
        }
        if !self
            .motion
            .step(&geometry, left, right, nanos_to_seconds(dt_ns))
        {
            return Err(Reject::NonFinite);
        }
        self.last = rates.t();
        self.last_rates = (left, right);
        self.samples = self.samples.saturating_add(1);
        Ok(())
    }

    /// The motion over the gap from `start` (the IMU time before it) to
    /// `end` (the IMU's return), if the wheels covered it (see the module
    /// docs). Whatever the answer, the integration is over.
    pub fn take(
        &mut self,
        start: Timestamp,
        end: Timestamp,
        geometry: &WheelGeometry,
        config: &FilterConfig,
    ) -> Option<DeadReckoning> {
        let usable = self.anchor == Some(start) && self.samples > 0 && !self.broken;
        self.anchor = None;
        if !usable || !geometry.is_valid() {
            return None;
        }
        let mut motion = self.motion;
        // The IMU may return a little before or after the latest wheel sample.
        match end.nanos_since(self.last) {
            Some(tail) if tail > config.wheel.max_dt_ns => return None,
            Some(tail) if tail > 0 => {
                let (l, r) = self.last_rates;
                if !motion.step(geometry, l, r, nanos_to_seconds(tail)) {
                    return None;
                }
            }
            _ => {}
        }
        Some(motion)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    fn fused(c: &SampleCounts) -> u32 {
        c.seen() - c.rejected_total()
    }

    fn geometry() -> WheelGeometry {
        WheelGeometry {
            radius_left: 0.035,
            radius_right: 0.035,
            track: 0.23,
            forward_std: 0.02,
            lateral_std: 0.01,
        }
    }

    fn rates(ms: u64, l: f32, r: f32) -> WheelRates {
        WheelRates::new(Timestamp(ms * MS), l, r).unwrap()
    }

    #[test]
    fn only_samples_during_a_gap_are_taken() {
        let c = FilterConfig::default();
        let mut o = GapOdometry::new();
        let imu = Timestamp(1000 * MS);
        // Within one IMU step of the filter time, or before it: not a gap.
        assert_eq!(
            o.offer(imu, &rates(1010, 8.0, 8.0), &geometry(), None, &c),
            None
        );
        assert_eq!(
            o.offer(imu, &rates(990, 8.0, 8.0), &geometry(), None, &c),
            None
        );
        // One IMU step (20 ms) late is not yet a gap.
        assert_eq!(
            o.offer(imu, &rates(1020, 8.0, 8.0), &geometry(), None, &c),
            None
        );
        assert_eq!(o.counts().seen(), 0);
        for k in 2..=25u64 {
            let got = o.offer(imu, &rates(1000 + 20 * k, 8.0, 8.0), &geometry(), None, &c);
            assert_eq!(got, Some(Ok(())));
        }
        let m = o
            .take(imu, Timestamp(1505 * MS), &geometry(), &c)
            .expect("covered");
        // 0.505 s at 0.28 m/s straight ahead.
        assert!((m.x - 0.28 * 0.505).abs() < 1e-4, "{}", m.x);
        assert!(m.psi.abs() < 1e-6);
        assert!((m.elapsed - 0.505).abs() < 1e-5);
        assert_eq!(fused(o.counts()), 24);
        // Taken once.
        assert_eq!(o.take(imu, Timestamp(1505 * MS), &geometry(), &c), None);
    }

    #[test]
    fn bad_samples_are_refused_with_their_reason() {
        let c = FilterConfig::default();
        let mut o = GapOdometry::new();
        let imu = Timestamp(0);
        let g = geometry();
        assert_eq!(
            o.offer(imu, &rates(40, 8.0, 8.0), &g, None, &c),
            Some(Ok(()))
        );
        // Rates the integration cannot hold (finite, but the step overflows).
        let wide = WheelGeometry {
            radius_left: 1.0e30,
            radius_right: 1.0e30,
            ..g
        };
        let mut huge_max = c;
        huge_max.gap.max_wheel_speed = f32::INFINITY;
        assert_eq!(
            o.offer(imu, &rates(60, 3.0e10, -3.0e10), &wide, None, &huge_max),
            Some(Err(Reject::NonFinite))
        );
        // Non-finite rates cannot be built at all.
        assert_eq!(
            WheelRates::new(Timestamp(60 * MS), f32::NAN, 8.0),
            Err(Reject::NonFinite)
        );
        let huge = rates(60, 1.0e6, 8.0);
        assert_eq!(
            o.offer(imu, &huge, &g, None, &c),
            Some(Err(Reject::OutOfRange))
        );
        let same = rates(40, 8.0, 8.0);
        assert_eq!(
            o.offer(imu, &same, &g, None, &c),
            Some(Err(Reject::Duplicate))
        );
        let older = rates(30, 8.0, 8.0);
        assert_eq!(
            o.offer(imu, &older, &g, None, &c),
            Some(Err(Reject::OutOfOrder))
        );
        let bad = WheelGeometry {
            track: f32::NAN,
            ..g
        };
        let ok = rates(80, 8.0, 8.0);
        assert_eq!(
            o.offer(imu, &ok, &bad, None, &c),
            Some(Err(Reject::Degenerate))
        );
        // The refused ones left the integration alone; a good one goes on.
        assert_eq!(o.offer(imu, &ok, &g, None, &c), Some(Ok(())));
        let counts = o.counts();
        assert_eq!(fused(counts), 2);
        assert_eq!(counts.rejected(Reject::NonFinite), 1);
        assert_eq!(counts.rejected(Reject::OutOfRange), 1);
        assert_eq!(counts.rejected(Reject::Duplicate), 1);
        assert_eq!(counts.rejected(Reject::OutOfOrder), 1);
        assert_eq!(counts.rejected(Reject::Degenerate), 1);
        let m = o.take(imu, Timestamp(80 * MS), &g, &c).expect("covered");
        assert!((m.x - 0.28 * 0.08).abs() < 1e-5, "{}", m.x);
    }

    #[test]
    fn silent_wheels_inside_the_gap_leave_it_to_the_fallback() {
        let c = FilterConfig::default();
        let mut o = GapOdometry::new();
        let imu = Timestamp(0);
        let g = geometry();
        assert_eq!(
            o.offer(imu, &rates(40, 8.0, 8.0), &g, None, &c),
            Some(Ok(()))
        );
        let late = rates(40 + 300, 8.0, 8.0);
        assert_eq!(o.offer(imu, &late, &g, None, &c), Some(Err(Reject::Gap)));
        assert_eq!(o.take(imu, Timestamp(400 * MS), &g, &c), None);
        // Wheels that stop before the IMU returns: the tail is too long.
        let mut o = GapOdometry::new();
        assert_eq!(
            o.offer(imu, &rates(40, 8.0, 8.0), &g, None, &c),
            Some(Ok(()))
        );
        assert_eq!(o.take(imu, Timestamp(400 * MS), &g, &c), None);
        // A different gap (the anchor moved on): nothing to take.
        let mut o = GapOdometry::new();
        assert_eq!(
            o.offer(imu, &rates(40, 8.0, 8.0), &g, None, &c),
            Some(Ok(()))
        );
        assert_eq!(o.take(Timestamp(MS), Timestamp(50 * MS), &g, &c), None);
        // Switched off: nothing offered.
        let mut off = c;
        off.gap.wheels = false;
        let mut o = GapOdometry::new();
        assert_eq!(o.offer(imu, &rates(40, 8.0, 8.0), &g, None, &off), None);
    }

    #[test]
    fn spinning_wheels_are_scaled_to_the_flow() {
        let c = FilterConfig::default();
        let g = geometry();
        let imu = Timestamp(0);
        // Wheels say 0.42 m/s, the flow 0.30 +- 0.01: spinning.
        let flow = Some(SpeedWitness {
            speed: 0.3,
            std: 0.01,
        });
        let mut o = GapOdometry::new();
        for k in 2..=25u64 {
            assert_eq!(
                o.offer(imu, &rates(20 * k, 12.0, 12.0), &g, flow, &c),
                Some(Ok(()))
            );
        }
        assert_eq!(o.slips(), 24);
        let m = o.take(imu, Timestamp(500 * MS), &g, &c).expect("covered");
        assert!((m.x - 0.3 * 0.5).abs() < 1e-3, "{}", m.x);
        // Agreeing wheels, a vague flow, or turning in place: wheels kept.
        let cases = [
            (8.0, 8.0, 0.28, 0.01),
            (12.0, 12.0, 0.3, 0.2),
            (-1.0, 1.0, 0.3, 0.01),
        ];
        for (l, r, speed, std) in cases {
            let mut o = GapOdometry::new();
            let w = Some(SpeedWitness { speed, std });
            assert_eq!(o.offer(imu, &rates(40, l, r), &g, w, &c), Some(Ok(())));
            assert_eq!(o.slips(), 0, "{l} {r} {speed} {std}");
        }
    }
}
