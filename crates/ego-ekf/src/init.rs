//! Initialisation from the first still IMU samples: the mean specific force
//! gives roll and pitch (gravity-aligned attitude, yaw zero), the mean rate
//! the gyro bias. A sample that does not look still restarts the average.
//!
//! A robot that drives off at once and vibrates (a skid-steered Husky on
//! rough ground) may never give enough still samples in a row. Then, after
//! [`InitConfig::moving_samples`] samples (0.5 s) without a still start,
//! the mean specific force over them gives roll and pitch all the same,
//! when its size is within [`InitConfig::moving_max_accel_deviation`] of
//! gravity (driving at a near-constant speed: the vibration averages out):
//! a *moving start*, with the larger tilt and velocity uncertainty of
//! [`InitConfig::moving`] (a steady acceleration of 0.5 m/s^2 tilts the
//! mean by 3 degrees) and no gyro bias (the robot may be turning). Otherwise
//! the next 0.5 s are tried.

use crate::config::InitConfig;
use crate::state::{Quat, Vec3};

/// What the still samples said.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillStart {
    /// Gravity-aligned attitude, yaw zero.
    pub q_wb: Quat,
    /// Mean angular rate: the gyro bias (zero for a moving start).
    pub gyro_bias: Vec3,
    /// Whether the robot was moving: the start's uncertainty is then
    /// [`InitConfig::moving`]'s.
    pub moving: bool,
}

/// Roll and pitch from a mean specific force, yaw zero.
fn level(a: &Vec3) -> Quat {
    let roll = libm::atan2f(a.y, a.z);
    let pitch = libm::atan2f(-a.x, libm::sqrtf(a.y * a.y + a.z * a.z));
    Quat::from_euler_angles(roll, pitch, 0.0)
}

/// Averages still IMU samples until there are enough.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Initialiser {
    sum_accel: Vec3,
    sum_gyro: Vec3,
    n: u16,
    /// Every sample's specific force since the last moving-start attempt.
    moving_accel: Vec3,
    moving_n: u16,
}

impl Initialiser {
    /// Nothing averaged yet.
    pub const fn new() -> Self {
        Initialiser {
            sum_accel: Vec3::new(0.0, 0.0, 0.0),
            sum_gyro: Vec3::new(0.0, 0.0, 0.0),
            n: 0,
            moving_accel: Vec3::new(0.0, 0.0, 0.0),
            moving_n: 0,
        }
    }

    /// Samples averaged so far.
    pub fn len(&self) -> u16 {
        self.n
    }

    /// Whether nothing is averaged.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Forgets the averages.
    pub fn restart(&mut self) {
        *self = Self::default();
    }

    /// Forgets the still samples' average (the moving one goes on).
    fn restart_still(&mut self) {
        self.sum_accel = Vec3::zeros();
        self.sum_gyro = Vec3::zeros();
        self.n = 0;
    }

    /// The moving start, when `config.moving_samples` samples are averaged
    /// and their mean specific force is within the deviation allowed.
    fn add_moving(
        &mut self,
        config: &InitConfig,
        gravity: f32,
        accel: &Vec3,
    ) -> Option<StillStart> {
        if config.moving_samples == 0 {
            return None;
        }
        self.moving_accel += accel;
        self.moving_n = self.moving_n.saturating_add(1);
        // Not while still samples are being averaged: that start may come.
        if self.moving_n < config.moving_samples || self.n > 0 {
            return None;
        }
        let a = self.moving_accel / f32::from(self.moving_n);
        self.moving_accel = Vec3::zeros();
        self.moving_n = 0;
        // A NaN deviation is no start either.
        let level_enough = libm::fabsf(a.norm() - gravity) < config.moving_max_accel_deviation;
        if !level_enough {
            return None;
        }
        self.restart();
        Some(StillStart {
            q_wb: level(&a),
            gyro_bias: Vec3::zeros(),
            moving: true,
        })
    }

    /// Adds one sample; returns the start once `config.samples` still
    /// samples in a row are averaged, or the moving start (module docs).
    pub fn add(
        &mut self,
        config: &InitConfig,
        gravity: f32,
        gyro: &Vec3,
        accel: &Vec3,
    ) -> Option<StillStart> {
        let still = gyro.norm() < config.max_gyro
            && libm::fabsf(accel.norm() - gravity) < config.max_accel_deviation;
        if !still {
            self.restart_still();
            return self.add_moving(config, gravity, accel);
        }
        self.sum_accel += accel;
        self.sum_gyro += gyro;
        self.n = self.n.saturating_add(1);
        if self.n < config.samples {
            return self.add_moving(config, gravity, accel);
        }
        let n = f32::from(self.n);
        let start = StillStart {
            q_wb: level(&(self.sum_accel / n)),
            gyro_bias: self.sum_gyro / n,
            moving: false,
        };
        self.restart();
        Some(start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: f32 = 9.81;

    /// Specific force of a robot tilted by `roll` rad, with a vibration of
    /// `amp` m/s^2 alternating in sign on x and z.
    fn accel(k: u16, roll: f32, amp: f32) -> Vec3 {
        let v = if k.is_multiple_of(2) { amp } else { -amp };
        Vec3::new(v, G * libm::sinf(roll), G * libm::cosf(roll) + v)
    }

    #[test]
    fn still_samples_start_still_with_the_gyro_bias() {
        let c = InitConfig::default();
        let mut init = Initialiser::new();
        let gyro = Vec3::new(0.001, -0.002, 0.003);
        let mut start = None;
        for k in 0..c.samples {
            start = init.add(&c, G, &gyro, &accel(k, 0.1, 0.0));
        }
        let s = start.expect("a still start after `samples` still samples");
        assert!(!s.moving);
        assert!((s.gyro_bias - gyro).norm() < 1e-6);
        let (roll, _, _) = s.q_wb.euler_angles();
        assert!((roll - 0.1).abs() < 1e-4);
    }

    #[test]
    fn a_robot_that_never_stands_still_starts_moving_after_half_a_second() {
        let c = InitConfig::default();
        let mut init = Initialiser::new();
        // Vibrating (never still) while turning at 0.5 rad/s.
        let gyro = Vec3::new(0.0, 0.0, 0.5);
        for k in 0..c.moving_samples - 1 {
            assert_eq!(init.add(&c, G, &gyro, &accel(k, 0.05, 2.0)), None);
        }
        let s = init
            .add(&c, G, &gyro, &accel(c.moving_samples - 1, 0.05, 2.0))
            .expect("a moving start");
        assert!(s.moving);
        assert_eq!(s.gyro_bias, Vec3::zeros());
        let (roll, pitch, _) = s.q_wb.euler_angles();
        assert!(
            (roll - 0.05).abs() < 2e-3 && pitch.abs() < 2e-2,
            "{roll} {pitch}"
        );

        // Accelerating hard on average: no start from that half second.
        let mut init = Initialiser::new();
        let hard = Vec3::new(4.0, 0.0, G);
        for _ in 0..c.moving_samples {
            assert_eq!(init.add(&c, G, &gyro, &hard), None);
        }
        // Off: never.
        let off = InitConfig {
            moving_samples: 0,
            ..c
        };
        let mut init = Initialiser::new();
        for k in 0..1000 {
            assert_eq!(init.add(&off, G, &gyro, &accel(k, 0.05, 2.0)), None);
        }
    }
}
