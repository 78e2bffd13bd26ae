//! Vibration as process noise: the ground shakes the robot (a skid steer's
//! lugged tyres on asphalt, sand, snow; a vacuum's wheels on tile joints),
//! and the accelerometer reads it as a zero-mean acceleration far above
//! the sensor's own white noise. The propagation integrates it with the
//! sensor's noise density alone, so the filter believes its velocity to
//! millimetres per second while the shaking walks it by decimetres between
//! two wheel samples; the wheels' forward rows, weighted by that belief,
//! then fail their gate one after another and the velocity runs away on
//! the IMU alone. Measured on the ten BorealTC logs (a Husky at 100 Hz,
//! `host-sim terrain-stats`): the horizontal specific force's spread over
//! half a second is 0.23 m/s^2 on ICE_06 and 0.9-4.3 m/s^2 on the others,
//! against a consumer MEMS accelerometer's 0.02 m/s^2 per sample.
//!
//! [`Vibration`] measures it per world axis: half the mean square of the
//! difference between successive samples of the specific force rotated into
//! the world frame (von Neumann's estimator of a white sequence's variance:
//! the robot's own accelerations, smooth from one sample to the next, add
//! next to nothing), averaged exponentially ([`VibrationConfig::power_tau_s`]);
//! the power beyond the sensor's own sample variance (`accel_density^2 /
//! dt`) is the vibration's variance per sample, and the velocity's process
//! noise on that axis gains that times `dt^2` per step (a white
//! acceleration sample's velocity increment). The gyroscope's rate is
//! measured the same way, in the body frame, for the attitude. A jolt (a
//! wheel climbing a cable or a threshold strip: a few m/s^2 for a fifth of
//! a second) is motion the filter must follow, not vibration: each sample's
//! term enters the power clipped at [`VibrationConfig::clip_sigmas`]
//! squared times the power so far (at least the sensor's own variance), so
//! a lone jolt hardly raises it while a floor that keeps shaking raises it
//! within a few tenths of a second. An
//! adaptive process noise from the measured specific force, after the
//! vibration-aware system noise of land-vehicle inertial navigation
//! (Groves, "Principles of GNSS, Inertial, and Multisensor Integrated
//! Navigation Systems", 2nd ed., 2013, sec. 14.2.7). The horizontal and
//! vertical velocity and the roll and pitch take it by default (the yaw,
//! which no gravity leaks into, does not).

use crate::state::{ErrorState, TH, V, Vec3};

/// How the vibration is measured and which velocity axes take it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VibrationConfig {
    /// Time constant of the vibration's power, s.
    pub power_tau_s: f32,
    /// A sample's term enters the power clipped at this many squared times
    /// the power so far (or the sensor's variance, if larger).
    pub clip_sigmas: f32,
    /// Whether the world's horizontal velocity axes take the vibration.
    pub horizontal: bool,
    /// Whether the world's vertical velocity axis takes the vibration.
    pub vertical: bool,
    /// Whether the attitude's roll and pitch axes take the rotational
    /// vibration the gyroscope measures beyond its noise density.
    pub tilt: bool,
}

impl VibrationConfig {
    /// The defaults: a 0.5 s power average, samples clipped at 3 sigma; the
    /// velocity and the roll and pitch take it.
    pub const DEFAULT: Self = VibrationConfig {
        power_tau_s: 0.5,
        clip_sigmas: 3.0,
        horizontal: true,
        vertical: true,
        tilt: true,
    };

    /// Whether the time constant is finite and not negative and the clip
    /// finite and positive.
    pub fn is_valid(&self) -> bool {
        self.power_tau_s.is_finite()
            && self.power_tau_s >= 0.0
            && self.clip_sigmas.is_finite()
            && self.clip_sigmas > 0.0
    }
}

impl Default for VibrationConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The vibration's running measurement, per world axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vibration {
    previous: Option<Vec3>,
    power: Vec3,
    rate_previous: Option<Vec3>,
    rate_power: Vec3,
}

impl Default for Vibration {
    fn default() -> Self {
        Self::new()
    }
}

