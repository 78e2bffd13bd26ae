//! IMU propagation of the nominal state and of the error-state covariance.
//!
//! Implements Solà, "Quaternion kinematics for the error-state Kalman
//! filter" (2017): the nominal kinematics integrated by Euler steps
//! (sec. 5.4.1, eq. 260: position with the half-acceleration term,
//! quaternion by the exponential map of the bias-corrected rate) and the
//! discrete error-state transition and process noise (sec. 5.4.3 and 7.2,
//! eqs. 269-270: `F_x`, and `Q_i` from the noise densities and random walks
//! integrated over the step).
//!
//! The covariance step exploits the block structure: `F` is identity except
//! the blocks `F_pv = I dt`, `F_vtheta = -R [a]x dt`, `F_vab = -R dt`,
//! `F_vg = I dt`, `F_thetatheta = Exp(w dt)^T`, `F_thetawb = -I dt` of the
//! IMU part, and the clone and robot blocks have `F = I`. So `F P F^T` is a
//! few 3-row operations on `P` followed by the same operations on columns:
//! the IMU block and the IMU-to-rest cross terms change, the rest-to-rest
//! block only gains its small `Q`. [`propagate_covariance_dense`] is the
//! dense reference the tests compare against.

use nalgebra::{Matrix3, Rotation3};

use crate::config::{ImuNoise, RobotPrior};
use crate::covariance::skew;
use crate::state::{
    BA, BG, CL, Covariance, DIM, ErrorState, G, NominalState, P, RAD, RB, TH, V, Vec3,
};

/// The non-identity blocks of the discrete error-state transition `F_x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transition {
    /// Step, s.
    pub dt: f32,
    /// `dv / dtheta = -R [a_m - a_b]x dt`.
    pub f_vth: Matrix3<f32>,
    /// `dv / da_b = -R dt`.
    pub f_vba: Matrix3<f32>,
    /// `dtheta / dtheta = R{(w_m - w_b) dt}^T`.
    pub f_thth: Matrix3<f32>,
}

impl Transition {
    /// The transition for one step from the attitude `r_wb` at the start of
    /// the step and the bias-corrected samples.
    pub fn new(r_wb: &Matrix3<f32>, accel: &Vec3, gyro: &Vec3, dt: f32) -> Self {
        Transition {
            dt,
            f_vth: -(r_wb * skew(accel)) * dt,
            f_vba: -r_wb * dt,
            f_thth: Rotation3::new(gyro * dt).matrix().transpose(),
        }
    }

    /// The full 35x35 `F_x` (for the dense reference and tests).
    pub fn dense(&self) -> Covariance {
        let mut f = Covariance::identity();
        let i3 = Matrix3::<f32>::identity();
        f.fixed_view_mut::<3, 3>(P, V).copy_from(&(i3 * self.dt));
        f.fixed_view_mut::<3, 3>(V, TH).copy_from(&self.f_vth);
        f.fixed_view_mut::<3, 3>(V, BA).copy_from(&self.f_vba);
        f.fixed_view_mut::<3, 3>(V, G).copy_from(&(i3 * self.dt));
        f.fixed_view_mut::<3, 3>(TH, TH).copy_from(&self.f_thth);
        f.fixed_view_mut::<3, 3>(TH, BG).copy_from(&(-i3 * self.dt));
        f
    }
}

/// The diagonal of the discrete process noise `Q` for a step of `dt`
/// seconds: `V_i = sigma_a^2 dt`, `Theta_i = sigma_w^2 dt`,
/// `A_i = sigma_aw^2 dt`, `Omega_i = sigma_ww^2 dt` (Solà 2017, eq. 271 with
/// continuous densities), and the robot states' random walks.
pub fn process_noise(imu: &ImuNoise, robot: &RobotPrior, dt: f32) -> ErrorState {
    let mut q = ErrorState::zeros();
    let blocks = [
        (V, 3, imu.accel_density),
        (TH, 3, imu.gyro_density),
        (BA, 3, imu.accel_random_walk),
        (BG, 3, imu.gyro_random_walk),
        (CL, 6, robot.contact_random_walk),
        (RB, 3, robot.rotation_random_walk),
        (RAD, 2, robot.radius_random_walk),
    ];
    for (start, len, density) in blocks {
        q.rows_mut(start, len).fill(density * density * dt);
    }
    q
}

