//! Horizontal impacts: the robot hit something and stopped; its wheels may
//! not have.
//!
//! A robot that drives into an obstacle (a chair leg, a wall its bumper
//! missed) or gets wedged stops within milliseconds while its wheels keep
//! turning. The accelerometer sees that stop as a horizontal specific
//! force far beyond anything the drive commands: a robot vacuum accelerates
//! at well under 1 m/s^2 (the simulated drive's largest horizontal specific
//! force over a fault-free hour is 0.76 m/s^2), a stop from 0.3 m/s within
//! 30 ms is 10 m/s^2. The filter integrates the stop; the first wheel
//! samples after it still report the speed before it.
//!
//! Those samples must be gated on the wheels' own noise. A distrust factor
//! (the adverse-event memory's weight where the robot is, the scale
//! pipeline's verdict) inflates the noise the wheels are fused with; gated on
//! that inflated noise, a 0.3 m/s innovation against a filter at rest passes
//! a 2.8x wider gate, and the wheels drag the stopped filter forward. So
//! for [`RecoveryConfig::impact_hold_ns`] around an impact (the largest
//! horizontal specific force of an IMU step at least
//! [`RecoveryConfig::impact_accel`]), the wheels' forward and differential
//! rows are gated as the uninflated rows would be, and fused with the
//! inflated noise when they pass; the hold ends early at the first sample
//! taken after the impact whose forward row passes (the wheels agree with
//! the IMU again). Distrust then lowers what a sample counts and never lets
//! a larger innovation pass. Away from impacts the gate tests the inflated
//! noise: lowering the wheels' weight where they misled before lets more of
//! them in where they are only noisier (a lap end's start and stop), which
//! gating on the uninflated noise everywhere refused (measured: the
//! fault-free hour's planar ATE 0.156 m against 0.112 m).

use vslam_core::Timestamp;

use crate::config::RecoveryConfig;
use crate::state::Vec3;

/// The horizontal part `|a_xy|` of the world-frame acceleration `a`
/// ([`crate::propagate::world_acceleration`]), m/s^2: the drive's
/// acceleration in level motion, large when the robot hits something.
pub fn horizontal(a: &Vec3) -> f32 {
    libm::sqrtf(a.x * a.x + a.y * a.y)
}

/// The latest impact and the counts (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImpactWatch {
    /// Time of the latest impact whose hold is still open.
    open: Option<Timestamp>,
    /// Impacts detected (IMU steps at or above the threshold that opened
    /// or renewed a hold).
    impacts: u32,
    /// Wheel samples whose forward or differential row the uninflated
    /// gate refused while a hold was open (each also counted as gated in
    /// the wheels' counts).
    strict_gated: u32,
}

impl ImpactWatch {
    /// No impact yet.
    pub const fn new() -> Self {
        ImpactWatch {
            open: None,
            impacts: 0,
            strict_gated: 0,
        }
    }

    /// One IMU step at `t` with horizontal specific force `horizontal`
    /// (m/s^2); NaN is not an impact.
    pub fn step(&mut self, cfg: &RecoveryConfig, t: Timestamp, horizontal: f32) {
        if horizontal >= cfg.impact_accel {
            self.open = Some(t);
            self.impacts = self.impacts.saturating_add(1);
        }
    }

    /// Whether a wheel sample taken at `t` lies within the hold of the open
    /// impact (before or after it).
    pub fn holds_at(&self, cfg: &RecoveryConfig, t: Timestamp) -> bool {
        self.open.is_some_and(|at| {
            let apart = t.nanos_since(at).or_else(|| at.nanos_since(t));
            apart.is_some_and(|d| d <= cfg.impact_hold_ns)
        })
    }

    /// Records what the strict gate did with a wheel sample taken at `t`
    /// within the hold: `forward_fused`, the wheels agree again and a
    /// sample taken after the impact closes the hold; `gated`, one more
    /// strictly gated sample.
    pub fn judged(&mut self, t: Timestamp, forward_fused: bool, gated: bool) {
        if gated {
            self.strict_gated = self.strict_gated.saturating_add(1);
        }
        if forward_fused && self.open.is_some_and(|at| t.nanos_since(at).is_some()) {
            self.open = None;
        }
    }

    /// Impacts detected.
    pub fn impacts(&self) -> u32 {
        self.impacts
    }

    /// Wheel samples the uninflated gate refused around impacts.
    pub fn strict_gated(&self) -> u32 {
        self.strict_gated
    }

    /// Time of the impact whose hold is open, if any.
    pub fn open(&self) -> Option<Timestamp> {
        self.open
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn a_hold_opens_at_the_threshold_and_closes_when_the_wheels_agree_after_it() {
        let cfg = RecoveryConfig::DEFAULT;
        let mut w = ImpactWatch::new();
        w.step(&cfg, Timestamp(100 * MS), cfg.impact_accel * 0.99);
        w.step(&cfg, Timestamp(104 * MS), f32::NAN);
        assert_eq!(w.impacts(), 0);
        assert!(!w.holds_at(&cfg, Timestamp(104 * MS)));
        w.step(&cfg, Timestamp(108 * MS), cfg.impact_accel);
        assert_eq!(w.impacts(), 1);
        // Around the impact, either side, up to the hold.
        assert!(w.holds_at(&cfg, Timestamp(100 * MS)));
        assert!(w.holds_at(&cfg, Timestamp(108 * MS + cfg.impact_hold_ns)));
        assert!(!w.holds_at(&cfg, Timestamp(108 * MS + cfg.impact_hold_ns + 1)));
        // A sample from before the impact that passes does not close it.
        w.judged(Timestamp(100 * MS), true, false);
        assert!(w.holds_at(&cfg, Timestamp(120 * MS)));
        w.judged(Timestamp(120 * MS), false, true);
        assert_eq!(w.strict_gated(), 1);
        w.judged(Timestamp(140 * MS), true, false);
        assert!(!w.holds_at(&cfg, Timestamp(160 * MS)));
        assert_eq!(w.open(), None);
    }
}
