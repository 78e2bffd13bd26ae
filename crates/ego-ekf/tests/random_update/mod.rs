//! Seeded random filter states and covariances, the `f64` textbook update
//! used as the oracle, and the error measures: shared by the tests that
//! compare the fast update paths with the dense formulas (`fast_update.rs`,
//! `wheel_fast.rs`), and by `clone.rs` for its random covariances.
#![allow(dead_code)]

use ego_ekf::state::{CTH, Covariance, DIM, ErrorState, NominalState, Quat, RB, TH, Vec3};
use ego_ekf::update::Measurement;
use nalgebra::{Matrix3, SMatrix};

/// A small seeded generator (splitmix64), uniform in `[-0.5, 0.5)`.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    }
    pub fn vec3(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * scale
    }
}

/// A random symmetric positive-definite covariance with standard deviations
/// spread over three decades, 1e-3 to 1 (as in the filter: radii in mm, attitude in
/// mrad, positions in cm) and correlations up to about 0.9.
pub fn random_covariance(rng: &mut Rng) -> Covariance {
    let a = SMatrix::<f32, DIM, DIM>::from_fn(|_, _| rng.next());
    let c = a * a.transpose() + Covariance::identity() * 0.3;
    let d = ErrorState::from_fn(|_, _| 10f32.powf(-3.0 + 3.0 * (rng.next() + 0.5)));
    let n = c.diagonal().map(|v| 1.0 / v.sqrt());
    let corr = c.component_mul(&(n * n.transpose()));
    let p = corr.component_mul(&(d * d.transpose()));
    // Exactly symmetric, as the filter keeps it.
    (p + p.transpose()) * 0.5
}

/// A random nominal state near a driving robot.
pub fn random_state(rng: &mut Rng) -> NominalState {
    let q_wb = Quat::from_scaled_axis(rng.vec3(0.2) + Vec3::new(0.0, 0.0, 6.0 * rng.next()));
    NominalState {
        p_wb: rng.vec3(4.0),
        v_wb: rng.vec3(0.6),
        q_wb,
        accel_bias: rng.vec3(0.05),
        gyro_bias: rng.vec3(0.005),
        gravity: Vec3::new(0.0, 0.0, -9.81) + rng.vec3(0.02),
        gyro_scale: 0.004,
        clone_p_wb: rng.vec3(4.0),
        clone_q_wb: q_wb * Quat::from_scaled_axis(rng.vec3(0.01)),
        p_bl: Vec3::new(0.0, 0.115, -0.06) + rng.vec3(0.01),
        p_br: Vec3::new(0.0, -0.115, -0.06) + rng.vec3(0.01),
        q_rb: Quat::from_scaled_axis(rng.vec3(0.05)),
        radius_left: 0.035 + 0.001 * rng.next(),
        radius_right: 0.035 + 0.001 * rng.next(),
    }
}

/// Largest `|a_ij - b_ij| / sqrt(s_i s_j)` with `s` the size of the numbers
/// the step combines into entry `i`: its variance before (`prior`; an update
/// that shrinks a variance by orders of magnitude leaves rounding of the
/// prior's size, in any `f32` formula) and after (`b`), and for a rotation
/// error the largest variance of its block (the reset mixes the block).
pub fn normalised_error(a: &Covariance, b: &Covariance, prior: &Covariance) -> f32 {
    let block_max = |i: usize| {
        [TH, CTH, RB]
            .into_iter()
            .filter(|r| (*r..*r + 3).contains(&i))
            .flat_map(|r| (r..r + 3).map(|k| prior[(k, k)]))
            .fold(0.0f32, f32::max)
    };
    let s = ErrorState::from_fn(|i, _| prior[(i, i)].max(b[(i, i)]).max(block_max(i)).sqrt());
    let scale = s * s.transpose();
    (a - b)
        .iter()
        .zip(scale.iter())
        .map(|(e, s)| e.abs() / s)
        .fold(0.0, f32::max)
}

/// Largest difference of two error states taking `a` to `b`, for the
/// additive parts (positions, velocities, biases, gravity, contact points,
/// radii) and the rotations (angle of `a^-1 b`).
pub fn state_error(a: &NominalState, b: &NominalState) -> f32 {
    let v = [
        (a.p_wb - b.p_wb).amax(),
        (a.v_wb - b.v_wb).amax(),
        (a.accel_bias - b.accel_bias).amax(),
        (a.gyro_bias - b.gyro_bias).amax(),
        (a.gravity - b.gravity).amax(),
        (a.clone_p_wb - b.clone_p_wb).amax(),
        (a.p_bl - b.p_bl).amax(),
        (a.p_br - b.p_br).amax(),
        (a.radius_left - b.radius_left).abs(),
        (a.radius_right - b.radius_right).abs(),
        a.q_wb.angle_to(&b.q_wb),
        a.clone_q_wb.angle_to(&b.clone_q_wb),
        a.q_rb.angle_to(&b.q_rb),
    ];
    v.into_iter().fold(0.0, f32::max)
}

/// The dense textbook update evaluated in `f64`: `K = P H^T S^-1`, the
/// Joseph form, `dx = K y`, injection and the dense reset `G P G^T`. The
/// oracle: the `f32` dense reference ([`gated_update_dense`]) loses up to
/// 0.5 % of the NIS to the inverse of an ill-conditioned `S`, the fast
/// update (Cholesky) much less.
pub fn oracle<const M: usize>(
    x0: &NominalState,
    p0: &Covariance,
    m: &Measurement<M>,
) -> (NominalState, SMatrix<f64, DIM, DIM>, f64) {
    let p = p0.cast::<f64>();
    let h = m.h.cast::<f64>();
    let r = m.noise.cast::<f64>();
    let y = m.residual.cast::<f64>();
    let s_inv = (h * p * h.transpose() + r).try_inverse().unwrap();
    let nis = (y.transpose() * s_inv * y).x;
    let k = p * h.transpose() * s_inv;
    let ikh = SMatrix::<f64, DIM, DIM>::identity() - k * h;
    let joseph = ikh * p * ikh.transpose() + k * r * k.transpose();
    let dx = k * y;
    let mut g = SMatrix::<f64, DIM, DIM>::identity();
    for b in [TH, CTH, RB] {
        let a = dx.fixed_rows::<3>(b) * 0.5;
        let block = Matrix3::identity() - a.cross_matrix();
        g.fixed_view_mut::<3, 3>(b, b).copy_from(&block);
    }
    let mut x = *x0;
    x.inject(&dx.cast::<f32>());
    (x, g * joseph * g.transpose(), nis)
}