/// Integrates the nominal state over one step with bias-corrected samples
/// (Solà 2017, eq. 260). Clone and robot states do not move.
pub fn propagate_nominal(x: &mut NominalState, accel: &Vec3, gyro: &Vec3, dt: f32) {
    let a_w = x.q_wb * accel + x.gravity;
    x.p_wb += x.v_wb * dt + a_w * (0.5 * dt * dt);
    x.v_wb += a_w * dt;
    let q = x.q_wb * crate::state::Quat::from_scaled_axis(gyro * dt);
    x.q_wb = crate::state::Quat::new_normalize(q.into_inner());
}

// The block step below relies on position, velocity and attitude being the
// first nine error-state components.
const _: () = assert!(P == 0 && V == 3 && TH == 6);

/// `P <- F P F^T + Q` for a symmetric `P`, using only the non-identity
/// blocks of `F`.
///
/// `F` changes only the block rows and columns of position, velocity and
/// attitude. So: those block columns are replaced by `P F^T` over all rows
/// (contiguous columns in nalgebra's column-major storage); the block rows of
/// every other column follow by symmetry (a transposed copy); only the 9x9
/// block of those rows and columns needs the row operations `F (P F^T)`.
/// The result is exactly symmetric if `P` was.
pub fn propagate_covariance(p: &mut Covariance, f: &Transition, q: &ErrorState) {
    let dt = f.dt;
    // Columns: P <- P F^T, one row at a time, in registers: each row's new
    // position, velocity and attitude entries from its first 18 entries.
    let (a_vth, a_vba, a_thth) = (
        f.f_vth.transpose(),
        f.f_vba.transpose(),
        f.f_thth.transpose(),
    );
    for i in 0..DIM {
        let r = p.fixed_view::<1, 18>(i, 0).into_owned();
        let r_v = r.fixed_columns::<3>(V);
        let r_th = r.fixed_columns::<3>(TH);
        let new_p = r.fixed_columns::<3>(P) + r_v * dt;
        let new_v =
            r_v + r_th * a_vth + r.fixed_columns::<3>(BA) * a_vba + r.fixed_columns::<3>(G) * dt;
        let new_th = r_th * a_thth - r.fixed_columns::<3>(BG) * dt;
        let mut out = p.fixed_view_mut::<1, 9>(i, 0);
        out.fixed_columns_mut::<3>(P).copy_from(&new_p);
        out.fixed_columns_mut::<3>(V).copy_from(&new_v);
        out.fixed_columns_mut::<3>(TH).copy_from(&new_th);
    }
    // Rows of the other columns: by symmetry, the transposed new columns.
    let moved = p.fixed_view::<{ DIM - 9 }, 9>(9, 0).transpose();
    p.fixed_view_mut::<9, { DIM - 9 }>(0, 9).copy_from(&moved);
    // The 9x9 block: F (P F^T) on its rows, with the rows BA, BG, G of these
    // columns taken from the columns just computed.
    let a = p.fixed_columns::<9>(P).into_owned();
    let r_v = a.fixed_rows::<3>(V);
    let r_th = a.fixed_rows::<3>(TH);
    let new_p = a.fixed_rows::<3>(P) + r_v * dt;
    let new_v = r_v + f.f_vth * r_th + f.f_vba * a.fixed_rows::<3>(BA) + a.fixed_rows::<3>(G) * dt;
    let new_th = f.f_thth * r_th - a.fixed_rows::<3>(BG) * dt;
    p.fixed_view_mut::<3, 9>(P, P).copy_from(&new_p);
    p.fixed_view_mut::<3, 9>(V, P).copy_from(&new_v);
    p.fixed_view_mut::<3, 9>(TH, P).copy_from(&new_th);
    // Make the 9x9 block exactly symmetric (rounding of the two products).
    let block = p.fixed_view::<9, 9>(P, P).into_owned();
    p.fixed_view_mut::<9, 9>(P, P)
        .copy_from(&((block + block.transpose()) * 0.5));
    let diagonal = p.diagonal() + q;
    p.set_diagonal(&diagonal);
}

/// The dense reference `P <- F P F^T + Q` (about 85 000 multiply-adds).
pub fn propagate_covariance_dense(p: &mut Covariance, f: &Transition, q: &ErrorState) {
    let fd = f.dense();
    *p = fd * *p * fd.transpose() + Covariance::from_diagonal(q);
}

/// The gravity-compensated vertical specific force `|(R (a_m - a_b) + g)_z|`,
/// m/s^2: zero at rest and in level motion, large on bumps and thresholds.
pub fn vertical_deviation(x: &NominalState, accel: &Vec3) -> f32 {
    libm::fabsf((x.q_wb * accel + x.gravity).z)
}
