//! IMU plausibility: two faults a range check cannot see, refused before a
//! reading moves the state.
//!
//! - **A gyro jump.** A ground robot's angular rate cannot change faster
//!   than its motors, tyres and inertia allow. A reading whose rate differs
//!   from the last accepted one by more than
//!   `step_floor + max_angular_accel * (t - t_accepted)` is refused as
//!   [`Reject::OutOfRange`]: a value the robot cannot physically have (a
//!   bit error in the rate register, a corrupted bus word). The allowance
//!   grows with the time since the last accepted reading, so a true change
//!   beyond it is accepted at the latest after
//!   `(gyro_max - step_floor) / max_angular_accel` seconds, and the reading
//!   that ends the pause bridges it ([`crate::gap`]).
//! - **A yaw jump.** About the vertical a ground robot turns only as fast
//!   as its wheels' traction lets it, far slower than it may roll or pitch
//!   on a bump: the rate change along the vertical (the filter's attitude
//!   tells where it lies in the IMU's frame) is held to
//!   `yaw_step_floor + max_yaw_accel * (t - t_accepted)`, refused as
//!   [`Reject::OutOfRange`] beyond (a true change is accepted once the
//!   allowance has grown to it: 45 ms for 1 rad/s from rest, the last
//!   accepted rate held over the pause). A small spike in the yaw rate (a bit
//!   error in a low bit, a glitch that multiplies a rate near zero) stays
//!   within the whole rate's allowance and would otherwise turn the heading
//!   unseen: 0.5 rad/s for 16 ms is half a degree.
//! - **A frozen output.** A MEMS IMU's noise changes its readings every
//!   sample; an output that repeats bit for bit on all six axes is frozen (a
//!   stale data register, a data-ready line that stopped). An IMU polled
//!   faster than its output data rate repeats each reading a few times, so
//!   a reading is refused ([`Reject::LowQuality`]: it carries no
//!   information) only once it repeats one taken more than
//!   `frozen_after_ns` before it. Off in [`ImuPlausibility::DEFAULT`]: a
//!   simulator or a test bench that feeds noise-free readings (gravity
//!   alone, standing still) would have them refused;
//!   [`ImuPlausibility::FIELD`] turns it on for a real IMU (`host-sim`'s
//!   replay of simulated and recorded logs and the firmware do).
//!
//! A refused reading leaves the state untouched. The next accepted one
//! integrates over its own part of the interval, the last accepted rates
//! held over the refused part (the refused readings told nothing; a spike
//! that ends a refused run and is within the grown allowance turns the
//! heading for one step, not for the whole run), or, after more than the
//! IMU's largest step, ends a gap that the wheels bridge. The defaults refuse no
//! reading of the BorealTC excerpts in `data/real/borealtc` (largest rate
//! change between two of their 100 Hz readings 0.30 rad/s, against an
//! allowance of 1.0 rad/s, and 0.12 rad/s about their IMU's z axis, the
//! vertical of the level robot, against 0.3 rad/s; `cargo test -p host-sim
//! --test real_data plausibility`).

use crate::state::Vec3;
use vslam_core::sensors::ImuSample;
use vslam_core::{Reject, Timestamp};

/// What a plausible IMU reading is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuPlausibility {
    /// Largest angular acceleration the robot can have, rad/s^2.
    pub max_angular_accel: f32,
    /// Rate change allowed on top of `max_angular_accel` times the step,
    /// rad/s (noise, a jolt's short spike).
    pub step_floor: f32,
    /// Largest angular acceleration about the vertical, rad/s^2.
    pub max_yaw_accel: f32,
    /// Yaw-rate change allowed on top of `max_yaw_accel` times the step,
    /// rad/s (noise).
    pub yaw_step_floor: f32,
    /// A reading that repeats, bit for bit, one taken more than this long
    /// before it is frozen, ns (`None`: never judged frozen).
    pub frozen_after_ns: Option<u64>,
}

impl ImuPlausibility {
    /// A robot vacuum: angular acceleration up to 50 rad/s^2 (2.5 times the
    /// gap model's 20 rad/s^2, [`crate::config::GapConfig`]) plus 0.5 rad/s,
    /// so 0.7 rad/s between two 250 Hz readings; about the vertical the gap
    /// model's 20 rad/s^2 plus 0.1 rad/s (0.18 rad/s between two readings,
    /// against 0.031 rad/s at most in an hour of the simulator's drive with
    /// its noise); readings never judged frozen (noise-free synthetic
    /// readings repeat).
    pub const DEFAULT: Self = ImuPlausibility {
        max_angular_accel: 50.0,
        step_floor: 0.5,
        max_yaw_accel: 20.0,
        yaw_step_floor: 0.1,
        frozen_after_ns: None,
    };

