//! Sensor readings from the true motion: IMU (250 Hz), wheel encoders
//! (50 Hz), downward optical flow (100 Hz), each with its noise model.

use super::motion::{TRUTH_STEP_NS, TruthStep};
use super::world::Surface;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use vslam_core::Timestamp;
use vslam_core::sensors::{FlowSample, RawImuSample};

/// Standard gravity, m/s^2.
pub const GRAVITY: f64 = 9.81;

fn gauss(rng: &mut ChaCha8Rng, std: f64) -> f64 {
    Normal::new(0.0, std.max(0.0))
        .map(|n| n.sample(rng))
        .unwrap_or(0.0)
}

/// IMU noise model (continuous-time densities, as in an ASL `sensor.yaml`) and true biases.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuModel {
    /// Rate, Hz (must divide 1 kHz).
    pub rate_hz: f64,
    /// rad/s/sqrt(Hz).
    pub gyro_noise_density: f64,
    /// rad/s^2/sqrt(Hz).
    pub gyro_random_walk: f64,
    /// m/s^2/sqrt(Hz).
    pub accel_noise_density: f64,
    /// m/s^3/sqrt(Hz).
    pub accel_random_walk: f64,
    /// Initial gyroscope bias, rad/s.
    pub gyro_bias: [f64; 3],
    /// Initial accelerometer bias, m/s^2.
    pub accel_bias: [f64; 3],
    /// Scale-factor error of the gyroscope's z axis: it reads
    /// `(1 + k) w_z + b_z + n` (0.01 is 1 %, 3.6 degrees a turn).
    pub gyro_scale_error: f64,
}

impl ImuModel {
    /// A consumer MEMS IMU (BMI088-class), with the noise of the
    /// robot-vacuum preset ([`super::preset`]).
    pub fn mems() -> Self {
        let n = super::preset::preset().imu.noise;
        let d = super::preset::decimal;
        ImuModel {
            rate_hz: 250.0,
            gyro_noise_density: d(n.gyro_density),
            gyro_random_walk: d(n.gyro_random_walk),
            accel_noise_density: d(n.accel_density),
            accel_random_walk: d(n.accel_random_walk),
            gyro_bias: [0.004, -0.003, 0.005],
            accel_bias: [0.05, -0.04, 0.08],
            gyro_scale_error: 0.0,
        }
    }
}

/// Vertical vibration the floor adds to the accelerometer, m/s^2 standard deviation.
pub fn floor_vibration(s: Option<Surface>) -> f64 {
    match s {
        Some(Surface::Carpet) => 0.6,
        Some(Surface::Tile) => 0.15,
        Some(Surface::Wood) => 0.1,
        Some(Surface::Concrete) => 0.2,
        None => 0.0,
    }
}

/// IMU samples (IMU at the body origin, axes aligned with the body) and the
/// true biases at each sample. Each sample holds the mean of the true rate
/// and specific force over its output period (the truth steps after the
/// previous sample up to its own), as an IMU's decimation filter delivers
/// them: a sample read at one instant would carry an impulse (a stop against
/// an obstacle, one truth step long) over its whole period and change the
/// integrated velocity by a multiple of the real change.
pub fn imu(
    truth: &[TruthStep],
    m: &ImuModel,
    rng: &mut ChaCha8Rng,
) -> (Vec<RawImuSample>, Vec<[[f64; 3]; 2]>) {
    let mut imu = Imu::new(m);
    let mut out = Vec::new();
    let mut biases = Vec::new();
    for (i, s) in truth.iter().enumerate().step_by(imu.every) {
        let period = truth
            .get(i.saturating_sub(imu.every - 1)..=i)
            .unwrap_or(&[]);
        let (sample, bias) = imu.sample(period, s, rng);
        out.push(sample);
        biases.push(bias);
    }
    (out, biases)
}

/// The IMU one sample at a time: noise levels and the biases' random walk.
#[derive(Clone, Copy, Debug)]
pub struct Imu {
    /// Truth steps per sample.
    pub every: usize,
    gn: f64,
    an: f64,
    gw: f64,
    aw: f64,
    bg: [f64; 3],
    ba: [f64; 3],
    /// The z rate's scale-factor error ([`ImuModel::gyro_scale_error`]).
    gyro_scale_error: f64,
}

impl Imu {
    /// The IMU of model `m` at its initial biases.
    pub fn new(m: &ImuModel) -> Self {
        let every = ((1e9 / m.rate_hz) as u64 / TRUTH_STEP_NS).max(1) as usize;
        let dt = every as f64 * TRUTH_STEP_NS as f64 * 1e-9;
        Imu {
            every,
            gn: m.gyro_noise_density / dt.sqrt(),
            an: m.accel_noise_density / dt.sqrt(),
            gw: m.gyro_random_walk * dt.sqrt(),
            aw: m.accel_random_walk * dt.sqrt(),
            bg: m.gyro_bias,
            ba: m.accel_bias,
            gyro_scale_error: m.gyro_scale_error,
        }
    }

