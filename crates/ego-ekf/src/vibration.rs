//! Vertical vibration as process noise: a floor shakes the robot (carpet
//! pile, tile joints, a threshold strip), and the accelerometer's vertical
//! axis reads it as a zero-mean acceleration far above the sensor's own
//! white noise (the simulator's carpet: 0.6 m/s^2 per 250 Hz sample, twenty
//! times a consumer MEMS accelerometer's). Integrated by the propagation
//! with the sensor's noise density alone, it walks the vertical velocity
//! by centimetres per second while the filter believes millimetres, so the
//! wheels' vertical row and the floor update, weighted by that belief, do
//! not pull it back, and the height wanders (the filter's vertical motion
//! over a camera pair then disagrees with the camera's).
//!
//! [`Vibration`] measures it: the body-z specific force, high-passed by an
//! exponential mean ([`VibrationConfig::mean_tau_s`]), its square averaged
//! the same way ([`VibrationConfig::power_tau_s`]); the power beyond the
//! sensor's own sample variance (`accel_density^2 / dt`) is the vibration's
//! variance per sample, and the vertical velocity's process noise gains
//! that times `dt^2` per step (a white acceleration sample's velocity
//! increment). A jolt (a wheel climbing a cable or a threshold strip: a
//! few m/s^2 for a fifth of a second) is motion the filter must follow, not
//! vibration: each sample's square enters the power clipped at
//! [`VibrationConfig::clip_sigmas`] squared times the power so far (at
//! least the sensor's own variance), so a lone jolt hardly raises it while
//! a floor that keeps shaking raises it within a few tenths of a second.
//! An adaptive process noise from the measured specific force,
//! after the vibration-aware noise models of land-vehicle inertial
//! navigation (e.g. Groves, "Principles of GNSS, Inertial, and Multisensor
//! Integrated Navigation Systems", 2nd ed., sec. 14.2.7, vibration in the
//! system noise).

use crate::state::{ErrorState, V};

/// How the vibration is measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VibrationConfig {
    /// Time constant of the mean specific force the vibration is measured
    /// against, s.
    pub mean_tau_s: f32,
    /// Time constant of the vibration's power, s.
    pub power_tau_s: f32,
    /// A sample's square enters the power clipped at this many squared
    /// times the power so far (or the sensor's variance, if larger).
    pub clip_sigmas: f32,
}

impl VibrationConfig {
    /// The defaults: a 0.2 s mean, a 0.5 s power average, samples
    /// clipped at 3 sigma.
    pub const DEFAULT: Self = VibrationConfig {
        mean_tau_s: 0.2,
        power_tau_s: 0.5,
        clip_sigmas: 3.0,
    };
}

impl Default for VibrationConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The vertical vibration's running measurement.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vibration {
    mean: Option<f32>,
    power: f32,
}

impl Vibration {
    /// Nothing measured.
    pub const fn new() -> Self {
        Vibration {
            mean: None,
            power: 0.0,
        }
    }

    /// Takes one sample's body-z specific force `fz` (m/s^2) over a step of
    /// `dt` seconds; gives the vibration's variance per sample beyond the
    /// sensor's own `noise_var` (m^2/s^4, zero when there is none). A
    /// non-finite `fz` or `dt` changes nothing.
    pub fn step(&mut self, config: &VibrationConfig, fz: f32, dt: f32, noise_var: f32) -> f32 {
        if !(fz.is_finite() && dt.is_finite() && dt > 0.0) {
            return self.excess(noise_var);
        }
        let Some(mean) = self.mean else {
            self.mean = Some(fz);
            return 0.0;
        };
        let a = weight(dt, config.mean_tau_s);
        let mean = mean + a * (fz - mean);
        self.mean = Some(mean);
        let d = fz - mean;
        let clip = config.clip_sigmas * config.clip_sigmas * self.power.max(noise_var);
        let b = weight(dt, config.power_tau_s);
        self.power += b * ((d * d).min(clip) - self.power);
        self.excess(noise_var)
    }

    /// The measured power beyond `noise_var`.
    pub fn excess(&self, noise_var: f32) -> f32 {
        (self.power - noise_var).max(0.0)
    }
}

