//! A small simulator for the filter tests: a differential-drive robot on a
//! plane driving curves with stops, an IMU with white noise and constant
//! biases at 250 Hz, wheel rates with noise at 50 Hz, and a downward flow
//! sensor at 25 Hz. Seeded, deterministic.
#![allow(dead_code)]

pub mod monte_carlo;

use ego_ekf::state::{Quat, STANDARD_GRAVITY, Vec3};
use nalgebra::UnitQuaternion;
use vslam_core::Timestamp;
use vslam_core::geometry::Extrinsics;
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, WheelRates};

/// splitmix64 + Box-Muller: enough randomness for a seeded test.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1))
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
    pub fn vec3(&mut self, std: f64) -> Vec3 {
        Vec3::new(
            (self.normal() * std) as f32,
            (self.normal() * std) as f32,
            (self.normal() * std) as f32,
        )
    }
}

/// Sensor noise of the simulation.
#[derive(Clone, Copy, Debug)]
pub struct SimNoise {
    pub accel_density: f64,
    pub gyro_density: f64,
    pub accel_bias: Vec3,
    pub gyro_bias: Vec3,
    /// Accelerometer bias random walk, m/s^3/sqrt(Hz).
    pub accel_random_walk: f64,
    /// Gyroscope bias random walk, rad/s^2/sqrt(Hz).
    pub gyro_random_walk: f64,
    /// Per-wheel forward speed noise, m/s.
    pub wheel_std: f64,
    /// Flow velocity noise, m/s (before count quantisation).
    pub flow_std: f64,
}

/// The robot's true geometry.
#[derive(Clone, Copy, Debug)]
pub struct SimRobot {
    pub p_bl: Vec3,
    pub p_br: Vec3,
    pub q_rb: Quat,
    pub radius_left: f64,
    pub radius_right: f64,
}

/// One true state at a time.
#[derive(Clone, Copy, Debug)]
pub struct Truth {
    pub t: Timestamp,
    pub p_wb: Vec3,
    pub v_wb: Vec3,
    pub q_wb: Quat,
}

/// What happens at one IMU tick.
pub struct Tick {
    pub imu: ImuSample,
    pub truth: Truth,
    pub wheel: Option<WheelRates>,
    pub flow: Option<FlowSample>,
}

pub const IMU_DT_NS: u64 = 4_000_000;
pub const FLOW_CPR: f32 = 500.0;
pub const FLOW_HEIGHT: f32 = 0.03;

pub fn flow_optics() -> FlowOptics {
    let mount = Extrinsics::new(
        nalgebra::Rotation3::identity(),
        Vec3::new(0.10, 0.0, FLOW_HEIGHT),
    )
    .unwrap();
    FlowOptics::new(FLOW_CPR, FLOW_HEIGHT, mount).unwrap()
}

/// Planar differential-drive motion in the robot frame with rate limits.
pub struct Sim {
    pub rng: Rng,
    pub noise: SimNoise,
    pub robot: SimRobot,
    // robot origin on the floor
    x: f64,
    y: f64,
    yaw: f64,
    v: f64,
    r: f64,
    v_cmd: f64,
    r_cmd: f64,
    seg_left: f64,
    stopping: bool,
    k: u64,
    flow_acc: [f64; 2],
    pub with_flow: bool,
    /// The gyro's z scale-factor error `k` (it reads `(1 + k) w_z + b_z`).
    pub gyro_scale: f64,
    /// Random walk of `k`, 1/sqrt(s).
    pub gyro_scale_random_walk: f64,
    pub drive_time: f64,
    pub stop_time: f64,
}

const ACCEL_LIMIT: f64 = 0.6;
const YAW_ACCEL_LIMIT: f64 = 2.0;

