//! The filter state: nominal values and the indices of the error state,
//! defined once here (PX4 EKF2 style) and used everywhere else by name.
//!
//! Frames: world `W` (z up), the filter's body `b` is the IMU frame, and the
//! robot frame `r` is the chassis frame of the design (x forward, y left,
//! z up, origin mid-axle on the floor). The robot states place the chassis
//! in the IMU frame: the wheel ground-contact points `p_bl`, `p_br` (their
//! midpoint is the robot origin) and the rotation `R_rb` (body vectors into
//! robot vectors).
//!
//! Error-state parametrisation follows Solà, "Quaternion kinematics for the
//! error-state Kalman filter" (2017), sec. 5.3 and 6.1: positions, velocities,
//! biases, gravity, contact points and radii are additive; rotations are
//! local (right) perturbations `R = R_hat Exp(dtheta)`.
//!
//! | block | nominal | error | indices |
//! |---|---|---|---|
//! | IMU position `p_wb` | 3 | 3 | [`P`] |
//! | IMU velocity `v_wb` (world) | 3 | 3 | [`V`] |
//! | attitude `q_wb` | 4 | 3 | [`TH`] |
//! | accelerometer bias | 3 | 3 | [`BA`] |
//! | gyroscope bias | 3 | 3 | [`BG`] |
//! | gravity `g_w` | 3 | 3 | [`G`] |
//! | left contact point `p_bl` | 3 | 3 | [`CL`] |
//! | right contact point `p_br` | 3 | 3 | [`CR`] |
//! | body-to-robot rotation `q_rb` | 4 | 3 | [`RB`] |
//! | wheel radii (left, right) | 2 | 2 | [`RAD`] |
//! | clone position | 3 | 3 | [`CP`] |
//! | clone attitude | 4 | 3 | [`CTH`] |
//!
//! IMU: nominal 19, error [`IMU_DIM`] = 18; robot 11; clone 6; total
//! [`DIM`] = 35. The clone comes last: while it is decoupled (see
//! [`crate::covariance::decouple_clone`]) the states that take part in
//! propagation and updates are the first [`DIM`] - 6, one contiguous run
//! that the covariance loops end early on instead of stepping over.

use nalgebra::{Quaternion, SMatrix, SVector, UnitQuaternion, Vector3};

/// 3-vector, `f32`.
pub type Vec3 = Vector3<f32>;
/// Unit quaternion, `f32`.
pub type Quat = UnitQuaternion<f32>;

/// Error-state index of the IMU position.
pub const P: usize = 0;
/// Error-state index of the IMU velocity (world frame).
pub const V: usize = 3;
/// Error-state index of the attitude error (local, body frame).
pub const TH: usize = 6;
/// Error-state index of the accelerometer bias.
pub const BA: usize = 9;
/// Error-state index of the gyroscope bias.
pub const BG: usize = 12;
/// Error-state index of gravity.
pub const G: usize = 15;
/// Dimension of the IMU error state.
pub const IMU_DIM: usize = 18;
/// Error-state index of the left wheel contact point (body frame).
pub const CL: usize = 18;
/// Error-state index of the right wheel contact point (body frame).
pub const CR: usize = 21;
/// Error-state index of the body-to-robot rotation error.
pub const RB: usize = 24;
/// Error-state index of the left wheel radius; the right one follows.
pub const RAD: usize = 27;
/// Error-state index of the clone position.
pub const CP: usize = 29;
/// Error-state index of the clone attitude error.
pub const CTH: usize = 32;
/// Error-state index of the left wheel radius.
pub const RAD_L: usize = RAD;
/// Error-state index of the right wheel radius.
pub const RAD_R: usize = RAD + 1;
/// Dimension of the whole error state.
pub const DIM: usize = 35;
/// Dimension of the states that are not IMU states (clone and robot).
pub const REST_DIM: usize = DIM - IMU_DIM;

/// Error-state covariance.
pub type Covariance = SMatrix<f32, DIM, DIM>;
/// An error-state vector.
pub type ErrorState = SVector<f32, DIM>;

/// The nominal (large-signal) state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NominalState {
    /// IMU position in the world, m.
    pub p_wb: Vec3,
    /// IMU velocity in the world, m/s.
    pub v_wb: Vec3,
    /// IMU attitude: body (IMU) vectors into the world.
    pub q_wb: Quat,
    /// Accelerometer bias, m/s^2.
    pub accel_bias: Vec3,
    /// Gyroscope bias, rad/s.
    pub gyro_bias: Vec3,
    /// Gravity in the world, m/s^2 (about `[0, 0, -9.81]`).
    pub gravity: Vec3,
    /// Clone of the IMU position.
    pub clone_p_wb: Vec3,
    /// Clone of the IMU attitude.
    pub clone_q_wb: Quat,
    /// Left wheel ground-contact point, body frame, m.
    pub p_bl: Vec3,
    /// Right wheel ground-contact point, body frame, m.
    pub p_br: Vec3,
    /// Rotation of body vectors into the robot frame.
    pub q_rb: Quat,
    /// Left wheel radius, m.
    pub radius_left: f32,
    /// Right wheel radius, m.
    pub radius_right: f32,
}

