//! A skid steer's effective track, learned online from the wheels' turn
//! against the filter's.
//!
//! A skid-steered robot's wheels scrub sideways in a turn, so its yaw rate
//! is the wheels' speed difference over an effective track `chi * b` wider
//! than the physical one `b` (Mandow et al., "Experimental kinematics for
//! wheeled skid-steer mobile robots", IROS 2007: the expansion factor
//! `chi`, 1.5-2.2 on their floors; Martinez et al., "Approximating
//! kinematics for tracked mobile robots", IJRR 24(10), 2005: the
//! instantaneous centres of rotation of the two sides, which move with the
//! ground). `chi` changes with the floor, so it is estimated here, as a
//! scalar of its own beside the EKF, rather than as an EKF state: it is
//! observed only while the robot turns, needs a robust update (a wheel spin
//! on snow says nothing about the track), and outside the filter it leaves
//! the EKF's state, its covariance kernels and every differential-drive
//! robot's arithmetic as they are.
//!
//! The estimate is the ratio `a = chi b / b_k` of the effective track to the
//! filter's kinematic track `b_k` (the distance of its contact points, set
//! from the description's `track * track_factor`): the wheels' speed
//! difference `d = r_r w_r - r_l w_l` is `a b_k (w - c)` for the robot's
//! yaw rate `w` and the gyroscope's own z offset `c`, linear in `(a, e)`
//! with `e = -a c`: `d = a (w b_k) + e b_k`. The wheels' difference is the
//! measurement and the gyroscope's rate the regressor (the gyro is the
//! quieter of the two: with the wheels' noise in the regressor the
//! estimate would be biased, errors in variables). Per wheel sample: `d` is the
//! trapezoid of this and the previous sample's difference; `w` the mean of
//! the raw gyroscope's yaw rate (robot frame, not corrected by the filter's
//! bias) over the IMU steps since the previous sample. The raw rate keeps
//! the learner out of the loop through the filter's bias, which the wheel
//! rows move; left and right turns tell `a` from `e`. A two-state Kalman
//! filter with random walks (the floor changes) updates `(a, e)` from every
//! sample whose wheels move; a residual beyond [`SkidConfig::huber`]
//! standard deviations has its noise inflated (Huber weight), and `a` stays
//! within the description's bounds on `chi`.
//!
//! The wheel update then fuses the wheels with their speed difference
//! divided by `a` (the gain `g = 1 / a`) and their mean speed unchanged
//! ([`TrackScale::apply`]), the differential row's noise scaled by `g^2`
//! with it: the differential row `w b_k = g d` holds on the current floor,
//! and the gyroscope's bias is no longer asked to explain the skid.

use vslam_core::Timestamp;
use vslam_core::kinematics::rim;
use vslam_core::sensors::WheelRates;

use crate::state::{NominalState, Vec3};

/// How the effective track of a skid steer is learned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkidConfig {
    /// The physical track `b`, m (the one `chi` is relative to).
    pub track: f32,
    /// The nominal expansion factor `chi` (the description's
    /// `track_factor`), 1.
    pub nominal: f32,
    /// Smallest and largest `chi`, 1.
    pub bounds: [f32; 2],
    /// Initial standard deviation of the track ratio `a`, 1.
    pub ratio_std: f32,
    /// Random walk of `a`, 1/sqrt(s).
    pub ratio_walk: f32,
    /// Initial standard deviation of the offset term `e = -a c`, rad/s.
    pub offset_std: f32,
    /// Random walk of `e`, rad/s/sqrt(s).
    pub offset_walk: f32,
    /// Largest gyroscope offset `|c|`, rad/s (a MEMS gyro's is a few
    /// mrad/s; wheels that turn while the body does not are not an offset).
    pub max_offset: f32,
    /// Noise of an interval's mean yaw rate, rad/s.
    pub yaw_rate_std: f32,
    /// Noise of an interval's mean wheel speed difference, m/s.
    pub speed_std: f32,
    /// Smallest sum of the two rim speeds' magnitudes for a sample to be
    /// used (the wheels move), m/s.
    pub min_speed: f32,
    /// Normalised residual beyond which the Huber weight inflates the noise.
    pub huber: f32,
    /// Longest wheel interval used, ns (longer: restart the interval).
    pub max_interval_ns: u64,
}