fn rot_z(yaw: f64) -> nalgebra::Matrix3<f64> {
    let (s, c) = yaw.sin_cos();
    nalgebra::Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

fn to64(v: &Vec3) -> nalgebra::Vector3<f64> {
    v.cast::<f64>()
}

impl Sim {
    pub fn new(seed: u64, noise: SimNoise, robot: SimRobot) -> Self {
        Sim {
            rng: Rng::new(seed),
            noise,
            robot,
            x: 0.0,
            y: 0.0,
            yaw: 0.0,
            v: 0.0,
            r: 0.0,
            v_cmd: 0.0,
            r_cmd: 0.0,
            seg_left: 1.0,
            stopping: true,
            k: 0,
            flow_acc: [0.0; 2],
            with_flow: false,
            gyro_scale: 0.0,
            gyro_scale_random_walk: 0.0,
            drive_time: 6.0,
            stop_time: 1.5,
        }
    }

    fn r_rb(&self) -> nalgebra::Matrix3<f64> {
        self.robot
            .q_rb
            .to_rotation_matrix()
            .into_inner()
            .cast::<f64>()
    }

    fn p_mid(&self) -> nalgebra::Vector3<f64> {
        (to64(&self.robot.p_bl) + to64(&self.robot.p_br)) * 0.5
    }

    /// The true state now.
    pub fn truth(&self) -> Truth {
        let r_wr = rot_z(self.yaw);
        let r_rb = self.r_rb();
        let t_ri = -(r_rb * self.p_mid());
        let o = nalgebra::Vector3::new(self.x, self.y, 0.0);
        let p = o + r_wr * t_ri;
        let w = nalgebra::Vector3::new(0.0, 0.0, self.r);
        let v_o = r_wr * nalgebra::Vector3::new(self.v, 0.0, 0.0);
        let v = v_o + w.cross(&(r_wr * t_ri));
        let r_wb = r_wr * r_rb;
        Truth {
            t: Timestamp(self.k * IMU_DT_NS),
            p_wb: p.cast::<f32>(),
            v_wb: v.cast::<f32>(),
            q_wb: UnitQuaternion::from_matrix(&r_wb.cast::<f32>()),
        }
    }

    fn command(&mut self, dt: f64) {
        self.seg_left -= dt;
        if self.seg_left <= 0.0 {
            if self.stopping {
                self.stopping = false;
                self.v_cmd = self.rng.range(0.1, 0.35);
                self.r_cmd = self.rng.range(-0.8, 0.8);
                self.seg_left = self.drive_time * self.rng.range(0.5, 1.0);
            } else if self.rng.uniform() < 0.4 {
                self.stopping = true;
                self.v_cmd = 0.0;
                self.r_cmd = 0.0;
                self.seg_left = self.stop_time + 1.5;
            } else {
                self.v_cmd = self.rng.range(0.05, 0.35);
                self.r_cmd = self.rng.range(-1.0, 1.0);
                self.seg_left = self.drive_time * self.rng.range(0.3, 1.0);
            }
        }
    }

    /// (v_dot, r_dot) over the next sub-step toward the commands.
    fn rates(&self) -> (f64, f64) {
        let h = IMU_DT_NS as f64 * 1e-9;
        let dv = (self.v_cmd - self.v).clamp(-ACCEL_LIMIT * h, ACCEL_LIMIT * h) / h;
        let dr = (self.r_cmd - self.r).clamp(-YAW_ACCEL_LIMIT * h, YAW_ACCEL_LIMIT * h) / h;
        (dv, dr)
    }

    fn substep(&mut self, h: f64, v_dot: f64, r_dot: f64) {
        // Midpoint integration of the unicycle.
        let v_mid = self.v + 0.5 * h * v_dot;
        let r_mid = self.r + 0.5 * h * r_dot;
        let yaw_mid = self.yaw + 0.5 * h * r_mid;
        self.x += h * v_mid * yaw_mid.cos();
        self.y += h * v_mid * yaw_mid.sin();
        self.yaw += h * r_mid;
        self.v += h * v_dot;
        self.r += h * r_dot;
    }

    /// Advances one IMU period and returns the samples of that tick.
    pub fn tick(&mut self) -> Tick {
        let dt = IMU_DT_NS as f64 * 1e-9;
        self.command(dt);
        let (v_dot, r_dot) = self.rates();
        // Two sub-steps; the IMU reads at the midpoint of the interval.
        self.substep(0.5 * dt, v_dot, r_dot);
        let r_wr = rot_z(self.yaw);
        let r_rb = self.r_rb();
        let r_wb = r_wr * r_rb;
        let t_ri = -(r_rb * self.p_mid());
        let w = nalgebra::Vector3::new(0.0, 0.0, self.r);
        let wd = nalgebra::Vector3::new(0.0, 0.0, r_dot);
        let a_o = r_wr * nalgebra::Vector3::new(v_dot, self.v * self.r, 0.0);
        let arm = r_wr * t_ri;
        let a = a_o + wd.cross(&arm) + w.cross(&w.cross(&arm));
        let g = nalgebra::Vector3::new(0.0, 0.0, -(STANDARD_GRAVITY as f64));
        let f_b = r_wb.transpose() * (a - g);
        let mut w_b = r_wb.transpose() * w;
        w_b.z *= 1.0 + self.gyro_scale;
        self.substep(0.5 * dt, v_dot, r_dot);
        if self.v.abs() < 1e-12 {
            self.v = 0.0;
        }
        if self.r.abs() < 1e-12 {
            self.r = 0.0;
        }
        self.k += 1;
        let t = Timestamp(self.k * IMU_DT_NS);
        let sa = self.noise.accel_density / dt.sqrt();
        let sg = self.noise.gyro_density / dt.sqrt();
        let mut accel = [0f32; 3];
        let mut gyro = [0f32; 3];
        for i in 0..3 {
            accel[i] = (f_b[i] + self.noise.accel_bias[i] as f64 + sa * self.rng.normal()) as f32;
            gyro[i] = (w_b[i] + self.noise.gyro_bias[i] as f64 + sg * self.rng.normal()) as f32;
        }
        let imu = ImuSample::new(t, gyro, accel).unwrap();
        let (ra, rg) = (
            self.noise.accel_random_walk * dt.sqrt(),
            self.noise.gyro_random_walk * dt.sqrt(),
        );
        let (da, dg) = (self.rng.vec3(ra), self.rng.vec3(rg));
        self.noise.accel_bias += da;
        self.noise.gyro_bias += dg;
        if self.gyro_scale_random_walk > 0.0 {
            self.gyro_scale += self.gyro_scale_random_walk * dt.sqrt() * self.rng.normal();
        }

        // Wheels at 50 Hz: forward speed of each contact point, robot frame.
        let wheel = self.k.is_multiple_of(5).then(|| {
            let c_l = r_rb * (to64(&self.robot.p_bl) - self.p_mid());
            let c_r = r_rb * (to64(&self.robot.p_br) - self.p_mid());
            let stopped = self.v.abs() < 1e-9 && self.r.abs() < 1e-9;
            let n = if stopped { 0.0 } else { self.noise.wheel_std };
            let sl = self.v - self.r * c_l.y + n * self.rng.normal();
            let sr = self.v - self.r * c_r.y + n * self.rng.normal();
            WheelRates::new(
                t,
                (sl / self.robot.radius_left) as f32,
                (sr / self.robot.radius_right) as f32,
            )
            .unwrap()
        });

        // Flow at 100 Hz, integrated and quantised to counts.
        let optics = flow_optics();
        let t_rs = to64(optics.mount().t_bs());
        let v_s = nalgebra::Vector3::new(self.v, 0.0, 0.0)
            + nalgebra::Vector3::new(0.0, 0.0, self.r).cross(&t_rs);
        for (acc, vi) in self.flow_acc.iter_mut().zip([v_s.x, v_s.y]) {
            *acc += vi * dt / FLOW_HEIGHT as f64 * FLOW_CPR as f64;
        }
        let flow = (self.with_flow && self.k.is_multiple_of(10)).then(|| {
            let fdt = 10.0 * dt;
            let noise = self.noise.flow_std * fdt / FLOW_HEIGHT as f64 * FLOW_CPR as f64;
            let mut counts = [0i16; 2];
            for (c, acc) in counts.iter_mut().zip(self.flow_acc.iter_mut()) {
                let total = *acc + noise * self.rng.normal();
                let q = total.round();
                *acc -= q;
                *c = q as i16;
            }
            FlowSample {
                t,
                dx: counts[0],
                dy: counts[1],
                squal: 150,
                shutter: 0x0100,
                motion: true,
                ..FlowSample::default()
            }
        });
        Tick {
            imu,
            truth: self.truth(),
            wheel,
            flow,
        }
    }
}

/// Chi-square quantile by the Wilson-Hilferty approximation.
pub fn chi2_quantile(dof: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + z * a.sqrt()).powi(3)
}

/// NEES of a 3-D error block of the covariance.
pub fn nees3(err: &Vec3, p: &ego_ekf::state::Covariance, start: usize) -> f64 {
    let block = p
        .fixed_view::<3, 3>(start, start)
        .into_owned()
        .cast::<f64>();
    let e = err.cast::<f64>();
    match block.try_inverse() {
        Some(inv) => (e.transpose() * inv * e)[(0, 0)],
        None => f64::INFINITY,
    }
}

/// Attitude error `Log(R_est^T R_true)` (local, as the filter's).
pub fn attitude_error(est: &Quat, truth: &Quat) -> Vec3 {
    (est.inverse() * truth).scaled_axis()
}