/// Standard gravity, m/s^2.
pub const STANDARD_GRAVITY: f32 = 9.806_65;

impl NominalState {
    /// The robot origin (mid-point of the contact points) in the body frame.
    pub fn p_b_robot(&self) -> Vec3 {
        (self.p_bl + self.p_br) * 0.5
    }

    /// Copies the current pose into the clone.
    pub fn clone_pose(&mut self) {
        self.clone_p_wb = self.p_wb;
        self.clone_q_wb = self.q_wb;
    }

    /// Adds an error-state estimate to the nominal state (Solà 2017, sec. 6.2).
    pub fn inject(&mut self, dx: &ErrorState) {
        self.p_wb += dx.fixed_rows::<3>(P);
        self.v_wb += dx.fixed_rows::<3>(V);
        self.q_wb = rotate_local(&self.q_wb, &dx.fixed_rows::<3>(TH).into_owned());
        self.accel_bias += dx.fixed_rows::<3>(BA);
        self.gyro_bias += dx.fixed_rows::<3>(BG);
        self.gravity += dx.fixed_rows::<3>(G);
        self.clone_p_wb += dx.fixed_rows::<3>(CP);
        // A decoupled clone (see `crate::covariance::decouple_clone`) gets no
        // correction: skip its rotation (and the renormalisation, which the
        // copy that ends its decoupling makes moot).
        let d_clone = dx.fixed_rows::<3>(CTH).into_owned();
        if d_clone != Vec3::zeros() {
            self.clone_q_wb = rotate_local(&self.clone_q_wb, &d_clone);
        }
        self.p_bl += dx.fixed_rows::<3>(CL);
        self.p_br += dx.fixed_rows::<3>(CR);
        self.q_rb = rotate_local(&self.q_rb, &dx.fixed_rows::<3>(RB).into_owned());
        let radii = dx.fixed_rows::<2>(RAD);
        self.radius_left += radii.x;
        self.radius_right += radii.y;
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        let v3 = [
            &self.p_wb,
            &self.v_wb,
            &self.accel_bias,
            &self.gyro_bias,
            &self.gravity,
            &self.clone_p_wb,
            &self.p_bl,
            &self.p_br,
        ];
        let q = [&self.q_wb, &self.clone_q_wb, &self.q_rb];
        v3.iter().all(|v| v.iter().all(|x| x.is_finite()))
            && q.iter().all(|q| q.coords.iter().all(|x| x.is_finite()))
            && self.radius_left.is_finite()
            && self.radius_right.is_finite()
    }
}

/// Below this squared angle (rad^2; 0.05 rad) [`rotate_local`] takes the
/// series of `cos(t/2)` and `sin(t/2)/t` to the `t^4` term: the next terms
/// (`t^6/46080`, `t^6/645120`) are below `4e-13`, far under `f32` rounding.
const SERIES_MAX_ANGLE_SQ: f32 = 0.05 * 0.05;

/// `q Exp(dtheta)`, the local (right) perturbation of Solà 2017 (eq. 101),
/// with the quaternion exponential `[cos(t/2), sin(t/2) dtheta/t]`,
/// `t = |dtheta|`, and the product brought back to unit norm.
///
/// Cheap for the small angles of filter updates and IMU steps: a series
/// instead of `sinf`/`cosf` below 0.05 rad (exact in `f32`), and the norm
/// restored by one Newton step of `1/sqrt` around 1 (`q (3 - |q|^2) / 2`),
/// which takes a norm error `e` to about `e^2`: the product of two unit
/// quaternions is off by a few ulps only, so no square root is needed.
pub fn rotate_local(q: &Quat, dtheta: &Vec3) -> Quat {
    let t2 = dtheta.norm_squared();
    let (w, s) = if t2 < SERIES_MAX_ANGLE_SQ {
        (
            1.0 - t2 * (1.0 / 8.0) + t2 * t2 * (1.0 / 384.0),
            0.5 - t2 * (1.0 / 48.0) + t2 * t2 * (1.0 / 3840.0),
        )
    } else {
        let t = libm::sqrtf(t2);
        (libm::cosf(0.5 * t), libm::sinf(0.5 * t) / t)
    };
    let dq = Quaternion::new(w, s * dtheta.x, s * dtheta.y, s * dtheta.z);
    let r = q.quaternion() * dq;
    let n2 = r.norm_squared();
    if libm::fabsf(n2 - 1.0) < 1e-3 {
        Quat::new_unchecked(r * (1.5 - 0.5 * n2))
    } else {
        Quat::new_normalize(r)
    }
}
