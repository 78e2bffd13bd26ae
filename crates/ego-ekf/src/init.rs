//! Initialisation from the first still IMU samples: the mean specific force
//! gives roll and pitch (gravity-aligned attitude, yaw zero), the mean rate
//! the gyro bias. A sample that does not look still restarts the average.

use crate::config::InitConfig;
use crate::state::{Quat, Vec3};

/// What the still samples said.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StillStart {
    /// Gravity-aligned attitude, yaw zero.
    pub q_wb: Quat,
    /// Mean angular rate: the gyro bias.
    pub gyro_bias: Vec3,
}

/// Averages still IMU samples until there are enough.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Initialiser {
    sum_accel: Vec3,
    sum_gyro: Vec3,
    n: u16,
}

impl Initialiser {
    /// Nothing averaged yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Samples averaged so far.
    pub fn len(&self) -> u16 {
        self.n
    }

    /// Whether nothing is averaged.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Forgets the average.
    pub fn restart(&mut self) {
        *self = Self::default();
    }

    /// Adds one sample; returns the start once `config.samples` still
    /// samples are averaged.
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
            self.restart();
            return None;
        }
        self.sum_accel += accel;
        self.sum_gyro += gyro;
        self.n = self.n.saturating_add(1);
        if self.n < config.samples {
            return None;
        }
        let n = f32::from(self.n);
        let a = self.sum_accel / n;
        let roll = libm::atan2f(a.y, a.z);
        let pitch = libm::atan2f(-a.x, libm::sqrtf(a.y * a.y + a.z * a.z));
        let start = StillStart {
            q_wb: Quat::from_euler_angles(roll, pitch, 0.0),
            gyro_bias: self.sum_gyro / n,
        };
        self.restart();
        Some(start)
    }
}