    /// [`ImuPlausibility::DEFAULT`] for a real, noisy IMU: a reading
    /// repeated bit for bit 20 ms after it was taken is frozen (an IMU
    /// polled at 250 Hz with an output data rate of 50 Hz or more repeats
    /// no reading that long).
    pub const FIELD: Self = ImuPlausibility {
        frozen_after_ns: Some(20_000_000),
        ..Self::DEFAULT
    };

    /// Whether every field is finite and positive.
    pub fn is_valid(&self) -> bool {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        positive(self.max_angular_accel)
            && positive(self.step_floor)
            && positive(self.max_yaw_accel)
            && positive(self.yaw_step_floor)
            && self.frozen_after_ns != Some(0)
    }

    /// The rate change allowed `dt_ns` after the last accepted reading, rad/s.
    pub fn allowance(&self, dt_ns: u64) -> f32 {
        self.step_floor + self.max_angular_accel * seconds(dt_ns)
    }

    /// The yaw-rate change allowed `dt_ns` after the last accepted
    /// reading, rad/s.
    pub fn yaw_allowance(&self, dt_ns: u64) -> f32 {
        self.yaw_step_floor + self.max_yaw_accel * seconds(dt_ns)
    }
}

/// `dt_ns` in seconds, through u32 (4.3 s, far beyond any step the filter
/// integrates): one conversion instruction on a Cortex-M4F, not a library
/// call.
fn seconds(dt_ns: u64) -> f32 {
    u32::try_from(dt_ns).unwrap_or(u32::MAX) as f32 * 1e-9
}

impl Default for ImuPlausibility {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The readings the check compares against.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlausibilityCheck {
    /// The last accepted reading's time and rate.
    accepted: Option<(Timestamp, Vec3)>,
    /// The last reading judged (rates, specific force).
    last: Option<(Vec3, Vec3)>,
    /// When the run of identical readings ending in `last` began.
    run_start: Option<Timestamp>,
}

impl PlausibilityCheck {
    /// Nothing seen yet.
    pub const fn new() -> Self {
        PlausibilityCheck {
            accepted: None,
            last: None,
            run_start: None,
        }
    }

    /// Judges `sample`, later than every reading judged before (the caller
    /// lets its clock refuse a time stamp that is not): frozen first, then
    /// the rate change against the last accepted reading, then, with the
    /// vertical `up` in the IMU's frame (a unit vector; `None` before the
    /// attitude is known), its part about the vertical. Records the reading
    /// for the frozen check; [`PlausibilityCheck::accepted`] records it as
    /// the reference for the rate.
    pub fn check(
        &mut self,
        cfg: &ImuPlausibility,
        sample: &ImuSample,
        up: Option<&Vec3>,
    ) -> Result<(), Reject> {
        let (t, gyro, accel) = (sample.t(), *sample.gyro(), *sample.accel());
        let same = self.last == Some((gyro, accel));
        self.last = Some((gyro, accel));
        let run_start = match self.run_start {
            Some(start) if same => start,
            _ => t,
        };
        self.run_start = Some(run_start);
        if let Some(frozen) = cfg.frozen_after_ns
            && t.nanos_since(run_start).is_some_and(|d| d > frozen)
        {
            return Err(Reject::LowQuality);
        }
        if let Some((ta, ga)) = self.accepted
            && let Some(dt_ns) = t.nanos_since(ta)
            && let allowed = cfg.allowance(dt_ns)
            && (gyro - ga).norm_squared() > allowed * allowed
        {
            return Err(Reject::OutOfRange);
        }
        if let (Some((ta, ga)), Some(up)) = (self.accepted, up)
            && let Some(dt_ns) = t.nanos_since(ta)
            && libm::fabsf((gyro - ga).dot(up)) > cfg.yaw_allowance(dt_ns)
        {
            return Err(Reject::OutOfRange);
        }
        Ok(())
    }