impl Vibration {
    /// Nothing measured.
    pub const fn new() -> Self {
        Vibration {
            previous: None,
            power: Vec3::new(0.0, 0.0, 0.0),
            rate_previous: None,
            rate_power: Vec3::new(0.0, 0.0, 0.0),
        }
    }

    /// Takes one sample's world-frame specific force `f` (m/s^2) and
    /// body-frame angular rate `w` (rad/s) over a step of `dt` seconds;
    /// `noise` holds the sensors' own sample variances (the clip's floor). A
    /// non-finite value or `dt`, or a `dt` that is not positive, changes
    /// nothing.
    pub fn step(
        &mut self,
        config: &VibrationConfig,
        f: &Vec3,
        w: &Vec3,
        noise: SampleNoise,
        dt: f32,
    ) {
        let finite = |v: &Vec3| v.iter().all(|x| x.is_finite());
        if !(finite(f) && finite(w) && dt.is_finite() && dt > 0.0) {
            return;
        }
        let b = weight(dt, config.power_tau_s);
        let k = config.clip_sigmas * config.clip_sigmas;
        track(
            &mut self.previous,
            &mut self.power,
            f,
            b,
            k,
            noise.accel_var,
        );
        track(
            &mut self.rate_previous,
            &mut self.rate_power,
            w,
            b,
            k,
            noise.gyro_var,
        );
    }

    /// The measured specific-force power per world axis beyond the
    /// accelerometer's sample variance `noise_var` (m^2/s^4, zero where
    /// there is none).
    pub fn excess(&self, noise_var: f32) -> Vec3 {
        beyond(&self.power, noise_var)
    }

    /// The measured angular-rate power per body axis beyond the gyroscope's
    /// sample variance `noise_var` (rad^2/s^2, zero where there is none).
    pub fn rate_excess(&self, noise_var: f32) -> Vec3 {
        beyond(&self.rate_power, noise_var)
    }

    /// Adds the measured vibration to the process noise `q` of a step of
    /// `dt` seconds, on the axes `config` names; `noise` holds the
    /// accelerometer's and the gyroscope's own sample variances (see
    /// [`Vibration::excess`], [`Vibration::rate_excess`]).
    pub fn add_to_process_noise(
        &self,
        config: &VibrationConfig,
        q: &mut ErrorState,
        noise: SampleNoise,
        dt: f32,
    ) {
        let accel = self.excess(noise.accel_var);
        let rate = self.rate_excess(noise.gyro_var);
        let entries = [
            (V, config.horizontal, accel.x),
            (V + 1, config.horizontal, accel.y),
            (V + 2, config.vertical, accel.z),
            (TH, config.tilt, rate.x),
            (TH + 1, config.tilt, rate.y),
        ];
        for (i, on, e) in entries {
            let add = e * dt * dt;
            if on
                && add > 0.0
                && add.is_finite()
                && let Some(v) = q.get_mut(i)
            {
                *v += add;
            }
        }
    }
}

/// The inertial sensors' own variance per sample: `density^2 / dt`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleNoise {
    /// The accelerometer's, m^2/s^4.
    pub accel_var: f32,
    /// The gyroscope's, rad^2/s^2.
    pub gyro_var: f32,
}

impl SampleNoise {
    /// From the noise densities and the step `dt` (s).
    pub fn new(accel_density: f32, gyro_density: f32, dt: f32) -> Self {
        SampleNoise {
            accel_var: accel_density * accel_density / dt,
            gyro_var: gyro_density * gyro_density / dt,
        }
    }
}

/// One step of the power average of `x`: half the square of its change
/// since the previous sample, clipped at `k` times the power so far (at
/// least `floor`), averaged with weight `b`.
fn track(previous: &mut Option<Vec3>, power: &mut Vec3, x: &Vec3, b: f32, k: f32, floor: f32) {
    let Some(p) = previous.replace(*x) else {
        return;
    };
    let d = x - p;
    let term = (d.component_mul(&d) * 0.5).zip_map(power, |t, pw| {
        let clip = k * if pw > floor { pw } else { floor };
        if t < clip { t } else { clip }
    });
    *power += (term - *power) * b;
}

/// `power` beyond `noise_var`, per axis, not below zero.
fn beyond(power: &Vec3, noise_var: f32) -> Vec3 {
    power.map(|p| {
        let e = p - noise_var;
        if e > 0.0 { e } else { 0.0 }
    })
}