    /// The sample at truth step `s`, the mean over `period` (the truth
    /// steps after the previous sample up to `s`), and the true biases in it
    /// (gyro, accel); the biases walk on.
    pub fn sample(
        &mut self,
        period: &[TruthStep],
        s: &TruthStep,
        rng: &mut ChaCha8Rng,
    ) -> (RawImuSample, [[f64; 3]; 2]) {
        let (bg, ba) = (self.bg, self.ba);
        let (mean_f, mean_w) = mean_body_motion(period);
        let fb = [
            mean_f[0],
            mean_f[1],
            mean_f[2] + gauss(rng, floor_vibration(s.surface)),
        ];
        let gyro = [
            bg[0] + gauss(rng, self.gn),
            bg[1] + gauss(rng, self.gn),
            (1.0 + self.gyro_scale_error) * mean_w + bg[2] + gauss(rng, self.gn),
        ];
        let accel = [
            fb[0] + ba[0] + gauss(rng, self.an),
            fb[1] + ba[1] + gauss(rng, self.an),
            fb[2] + ba[2] + gauss(rng, self.an),
        ];
        for i in 0..3 {
            self.bg[i] += gauss(rng, self.gw);
            self.ba[i] += gauss(rng, self.aw);
        }
        (
            RawImuSample {
                t: Timestamp(s.t_ns),
                gyro: gyro.map(|v| v as f32),
                accel: accel.map(|v| v as f32),
            },
            [bg, ba],
        )
    }
}

/// The mean specific force (the (level) body's axes, m/s^2) and yaw rate
/// (rad/s) over `steps`; zeros and gravity for none.
fn mean_body_motion(steps: &[TruthStep]) -> ([f64; 3], f64) {
    let mut f = [0.0; 3];
    let mut w = 0.0;
    for s in steps {
        let (c, si) = (s.yaw.cos(), s.yaw.sin());
        // Specific force in the world, rotated into the (level) body.
        let fw = [s.acc[0], s.acc[1], s.acc[2] + GRAVITY];
        f[0] += c * fw[0] + si * fw[1];
        f[1] += -si * fw[0] + c * fw[1];
        f[2] += fw[2];
        w += s.w;
    }
    if steps.is_empty() {
        return ([0.0, 0.0, GRAVITY], 0.0);
    }
    let n = steps.len() as f64;
    (f.map(|v| v / n), w / n)
}

/// The true wheel angles (radians, cumulative, left and right) at `rate_hz`:
/// what the encoders are read at.
pub fn wheel_angles(truth: &[TruthStep], rate_hz: f64) -> Vec<(Timestamp, f64, f64)> {
    let every = ((1e9 / rate_hz) as u64 / TRUTH_STEP_NS).max(1) as usize;
    truth
        .iter()
        .step_by(every)
        .map(|s| (Timestamp(s.t_ns), s.wheel_angle[0], s.wheel_angle[1]))
        .collect()
}

/// The downward flow sensor: mounting and optics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowModel {
    /// Report rate, Hz.
    pub rate_hz: f64,
    /// Sensor origin in the body, metres (z is the height above the floor).
    pub t_bs: [f64; 3],
    /// Counts per radian of angular flow.
    pub counts_per_radian: f64,
    /// Relative scale noise of each report.
    pub scale_noise: f64,
}

impl FlowModel {
    /// The robot-vacuum preset's flow sensor
    /// ([`traction::vslam_core::robot::FlowDescription::robot_vacuum`]): a
    /// PAA5100JE 30 mm above the floor, 10 cm ahead of the axle, looking down
    /// (sensor x = body x, sensor y = body -y, sensor z = body -z).
    pub fn paa5100() -> Self {
        let flow = traction::vslam_core::robot::FlowDescription::robot_vacuum();
        let d = super::preset::decimal;
        let t = flow.mount.t_bs();
        FlowModel {
            rate_hz: 100.0,
            t_bs: [d(t.x), d(t.y), d(t.z)],
            counts_per_radian: d(flow.counts_per_radian),
            scale_noise: 0.02,
        }
    }

    /// `T_BS` row-major.
    pub fn t_bs_matrix(&self) -> [f32; 16] {
        let [x, y, z] = self.t_bs.map(|v| v as f32);
        [
            1., 0., 0., x, 0., -1., 0., y, 0., 0., -1., z, 0., 0., 0., 1.,
        ]
    }
}

/// Image quality a flow sensor reports over a surface: SQUAL mean and std, shutter.
pub fn flow_quality(s: Option<Surface>) -> (f64, f64, f64) {
    match s {
        Some(Surface::Wood) => (100.0, 8.0, 0x0200 as f64),
        Some(Surface::Carpet) => (60.0, 10.0, 0x0500 as f64),
        Some(Surface::Tile) => (35.0, 8.0, 0x0C00 as f64),
        Some(Surface::Concrete) => (110.0, 8.0, 0x0180 as f64),
        None => (10.0, 3.0, 0x1F80 as f64),
    }
}