    /// Records an accepted reading: the reference of the next rate check.
    pub fn accepted(&mut self, t: Timestamp, gyro: &Vec3) {
        self.accepted = Some((t, *gyro));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vslam_core::sensors::RawImuSample;

    fn sample(k: u64, gz: f32, az: f32) -> ImuSample {
        rates(k, [0.001, -0.002, gz], az)
    }

    fn rates(k: u64, gyro: [f32; 3], az: f32) -> ImuSample {
        let raw = RawImuSample {
            t: Timestamp(k * 4_000_000),
            gyro,
            accel: [0.01, 0.02, az],
        };
        ImuSample::with_range(&raw, 35.0, 160.0).unwrap()
    }

    /// The IMU level: its z axis is the vertical.
    fn run(check: &mut PlausibilityCheck, s: &ImuSample) -> Result<(), Reject> {
        run_with(check, s, Some(&Vec3::z()))
    }

    fn run_with(
        check: &mut PlausibilityCheck,
        s: &ImuSample,
        up: Option<&Vec3>,
    ) -> Result<(), Reject> {
        let cfg = ImuPlausibility::FIELD;
        let r = check.check(&cfg, s, up);
        if r.is_ok() {
            check.accepted(s.t(), s.gyro());
        }
        r
    }

    #[test]
    fn a_spike_is_refused_and_the_rate_it_left_is_accepted_again() {
        let mut c = PlausibilityCheck::new();
        assert_eq!(run(&mut c, &sample(0, 0.05, 9.81)), Ok(()));
        // Gyro z a hundred times over for three readings: 5 rad/s.
        for k in 1..4 {
            assert_eq!(
                run(&mut c, &sample(k, 5.0 + k as f32 * 1e-3, 9.81)),
                Err(Reject::OutOfRange)
            );
        }
        assert_eq!(run(&mut c, &sample(4, 0.051, 9.81)), Ok(()));
    }

    #[test]
    fn a_turn_within_the_robots_angular_acceleration_is_accepted() {
        let mut c = PlausibilityCheck::new();
        // A turn: 0 -> 1.2 rad/s at 15 rad/s^2, 0.06 rad/s a reading.
        for k in 0..21 {
            let gz = (k as f32 * 0.06).min(1.2);
            assert_eq!(run(&mut c, &sample(k, gz, 9.81 + k as f32 * 1e-3)), Ok(()));
        }
        // A yaw step of 0.17 rad/s in one reading is within 0.1 + 20 * 0.004.
        assert_eq!(run(&mut c, &sample(21, 1.37, 9.7)), Ok(()));
        // One of 0.2 is not.
        assert_eq!(run(&mut c, &sample(22, 1.57, 9.7)), Err(Reject::OutOfRange));
        // A bump rolls the robot: 0 -> 2 rad/s about x at 40 rad/s^2.
        let mut c = PlausibilityCheck::new();
        for k in 0..14 {
            let gx = (k as f32 * 0.16).min(2.0);
            let s = rates(k, [gx, -0.002, 0.001], 9.81 + k as f32 * 1e-3);
            assert_eq!(run(&mut c, &s), Ok(()));
        }
        // A step of 0.6 rad/s in one reading is within 0.5 + 50 * 0.004.
        let s = rates(14, [2.6, -0.002, 0.001], 9.7);
        assert_eq!(run(&mut c, &s), Ok(()));
        // One of 0.75 is not.
        let s = rates(15, [3.35, -0.002, 0.001], 9.7);
        assert_eq!(run(&mut c, &s), Err(Reject::OutOfRange));
    }

    #[test]
    fn a_yaw_spike_within_the_whole_rates_allowance_is_refused() {
        // Driving straight, the yaw rate near zero; a glitch multiplies it
        // a hundred times for four readings (0.35 .. 0.6 rad/s).
        let spikes = [0.6, 0.35, 0.5, 0.45];
        let mut c = PlausibilityCheck::new();
        assert_eq!(run(&mut c, &sample(0, 0.004, 9.81)), Ok(()));
        for (k, gz) in (1..).zip(spikes) {
            assert_eq!(run(&mut c, &sample(k, gz, 9.81)), Err(Reject::OutOfRange));
        }
        assert_eq!(run(&mut c, &sample(5, 0.005, 9.81)), Ok(()));
        // Without the vertical (before the attitude is known) all four are
        // within the whole rate's allowance (0.7 rad/s, growing).
        let mut c = PlausibilityCheck::new();
        assert_eq!(run_with(&mut c, &sample(0, 0.004, 9.81), None), Ok(()));
        for (k, gz) in (1..).zip(spikes) {
            assert_eq!(run_with(&mut c, &sample(k, gz, 9.81), None), Ok(()));
        }
        // The vertical is wherever the attitude puts it: an IMU mounted
        // on its side sees yaw about its x axis.
        let mut c = PlausibilityCheck::new();
        let side = Vec3::x();
        let s = rates(0, [0.004, -0.002, 0.001], 9.81);
        assert_eq!(run_with(&mut c, &s, Some(&side)), Ok(()));
        let s = rates(1, [0.4, -0.002, 0.001], 9.81);
        assert_eq!(run_with(&mut c, &s, Some(&side)), Err(Reject::OutOfRange));
        let s = rates(2, [0.004, -0.002, 0.4], 9.81);
        assert_eq!(run_with(&mut c, &s, Some(&side)), Ok(()));
    }

    #[test]
    fn a_true_step_is_accepted_once_the_allowance_has_grown_to_it() {
        // 3 rad/s about x from rest needs (3 - 0.5) / 50 = 50 ms: 12.5
        // readings.
        let mut c = PlausibilityCheck::new();
        assert_eq!(run(&mut c, &rates(0, [0.0; 3], 9.81)), Ok(()));
        let accepted_at = (1..40)
            .find(|&k| run(&mut c, &rates(k, [3.0, 0.0, 0.0], 9.81 + k as f32 * 1e-4)).is_ok())
            .unwrap();
        assert_eq!(accepted_at, 13);
        // 1 rad/s about the vertical needs (1 - 0.1) / 20 = 45 ms: 11.25.
        let mut c = PlausibilityCheck::new();
        assert_eq!(run(&mut c, &sample(0, 0.0, 9.81)), Ok(()));
        let accepted_at = (1..40)
            .find(|&k| run(&mut c, &sample(k, 1.0, 9.81 + k as f32 * 1e-4)).is_ok())
            .unwrap();
        assert_eq!(accepted_at, 12);
    }

    #[test]
    fn a_frozen_output_is_refused_after_twenty_milliseconds() {
        let mut c = PlausibilityCheck::new();
        assert_eq!(run(&mut c, &sample(0, 0.3, 9.8)), Ok(()));
        // Repeats 4 ms .. 20 ms after the reading: an IMU polled faster
        // than it updates.
        for k in 1..=5 {
            assert_eq!(run(&mut c, &sample(k, 0.3, 9.8)), Ok(()), "repeat {k}");
        }
        for k in 6..100 {
            assert_eq!(
                run(&mut c, &sample(k, 0.3, 9.8)),
                Err(Reject::LowQuality),
                "repeat {k}"
            );
        }
        // The first new reading is accepted (within the rate allowance).
        assert_eq!(run(&mut c, &sample(100, 0.31, 9.8)), Ok(()));
        // Without the frozen check a repeat is a reading like another.
        let mut c = PlausibilityCheck::new();
        for k in 0..100 {
            let s = sample(k, 0.3, 9.8);
            assert_eq!(c.check(&ImuPlausibility::DEFAULT, &s, None), Ok(()));
            c.accepted(s.t(), s.gyro());
        }
        // One axis differing in its last bit is not a repeat.
        let mut c = PlausibilityCheck::new();
        for k in 0..50 {
            let az = if k % 2 == 0 {
                9.8
            } else {
                f32::from_bits(9.8f32.to_bits() + 1)
            };
            assert_eq!(run(&mut c, &sample(k, 0.3, az)), Ok(()));
        }
    }

    #[test]
    fn defaults_are_valid_and_bad_fields_are_not() {
        assert!(ImuPlausibility::DEFAULT.is_valid());
        assert!(ImuPlausibility::FIELD.is_valid());
        for bad in [
            ImuPlausibility {
                max_angular_accel: f32::NAN,
                ..ImuPlausibility::DEFAULT
            },
            ImuPlausibility {
                step_floor: 0.0,
                ..ImuPlausibility::DEFAULT
            },
            ImuPlausibility {
                frozen_after_ns: Some(0),
                ..ImuPlausibility::DEFAULT
            },
            ImuPlausibility {
                max_yaw_accel: -1.0,
                ..ImuPlausibility::DEFAULT
            },
            ImuPlausibility {
                yaw_step_floor: f32::INFINITY,
                ..ImuPlausibility::DEFAULT
            },
        ] {
            assert!(!bad.is_valid());
        }
    }
}
