//! Monte Carlo bookkeeping for the consistency tests: drawing a true robot,
//! its sensor errors and a start state from the filter's priors, and the
//! time-averaged NEES (ANEES) of error blocks over seeded runs against the
//! two-sided 95 % chi-square bounds (Bar-Shalom, Li & Kirubarajan,
//! *Estimation with Applications to Tracking and Navigation*, 2001,
//! sec. 5.4.2).

use ego_ekf::state::{Covariance, Quat, TH, Vec3};
use ego_ekf::{ExplicitStart, FilterConfig};

use super::{Rng, Sim, SimNoise, SimRobot, chi2_quantile};

/// Draws a true robot and noise from the filter's priors, and a start state
/// whose error is drawn from the initial covariance. The gyro's z scale
/// factor is drawn from its prior when the filter estimates it, else zero.
pub fn draw(seed: u64, c: &FilterConfig) -> (Sim, ExplicitStart) {
    let mut rng = Rng::new(seed ^ 0xABCD);
    let r = &c.robot;
    let i = &c.init;
    let robot = SimRobot {
        p_bl: r.p_bl + rng.vec3(r.contact_std as f64),
        p_br: r.p_br + rng.vec3(r.contact_std as f64),
        q_rb: r.q_rb * Quat::from_scaled_axis(rng.vec3(r.rotation_std as f64)),
        radius_left: r.radius as f64 + rng.normal() * r.radius_std as f64,
        radius_right: r.radius as f64 + rng.normal() * r.radius_std as f64,
    };
    let noise = SimNoise {
        accel_density: c.imu.noise.accel_density as f64,
        gyro_density: c.imu.noise.gyro_density as f64,
        accel_bias: rng.vec3(i.accel_bias_std as f64),
        gyro_bias: rng.vec3(i.gyro_bias_std as f64),
        accel_random_walk: c.imu.noise.accel_random_walk as f64,
        gyro_random_walk: c.imu.noise.gyro_random_walk as f64,
        wheel_std: c.grip.forward_std() as f64,
        flow_std: 0.005,
    };
    let mut sim = Sim::new(seed, noise, robot);
    if c.imu.estimate_gyro_scale {
        sim.gyro_scale = rng.normal() * i.gyro_scale_std as f64;
        sim.gyro_scale_random_walk = c.imu.gyro_scale_random_walk as f64;
    }
    let truth = sim.truth();
    let dth = Vec3::new(
        (rng.normal() * i.tilt_std as f64) as f32,
        (rng.normal() * i.tilt_std as f64) as f32,
        (rng.normal() * i.yaw_std as f64) as f32,
    );
    let start = ExplicitStart {
        t: truth.t,
        p_wb: truth.p_wb + rng.vec3(i.position_std as f64),
        v_wb: truth.v_wb + rng.vec3(i.velocity_std as f64),
        q_wb: truth.q_wb * Quat::from_scaled_axis(dth),
        accel_bias: Vec3::zeros(),
        gyro_bias: Vec3::zeros(),
    };
    (sim, start)
}

/// NEES of a 1-D error with variance `var`.
pub fn nees1(err: f64, var: f64) -> f64 {
    if var > 0.0 {
        err * err / var
    } else {
        f64::INFINITY
    }
}

/// The world-frame yaw error and its variance from the local attitude
/// error `e_th` of the estimate `q_est` and the covariance `p`:
/// `(R e_th)_z` and `(R P_thth R^T)_zz`.
pub fn yaw_error(e_th: &Vec3, q_est: &Quat, p: &Covariance) -> (f64, f64) {
    let r = q_est.to_rotation_matrix().into_inner().cast::<f64>();
    let block = p.fixed_view::<3, 3>(TH, TH).into_owned().cast::<f64>();
    let row = r.row(2).into_owned();
    let e = (row * e_th.cast::<f64>())[(0, 0)];
    let var = (row * block * row.transpose())[(0, 0)];
    (e, var)
}

/// One error block's NEES summed over the runs at each checkpoint.
pub struct Series {
    pub name: &'static str,
    pub dof: f64,
    sums: Vec<f64>,
}

/// The time-averaged NEES of one block and the fraction of checkpoints
/// whose run-averaged NEES lies inside the bounds.
#[derive(Clone, Copy, Debug)]
pub struct Summary {
    pub name: &'static str,
    pub mean: f64,
    pub inside: usize,
    /// Checkpoints above the upper bound (overconfident).
    pub above: usize,
    pub checkpoints: usize,
    pub lo: f64,
    pub hi: f64,
}

impl Summary {
    /// Whether the time-averaged ANEES lies inside the bounds and at least
    /// `fraction` of the checkpoints do.
    pub fn passes(&self, fraction: f64) -> bool {
        self.mean >= self.lo
            && self.mean <= self.hi
            && self.inside as f64 >= fraction * self.checkpoints as f64
    }
}

/// The NEES of several blocks at `checkpoints` times over `runs` runs.
pub struct Anees {
    runs: usize,
    pub series: Vec<Series>,
}

impl Anees {
    /// Blocks `(name, degrees of freedom)`, `checkpoints` per run.
    pub fn new(blocks: &[(&'static str, usize)], checkpoints: usize, runs: usize) -> Self {
        Anees {
            runs,
            series: blocks
                .iter()
                .map(|&(name, dof)| Series {
                    name,
                    dof: dof as f64,
                    sums: vec![0.0; checkpoints],
                })
                .collect(),
        }
    }

    /// Adds one run's NEES `values` (in the blocks' order) at `checkpoint`.
    pub fn add(&mut self, checkpoint: usize, values: &[f64]) {
        for (s, v) in self.series.iter_mut().zip(values) {
            if let Some(slot) = s.sums.get_mut(checkpoint) {
                *slot += v;
            }
        }
    }

    /// Each block's summary against the two-sided 95 % bounds of the
    /// chi-square with `dof * runs` degrees of freedom divided by `runs`;
    /// printed with the run-averaged series.
    pub fn summaries(&self) -> Vec<Summary> {
        let n = self.runs as f64;
        self.series
            .iter()
            .map(|s| {
                let lo = chi2_quantile(s.dof * n, -1.96) / n;
                let hi = chi2_quantile(s.dof * n, 1.96) / n;
                let series: Vec<f64> = s.sums.iter().map(|v| v / n).collect();
                let inside = series.iter().filter(|v| **v >= lo && **v <= hi).count();
                let above = series.iter().filter(|v| **v > hi).count();
                let mean = series.iter().sum::<f64>() / series.len().max(1) as f64;
                println!(
                    "{}: mean ANEES {mean:.2} in [{lo:.2}, {hi:.2}], inside {inside}/{} \
                     ({above} above); series {:?}",
                    s.name,
                    series.len(),
                    series
                        .iter()
                        .map(|v| (v * 100.0).round() / 100.0)
                        .collect::<Vec<_>>()
                );
                Summary {
                    name: s.name,
                    mean,
                    inside,
                    above,
                    checkpoints: series.len(),
                    lo,
                    hi,
                }
            })
            .collect()
    }
}