/// Flow reports: counts since the previous report (sub-count remainders are
/// kept, as the chip does), zero counts when the report is invalid.
pub fn flow(truth: &[TruthStep], m: &FlowModel, rng: &mut ChaCha8Rng) -> Vec<FlowSample> {
    let mut flow = Flow::new(m);
    truth.iter().filter_map(|s| flow.step(s, m, rng)).collect()
}

/// The flow sensor one truth step at a time: the counts accumulated since
/// the last report.
#[derive(Clone, Copy, Debug)]
pub struct Flow {
    every: usize,
    i: usize,
    acc: [f64; 2],
}

impl Flow {
    /// A sensor of model `m` that has seen nothing yet.
    pub fn new(m: &FlowModel) -> Self {
        Flow {
            every: ((1e9 / m.rate_hz) as u64 / TRUTH_STEP_NS).max(1) as usize,
            i: 0,
            acc: [0.0; 2],
        }
    }

    /// Takes truth step `s` (the next one); gives the report read at it, if any.
    pub fn step(
        &mut self,
        s: &TruthStep,
        m: &FlowModel,
        rng: &mut ChaCha8Rng,
    ) -> Option<FlowSample> {
        let h = m.t_bs[2];
        let dt = TRUTH_STEP_NS as f64 * 1e-9;
        let i = self.i;
        self.i += 1;
        let acc = &mut self.acc;
        // Sensor velocity in the body: v + w x r; then into the sensor frame.
        let vb = [s.v - s.w * m.t_bs[1], s.w * m.t_bs[0], 0.0];
        let vs = [vb[0], -vb[1]];
        for k in 0..2 {
            acc[k] += vs[k] * dt / h * m.counts_per_radian;
        }
        if !i.is_multiple_of(self.every) || i == 0 {
            return None;
        }
        // Lifted, the sensor sees no floor in focus.
        let floor = if s.episode == Some(super::script::EpisodeKind::Lifted) {
            None
        } else {
            s.surface
        };
        let (sq_mean, sq_std, shutter) = flow_quality(floor);
        let squal = (sq_mean + gauss(rng, sq_std)).clamp(0.0, 255.0) as u8;
        let shutter = (shutter * (1.0 + gauss(rng, 0.05))).clamp(0.0, 8191.0) as u16;
        let mut sample = FlowSample {
            t: Timestamp(s.t_ns),
            squal,
            shutter,
            motion: true,
            ..FlowSample::default()
        };
        if sample.is_valid() {
            let k = 1.0 + gauss(rng, m.scale_noise);
            let dx = (acc[0] * k).trunc();
            let dy = (acc[1] * k).trunc();
            acc[0] -= dx / k;
            acc[1] -= dy / k;
            sample.dx = dx.clamp(i16::MIN as f64, i16::MAX as f64) as i16;
            sample.dy = dy.clamp(i16::MIN as f64, i16::MAX as f64) as i16;
        } else {
            *acc = [0.0; 2];
        }
        sample.motion = sample.dx != 0 || sample.dy != 0;
        Some(sample)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// A robot driving at 0.3 m/s along +x that stops dead at step 1000
    /// (a stuck episode), with accelerations by central differences.
    fn sudden_stop() -> Vec<TruthStep> {
        let dt = TRUTH_STEP_NS as f64 * 1e-9;
        let mut steps: Vec<TruthStep> = (0..2000u64)
            .map(|i| {
                let v = if i < 1000 { 0.3 } else { 0.0 };
                TruthStep {
                    t_ns: i * TRUTH_STEP_NS,
                    p: [0.0; 3],
                    yaw: 0.0,
                    v,
                    w: 0.0,
                    vel: [v, 0.0, 0.0],
                    acc: [0.0; 3],
                    surface: None,
                    wheel_angle: [0.0; 2],
                    episode: None,
                }
            })
            .collect();
        for i in 1..steps.len() - 1 {
            steps[i].acc[0] = (steps[i + 1].vel[0] - steps[i - 1].vel[0]) / (2.0 * dt);
        }
        steps
    }

    #[test]
    fn an_impulse_integrates_to_the_velocity_change() {
        let model = ImuModel {
            gyro_noise_density: 0.0,
            gyro_random_walk: 0.0,
            accel_noise_density: 0.0,
            accel_random_walk: 0.0,
            gyro_bias: [0.0; 3],
            gyro_scale_error: 0.0,
            accel_bias: [0.0; 3],
            ..ImuModel::mems()
        };
        let (samples, _) = imu(&sudden_stop(), &model, &mut ChaCha8Rng::seed_from_u64(1));
        let dt = 1.0 / model.rate_hz;
        let dv: f64 = samples.iter().map(|s| f64::from(s.accel[0]) * dt).sum();
        // Read at single instants, the one sample on the impulse carried
        // -150 m/s^2 over 4 ms: -0.6 m/s.
        assert!((dv + 0.3).abs() < 1e-3, "velocity change {dv}");
    }
}