impl SkidConfig {
    /// The learner for a skid steer of physical track `track` (m) and
    /// nominal factor `nominal`: `chi` within 1-4, `a` 30 % uncertain at
    /// first and walking 2 %/sqrt(s); the gyro offset 10 mrad/s at first,
    /// walking 0.1 mrad/s/sqrt(s), at most 50 mrad/s; yaw-rate noise 0.03 rad/s and speed
    /// noise 0.03 m/s per interval; used while the rims move faster than
    /// 0.02 m/s together; Huber beyond 2 sigma; intervals up to 0.5 s.
    pub const fn new(track: f32, nominal: f32) -> Self {
        SkidConfig {
            track,
            nominal,
            bounds: [1.0, 4.0],
            ratio_std: 0.3,
            ratio_walk: 0.02,
            offset_std: 0.01,
            offset_walk: 1.0e-4,
            max_offset: 0.05,
            yaw_rate_std: 0.03,
            speed_std: 0.03,
            min_speed: 0.02,
            huber: 2.0,
            max_interval_ns: 500_000_000,
        }
    }

    /// Whether every value is finite and positive and the bounds are ordered.
    pub fn is_valid(&self) -> bool {
        let pos = |v: f32| v.is_finite() && v > 0.0;
        let [lo, hi] = self.bounds;
        [
            self.track,
            self.nominal,
            lo,
            self.ratio_std,
            self.ratio_walk,
            self.offset_std,
            self.offset_walk,
            self.max_offset,
            self.yaw_rate_std,
            self.speed_std,
            self.min_speed,
            self.huber,
        ]
        .iter()
        .all(|v| pos(*v))
            && hi.is_finite()
            && hi >= lo
            && self.max_interval_ns > 0
    }
}

/// What the learner holds about the effective track.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackEstimate {
    /// The expansion factor `chi`: effective over physical track, 1.
    pub chi: f32,
    /// Its standard deviation, 1.
    pub chi_std: f32,
    /// The raw gyroscope's z offset the learner sees, rad/s.
    pub gyro_offset: f32,
    /// Samples that updated it.
    pub updates: u32,
    /// Of those, samples whose noise the Huber weight inflated.
    pub downweighted: u32,
}

/// The previous wheel sample: its time and its wheels' speed difference.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Previous {
    t: Timestamp,
    difference: f32,
}

/// The online estimate of a skid steer's effective track (see the module
/// documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackScale {
    config: SkidConfig,
    /// `(a, e)`.
    x: [f32; 2],
    /// Their covariance `[[aa, ae], [ae, ee]]` as `[aa, ae, ee]`.
    p: [f32; 3],
    previous: Option<Previous>,
    /// The raw yaw rate integrated since the previous wheel sample, rad,
    /// and the time it covers, s.
    turned: f32,
    elapsed: f32,
    updates: u32,
    downweighted: u32,
}

impl TrackScale {
    /// The learner at the description's nominal factor: `a` is 1 (the
    /// filter's contact points already sit at the nominal effective track).
    pub const fn new(config: SkidConfig) -> Self {
        TrackScale {
            config,
            x: [1.0, 0.0],
            p: [
                config.ratio_std * config.ratio_std,
                0.0,
                config.offset_std * config.offset_std,
            ],
            previous: None,
            turned: 0.0,
            elapsed: 0.0,
            updates: 0,
            downweighted: 0,
        }
    }

    /// The current gain `g = 1 / a` from the wheels' speed difference to
    /// the filter's kinematic track times its yaw rate.
    pub fn gain(&self) -> f32 {
        1.0 / self.x[0]
    }

    /// The current estimate with the filter's kinematic track `b_k` (m).
    pub fn estimate(&self, kinematic_track: f32) -> TrackEstimate {
        let [a, e] = self.x;
        let k = kinematic_track / self.config.track;
        TrackEstimate {
            chi: a * k,
            chi_std: libm::sqrtf(self.p[0].max(0.0)) * k,
            gyro_offset: -e / a,
            updates: self.updates,
            downweighted: self.downweighted,
        }
    }

    /// Adds one IMU step: the raw (not bias-corrected) gyroscope rate in
    /// the IMU frame, over `dt` seconds, seen in the robot frame of `x`.
    pub fn observe_imu(&mut self, x: &NominalState, gyro: &Vec3, dt: f32) {
        let yaw_rate = (x.q_rb * gyro).z;
        if yaw_rate.is_finite() && dt.is_finite() && dt > 0.0 {
            self.turned += yaw_rate * dt;
            self.elapsed += dt;
        }
    }