/// The exponential average's weight of a step `dt` at time constant `tau`
/// (one, i.e. no averaging, for a time constant that is not positive).
fn weight(dt: f32, tau: f32) -> f32 {
    if tau > 0.0 { (dt / tau).min(1.0) } else { 1.0 }
}

/// Adds a vertical vibration of variance `excess` per sample to the
/// process noise `q` of a step of `dt` seconds (the world vertical
/// velocity's entry; the robot is level on its floor).
pub fn add_to_process_noise(q: &mut ErrorState, excess: f32, dt: f32) {
    if excess > 0.0
        && let Some(v) = q.get_mut(V + 2)
    {
        *v += excess * dt * dt;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator of zero-mean noise of unit variance
    /// (a sum of uniforms).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            let mut s = 0.0;
            for _ in 0..12 {
                self.0 = self
                    .0
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                s += (self.0 >> 40) as f32 / (1u64 << 24) as f32;
            }
            s - 6.0
        }
    }

    #[test]
    fn the_excess_power_is_the_vibration_variance() {
        let c = VibrationConfig::DEFAULT;
        let (dt, sensor) = (0.004, 0.03f32);
        let mut v = Vibration::new();
        let mut rng = Lcg(3);
        let mut excess = 0.0;
        for _ in 0..2_000 {
            let fz = 9.81 + 0.6 * rng.next() + sensor * rng.next();
            excess = v.step(&c, fz, dt, sensor * sensor);
        }
        // 0.6^2 = 0.36, within the 0.5 s average's scatter (~7 %).
        assert!((excess - 0.36).abs() < 0.08, "{excess}");
        // The sensor's noise alone: (almost) nothing.
        let mut quiet = Vibration::new();
        for _ in 0..2_000 {
            excess = quiet.step(&c, 9.81 + sensor * rng.next(), dt, sensor * sensor);
        }
        assert!(excess < 0.0005, "{excess}");
        // A slow change of the mean (a ramp) is not vibration.
        let mut ramp = Vibration::new();
        for k in 0..2_000 {
            excess = ramp.step(&c, 9.81 + 0.0005 * k as f32, dt, 0.0);
        }
        assert!(excess < 1e-4, "{excess}");
        // A cable under a wheel on a quiet floor: a 0.2 s raised-cosine
        // climb of 12 mm, +-4.7 m/s^2, is not vibration (clipped, a small
        // fraction of the carpet's 0.36; unclipped, several times it).
        let jolt_peak = |c: &VibrationConfig, rng: &mut Lcg| {
            let mut jolt = Vibration::new();
            let mut peak = 0.0f32;
            for k in 0..500 {
                let t = (k as f32 - 200.0) * dt;
                let bump = if (0.0..0.2).contains(&t) {
                    let w = core::f32::consts::TAU / 0.2;
                    0.5 * 0.012 * w * w * libm::cosf(w * t)
                } else {
                    0.0
                };
                let e = jolt.step(c, 9.81 + bump + sensor * rng.next(), dt, sensor * sensor);
                peak = peak.max(e);
            }
            peak
        };
        let clipped = jolt_peak(&c, &mut rng);
        assert!(clipped < 0.03, "{clipped}");
        let unclipped = VibrationConfig {
            clip_sigmas: 1e6,
            ..c
        };
        let peak = jolt_peak(&unclipped, &mut rng);
        assert!(peak > 1.0, "{peak}");
        // Bad samples change nothing.
        let before = v;
        v.step(&c, f32::NAN, dt, 0.0);
        v.step(&c, 9.81, 0.0, 0.0);
        assert_eq!(v, before);
    }

    #[test]
    fn only_the_vertical_velocity_gains_noise() {
        let mut q = ErrorState::zeros();
        add_to_process_noise(&mut q, 0.36, 0.004);
        assert!((q[V + 2] - 0.36 * 0.004 * 0.004).abs() < 1e-9);
        assert_eq!(q.iter().filter(|x| **x != 0.0).count(), 1);
        add_to_process_noise(&mut q, 0.0, 0.004);
        add_to_process_noise(&mut q, f32::NAN, 0.004);
        assert_eq!(q.iter().filter(|x| **x != 0.0).count(), 1);
    }
}