/// The exponential average's weight of a step `dt` at time constant `tau`
/// (one, i.e. no averaging, for a time constant that is not positive).
fn weight(dt: f32, tau: f32) -> f32 {
    if tau > 0.0 { (dt / tau).min(1.0) } else { 1.0 }
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
    fn the_excess_power_is_the_vibration_variance_per_axis() {
        let c = VibrationConfig::DEFAULT;
        let (dt, sensor) = (0.01, 0.02f32);
        let noise = SampleNoise {
            accel_var: sensor * sensor,
            gyro_var: 1e-6,
        };
        let mut v = Vibration::new();
        let mut rng = Lcg(3);
        let mut sum = Vec3::zeros();
        for k in 0..4_000 {
            let f = Vec3::new(
                1.5 * rng.next() + sensor * rng.next(),
                0.3 * rng.next() + sensor * rng.next(),
                9.81 + sensor * rng.next(),
            );
            v.step(&c, &f, &Vec3::zeros(), noise, dt);
            if k >= 2_000 {
                sum += v.excess(sensor * sensor);
            }
        }
        let e = sum / 2_000.0;
        // 1.5^2 = 2.25 and 0.3^2 = 0.09 (the sensor's own noise on z
        // leaves next to nothing).
        assert!((e.x - 2.25).abs() < 0.15, "{e}");
        assert!((e.y - 0.09).abs() < 0.008, "{e}");
        assert!(e.z < 0.0002, "{e}");
        // A robot's own smooth accelerations (1 m/s^2 at 1 Hz) are not
        // vibration.
        let mut drive = Vibration::new();
        for k in 0..2_000 {
            let a = libm::sinf(core::f32::consts::TAU * k as f32 * dt);
            drive.step(&c, &Vec3::new(a, 0.0, 9.81), &Vec3::zeros(), noise, dt);
        }
        assert!(drive.excess(0.0).x < 0.001, "{}", drive.excess(0.0));
        // A slow change of the mean (a ramp) is not vibration.
        let mut ramp = Vibration::new();
        for k in 0..2_000 {
            ramp.step(
                &c,
                &Vec3::new(0.0005 * k as f32, 0.0, 9.81),
                &Vec3::zeros(),
                noise,
                dt,
            );
        }
        assert!(ramp.excess(0.0).x < 1e-4);
        // Bad samples change nothing.
        let before = v;
        v.step(
            &c,
            &Vec3::new(f32::NAN, 0.0, 9.81),
            &Vec3::zeros(),
            noise,
            dt,
        );
        v.step(
            &c,
            &Vec3::zeros(),
            &Vec3::new(0.0, f32::NAN, 0.0),
            noise,
            dt,
        );
        v.step(&c, &Vec3::new(0.0, 0.0, 9.81), &Vec3::zeros(), noise, 0.0);
        v.step(
            &c,
            &Vec3::new(0.0, 0.0, 9.81),
            &Vec3::zeros(),
            noise,
            f32::INFINITY,
        );
        assert_eq!(v, before);
    }

    #[test]
    fn only_the_configured_axes_gain_noise() {
        let mut v = Vibration::new();
        v.power = Vec3::new(2.0, 1.0, 0.5);
        v.rate_power = Vec3::new(0.04, 0.09, 0.16);
        let dt = 0.01;
        let quiet = SampleNoise {
            accel_var: 0.0,
            gyro_var: 0.0,
        };
        let mut q = ErrorState::zeros();
        v.add_to_process_noise(&VibrationConfig::DEFAULT, &mut q, quiet, dt);
        assert!((q[V] - 2.0 * dt * dt).abs() < 1e-9);
        assert!((q[V + 1] - 1.0 * dt * dt).abs() < 1e-9);
        assert!((q[TH] - 0.04 * dt * dt).abs() < 1e-10);
        assert!((q[TH + 1] - 0.09 * dt * dt).abs() < 1e-10);
        assert!((q[V + 2] - 0.5 * dt * dt).abs() < 1e-9);
        // The yaw stays as it was.
        assert_eq!(q.iter().filter(|x| **x != 0.0).count(), 5);
        assert_eq!(q[TH + 2], 0.0);
        let vertical = VibrationConfig {
            horizontal: false,
            vertical: true,
            tilt: false,
            ..VibrationConfig::DEFAULT
        };
        let mut q = ErrorState::zeros();
        let noise = SampleNoise {
            accel_var: 0.25,
            gyro_var: 0.0,
        };
        v.add_to_process_noise(&vertical, &mut q, noise, dt);
        assert!((q[V + 2] - 0.25 * dt * dt).abs() < 1e-9);
        assert_eq!(q.iter().filter(|x| **x != 0.0).count(), 1);
        // The sensors' own noise above the measured power: nothing added.
        let mut q = ErrorState::zeros();
        let loud = SampleNoise {
            accel_var: 5.0,
            gyro_var: 1.0,
        };
        v.add_to_process_noise(&VibrationConfig::DEFAULT, &mut q, loud, dt);
        assert!(q.iter().all(|x| *x == 0.0));
    }

    #[test]
    fn the_rate_excess_is_the_rotational_vibration() {
        let c = VibrationConfig::DEFAULT;
        let (dt, sensor) = (0.01, 0.002f32);
        let noise = SampleNoise {
            accel_var: 4e-4,
            gyro_var: sensor * sensor,
        };
        let mut v = Vibration::new();
        let mut rng = Lcg(7);
        for _ in 0..2_000 {
            let w = Vec3::new(0.2 * rng.next(), sensor * rng.next(), 0.3);
            v.step(&c, &Vec3::new(0.0, 0.0, 9.81), &w, noise, dt);
        }
        let e = v.rate_excess(sensor * sensor / dt);
        assert!((e.x - 0.04).abs() < 0.012, "{e}");
        assert!(e.y < 1e-4 && e.z < 1e-6, "{e}");
    }

    #[test]
    fn a_lone_jolt_is_motion_a_shaking_floor_is_vibration() {
        let c = VibrationConfig::DEFAULT;
        // 250 Hz, a consumer accelerometer's 2e-3 m/s^2/sqrt(Hz).
        let dt = 0.004;
        let noise = SampleNoise::new(2e-3, 2e-4, dt);
        let sensor = libm::sqrtf(noise.accel_var);
        let mut rng = Lcg(11);
        let level =
            |rng: &mut Lcg, extra: f32| Vec3::new(0.0, 0.0, 9.81 + extra + sensor * rng.next());
        let mut v = Vibration::new();
        for _ in 0..500 {
            v.step(&c, &level(&mut rng, 0.0), &Vec3::zeros(), noise, dt);
        }
        // A wheel climbing a cable: three samples of 5 m/s^2.
        for k in 0..250 {
            let jolt = if (100..103).contains(&k) { 5.0 } else { 0.0 };
            v.step(&c, &level(&mut rng, jolt), &Vec3::zeros(), noise, dt);
        }
        let after_jolt = v.excess(noise.accel_var).z;
        // Unclipped, the jolt's squared steps (12.5 m^2/s^4 twice) would
        // have raised the power by about 0.2.
        assert!(after_jolt < 0.01, "{after_jolt}");
        // Carpet: 0.6 m/s^2 per sample (0.36 m^2/s^4), most of it within a
        // second (the clip delays the first tenths, the 0.5 s average the rest).
        for _ in 0..250 {
            let shake = 0.6 * rng.next();
            v.step(&c, &level(&mut rng, shake), &Vec3::zeros(), noise, dt);
        }
        let carpet = v.excess(noise.accel_var).z;
        assert!(carpet > 0.2 && carpet < 0.5, "{carpet}");
    }

    #[test]
    fn bad_time_constants_are_not_valid() {
        assert!(VibrationConfig::DEFAULT.is_valid());
        for bad in [f32::NAN, -1.0, f32::INFINITY] {
            let c = VibrationConfig {
                power_tau_s: bad,
                ..VibrationConfig::DEFAULT
            };
            assert!(!c.is_valid());
            let c = VibrationConfig {
                clip_sigmas: bad,
                ..VibrationConfig::DEFAULT
            };
            assert!(!c.is_valid());
        }
    }
}