    /// Learns from one wheel sample at the filter's time `now` and state
    /// `x`, with the floor's kept fraction of the wheels' speed `keep`
    /// (1 - expected slip).
    pub fn observe(&mut self, x: &NominalState, rates: &WheelRates, now: Timestamp, keep: f32) {
        let (vl, vr) = (
            rim(x.radius_left, rates.left()),
            rim(x.radius_right, rates.right()),
        );
        let difference = keep * (vr - vl);
        let (turned, elapsed) = (self.turned, self.elapsed);
        (self.turned, self.elapsed) = (0.0, 0.0);
        let before = self.previous.replace(Previous { t: now, difference });
        let Some(before) = before else { return };
        let Some(dt_ns) = now.nanos_since(before.t) else {
            return;
        };
        if dt_ns == 0 || dt_ns > self.config.max_interval_ns || elapsed.is_nan() || elapsed <= 0.0 {
            return;
        }
        let dt = vslam_core::time::nanos_to_seconds(dt_ns);
        let c = self.config;
        // Random walks over the interval, whether or not the sample is used.
        self.p[0] += c.ratio_walk * c.ratio_walk * dt;
        self.p[2] += c.offset_walk * c.offset_walk * dt;
        let b_k = kinematic_track(x);
        if b_k.is_nan() || b_k <= 0.0 || libm::fabsf(vl) + libm::fabsf(vr) < c.min_speed {
            return;
        }
        let d = 0.5 * (before.difference + difference);
        let w = turned / elapsed;
        self.update(d, [w * b_k, b_k]);
    }

    /// The Kalman update of `(a, e)` with `d = h . (a, e)`, Huber-weighted,
    /// `a` held within the bounds.
    fn update(&mut self, d: f32, h: [f32; 2]) {
        let c = &self.config;
        let [a, e] = self.x;
        let [paa, pae, pee] = self.p;
        let [wb, b_k] = h;
        let residual = d - (a * wb + e * b_k);
        let r = c.speed_std * c.speed_std + a * a * b_k * b_k * c.yaw_rate_std * c.yaw_rate_std;
        // P h^T and h P h^T.
        let ph = [paa * wb + pae * b_k, pae * wb + pee * b_k];
        let hph = wb * ph[0] + b_k * ph[1];
        let s = hph + r;
        if !(s > 0.0 && residual.is_finite()) {
            return;
        }
        let z = libm::fabsf(residual) / libm::sqrtf(s);
        // Huber: beyond the threshold the noise grows with the residual.
        let r = if z > c.huber {
            self.downweighted = self.downweighted.saturating_add(1);
            r * (z / c.huber)
        } else {
            r
        };
        let s = hph + r;
        let k = [ph[0] / s, ph[1] / s];
        let x = [a + k[0] * residual, e + k[1] * residual];
        let p = [paa - k[0] * ph[0], pae - k[0] * ph[1], pee - k[1] * ph[1]];
        // The description's bounds on chi, as bounds on a.
        let [lo, hi] = c.bounds;
        let (a_min, a_max) = (lo * c.track / b_k, hi * c.track / b_k);
        let ok = x.iter().chain(p.iter()).all(|v| v.is_finite())
            && p[0] > 0.0
            && p[2] > 0.0
            && p[1] * p[1] < p[0] * p[2];
        if ok {
            // max/min rather than clamp: no panic whatever the bounds.
            let a = x[0].max(a_min).min(a_max);
            let e_max = a * c.max_offset;
            self.x = [a, x[1].max(-e_max).min(e_max)];
            self.p = p;
            self.updates = self.updates.saturating_add(1);
        }
    }

    /// The rates the wheel update fuses: the same mean rim speed, the speed
    /// difference times `g`.
    pub fn apply(&self, x: &NominalState, rates: &WheelRates) -> WheelRates {
        let (rl, rr) = (x.radius_left, x.radius_right);
        let (vl, vr) = (rim(rl, rates.left()), rim(rr, rates.right()));
        let mid = 0.5 * (vl + vr);
        let half = 0.5 * self.gain() * (vr - vl);
        let (wl, wr) = ((mid - half) / rl, (mid + half) / rr);
        WheelRates::new(rates.t(), wl, wr).unwrap_or(*rates)
    }
}

/// The filter's kinematic track: the distance of its contact points, m.
fn kinematic_track(x: &NominalState) -> f32 {
    (x.p_br - x.p_bl).norm()
}

#[cfg(test)]
mod tests;
