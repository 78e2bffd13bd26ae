//! The filter state: nominal values and the layout of the error state,
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
//! error-state Kalman filter" (2017), sec. 5.3 and 6.1: [`Kind::Vector`]
//! blocks (positions, velocities, biases, gravity, contact points, radii)
//! are additive; [`Kind::Rotation`] blocks are local (right) perturbations
//! `R = R_hat Exp(dtheta)`, whose errors the reset after an update rotates
//! (see [`crate::covariance::reset_upper`]).
//!
//! # The layout table
//!
//! [`BLOCKS`] is the one table of the error state, in order: each block's
//! name, dimension, kind, part, process noise ([`Drive`]) and initial
//! standard deviation ([`Prior`]); [`layout`] fills in the start indices.
//! Everything else is derived from it by `const fn`s, at compile time:
//! [`DIM`], the start of every block ([`P`], [`V`], ...), the clone's rows
//! [`CLONE`], the rotation blocks [`ROTATIONS`], [`IMU_DIM`] and
//! [`REST_DIM`], a measurement's supporting columns ([`columns`]); and at
//! run time the diagonal of the process noise
//! ([`crate::propagate::process_noise`]) and the initial covariance
//! ([`crate::covariance::initial_variances`]). The covariance kernels
//! (`crate::kernels`) are written over [`DIM`] and [`CLONE`]. Adding a
//! block of states is a row of the table (plus its nominal field in
//! [`NominalState`] and its use in the models).
//!
//! | block | nominal | error | kind | part | start |
//! |---|---|---|---|---|---|
//! | IMU position `p_wb` | 3 | 3 | vector | IMU | [`P`] = 0 |
//! | IMU velocity `v_wb` (world) | 3 | 3 | vector | IMU | [`V`] = 3 |
//! | attitude `q_wb` | 4 | 3 | rotation | IMU | [`TH`] = 6 |
//! | accelerometer bias | 3 | 3 | vector | IMU | [`BA`] = 9 |
//! | gyroscope bias | 3 | 3 | vector | IMU | [`BG`] = 12 |
//! | gravity `g_w` | 3 | 3 | vector | IMU | [`G`] = 15 |
//! | gyroscope z scale-factor error `k` | 1 | 1 | vector | IMU | [`KG`] = 18 |
//! | left contact point `p_bl` | 3 | 3 | vector | robot | [`CL`] = 19 |
//! | right contact point `p_br` | 3 | 3 | vector | robot | [`CR`] = 22 |
//! | body-to-robot rotation `q_rb` | 4 | 3 | rotation | robot | [`RB`] = 25 |
//! | wheel radii (left, right) | 2 | 2 | vector | robot | [`RAD`] = 28 |
//! | clone position | 3 | 3 | vector | clone | [`CP`] = 30 |
//! | clone attitude | 4 | 3 | rotation | clone | [`CTH`] = 33 |
//!
//! IMU: nominal 20, error [`IMU_DIM`] = 19; robot 11; clone 6; total
//! [`DIM`] = 36 (the `tests` below pin these numbers, so a change of the
//! table is a change of the tests too). The IMU part comes first (the
//! propagation's transition works on its leading blocks) and the clone
//! last: while it is decoupled (see [`crate::covariance::decouple_clone`])
//! the states that take part in propagation and updates are the first
//! [`CLONE`]`.start`, one contiguous run that the covariance loops end
//! early on instead of stepping over. [`layout`] refuses (at compile time)
//! a table that breaks either rule.

use core::ops::Range;

use nalgebra::{Quaternion, SMatrix, SVector, UnitQuaternion, Vector3};

/// 3-vector, `f32`.
pub type Vec3 = Vector3<f32>;
/// Unit quaternion, `f32`.
pub type Quat = UnitQuaternion<f32>;

/// How a block's error enters its nominal value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Additive: `x = x_hat + dx`.
    Vector,
    /// A local rotation error of three components: `R = R_hat Exp(dtheta)`
    /// (rotated by the error reset after an update).
    Rotation,
}

/// Which part of the state a block belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Moved by the IMU propagation (the leading blocks).
    Imu,
    /// Robot states: constant in propagation, random walks.
    Robot,
    /// The pose clone (the trailing blocks): a copy of the pose, neither
    /// propagated nor driven by noise.
    Clone,
}

/// The process noise that drives a block: which density or random walk of
/// the configuration ([`crate::config::ImuNoise`],
/// [`crate::config::RobotPrior`]) enters its diagonal of `Q` (see
/// [`crate::propagate::process_noise`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Drive {
    /// No process noise (position, gravity, the clone).
    Zero,
    /// Accelerometer white noise (velocity).
    AccelNoise,
    /// Gyroscope white noise (attitude).
    GyroNoise,
    /// Accelerometer bias random walk.
    AccelBiasWalk,
    /// Gyroscope bias random walk.
    GyroBiasWalk,
    /// Gyroscope scale-factor random walk.
    GyroScaleWalk,
    /// Contact-point random walk.
    ContactWalk,
    /// Body-to-robot rotation random walk.
    RotationWalk,
    /// Wheel-radius random walk.
    RadiusWalk,
}

/// The initial standard deviation of a block: which one of the
/// configuration ([`crate::config::InitConfig`],
/// [`crate::config::RobotPrior`]) sets its diagonal of the initial
/// covariance (see [`crate::covariance::initial_variances`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prior {
    /// None: set by the copy of the pose (the clone).
    Copied,
    /// Position.
    Position,
    /// Velocity.
    Velocity,
    /// Attitude: tilt on the first two components, yaw on the third.
    Attitude,
    /// Accelerometer bias.
    AccelBias,
    /// Gyroscope bias.
    GyroBias,
    /// Gyroscope z scale-factor error.
    GyroScale,
    /// Gravity.
    Gravity,
    /// Contact point.
    Contact,
    /// Body-to-robot rotation.
    BodyToRobot,
    /// Wheel radius.
    Radius,
}

/// One block of the error state: a row of [`BLOCKS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Block {
    /// Name (the nominal field's).
    pub name: &'static str,
    /// First error-state index (filled in by [`layout`]).
    pub start: usize,
    /// Error-state dimension.
    pub dim: usize,
    /// Additive or rotation.
    pub kind: Kind,
    /// IMU, robot or clone.
    pub part: Part,
    /// Its process noise.
    pub drive: Drive,
    /// Its initial standard deviation.
    pub prior: Prior,
}

impl Block {
    /// A block of the table (its start is filled in by [`layout`]).
    pub const fn new(
        name: &'static str,
        dim: usize,
        kind: Kind,
        part: Part,
        drive: Drive,
        prior: Prior,
    ) -> Self {
        Block {
            name,
            start: 0,
            dim,
            kind,
            part,
            drive,
            prior,
        }
    }

    /// The block's error-state indices.
    pub const fn range(&self) -> Range<usize> {
        self.start..self.start + self.dim
    }
}

/// The table's rows with their start indices: each block starts where the
/// one before it ends. Refuses (a compile-time error for a `const`) a
/// table that does not put the IMU part first and the clone last, a
/// rotation block that is not three-dimensional, or an empty block.
#[allow(clippy::indexing_slicing)] // k < N; a const fn panics at compile time
pub const fn layout<const N: usize>(mut blocks: [Block; N]) -> [Block; N] {
    let mut start = 0;
    let mut k = 0;
    while k < N {
        let b = &mut blocks[k];
        assert!(b.dim > 0, "an empty block");
        assert!(
            !matches!(b.kind, Kind::Rotation) || b.dim == 3,
            "a rotation block has three components"
        );
        assert!(
            !matches!(b.part, Part::Clone) || matches!(b.drive, Drive::Zero),
            "the clone has no process noise"
        );
        if k > 0 {
            let before = part_rank(blocks[k - 1].part);
            assert!(
                before <= part_rank(blocks[k].part),
                "the IMU blocks come first, the clone's last"
            );
        }
        blocks[k].start = start;
        start += blocks[k].dim;
        k += 1;
    }
    blocks
}

/// The order of the parts in the table.
const fn part_rank(part: Part) -> u8 {
    match part {
        Part::Imu => 0,
        Part::Robot => 1,
        Part::Clone => 2,
    }
}

/// The error-state layout, in order (see the module doc).
pub const BLOCKS: [Block; 13] = {
    use Drive::*;
    use Kind::*;
    use Part::*;
    use Prior::*;
    layout([
        Block::new("p_wb", 3, Vector, Imu, Zero, Position),
        Block::new("v_wb", 3, Vector, Imu, AccelNoise, Velocity),
        Block::new("q_wb", 3, Rotation, Imu, GyroNoise, Attitude),
        Block::new("accel_bias", 3, Vector, Imu, AccelBiasWalk, AccelBias),
        Block::new("gyro_bias", 3, Vector, Imu, GyroBiasWalk, GyroBias),
        Block::new("gravity", 3, Vector, Imu, Zero, Gravity),
        Block::new("gyro_scale", 1, Vector, Imu, GyroScaleWalk, GyroScale),
        Block::new("p_bl", 3, Vector, Robot, ContactWalk, Contact),
        Block::new("p_br", 3, Vector, Robot, ContactWalk, Contact),
        Block::new("q_rb", 3, Rotation, Robot, RotationWalk, BodyToRobot),
        Block::new("radii", 2, Vector, Robot, RadiusWalk, Radius),
        Block::new("clone_p_wb", 3, Vector, Clone, Zero, Copied),
        Block::new("clone_q_wb", 3, Rotation, Clone, Zero, Copied),
    ])
};

/// Whether two names are equal (a `const fn`).
#[allow(clippy::indexing_slicing)] // i < a.len() == b.len()
const fn same_name(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// The block called `name`: for the constants below only, where a name
/// that is not in the table is a compile-time error.
#[allow(clippy::indexing_slicing, clippy::panic)] // k < BLOCKS.len(); evaluated at compile time
const fn block(name: &str) -> Block {
    let mut k = 0;
    while k < BLOCKS.len() {
        if same_name(BLOCKS[k].name, name) {
            return BLOCKS[k];
        }
        k += 1;
    }
    panic!("no block of that name")
}

/// The first error-state index of the block called `name` (see [`block`]).
const fn start(name: &str) -> usize {
    block(name).start
}

/// The error-state indices of the blocks of `part`: one contiguous run,
/// since [`layout`] keeps the parts in order (empty at the start of the
/// next part if there is none).
#[allow(clippy::indexing_slicing)] // k < BLOCKS.len()
pub const fn part_range(part: Part) -> Range<usize> {
    let (mut first, mut end, mut found) = (0, 0, false);
    let mut k = 0;
    while k < BLOCKS.len() {
        let b = BLOCKS[k];
        if part_rank(b.part) == part_rank(part) {
            if !found {
                first = b.start;
                found = true;
            }
            end = b.start + b.dim;
        } else if !found && part_rank(b.part) < part_rank(part) {
            first = b.start + b.dim;
            end = first;
        }
        k += 1;
    }
    first..end
}

/// The error-state columns of the blocks called `names`, in that order
/// (for a measurement's supporting columns). `N` must be the sum of their
/// dimensions; for constants only, where a name that is not in the table
/// or a wrong `N` is a compile-time error.
#[allow(clippy::indexing_slicing)] // n < N, checked; evaluated at compile time
pub const fn columns<const N: usize>(names: &[&str]) -> [usize; N] {
    let mut out = [0; N];
    let (mut n, mut k) = (0, 0);
    while k < names.len() {
        let b = block(names[k]);
        let mut c = 0;
        while c < b.dim {
            assert!(n < N, "more columns than N");
            out[n] = b.start + c;
            n += 1;
            c += 1;
        }
        k += 1;
    }
    assert!(n == N, "fewer columns than N");
    out
}

/// The number of columns of the blocks called `names` (the `N` of
/// [`columns`]); for constants only.
#[allow(clippy::indexing_slicing)] // k < names.len(); evaluated at compile time
pub const fn columns_len(names: &[&str]) -> usize {
    let (mut n, mut k) = (0, 0);
    while k < names.len() {
        n += block(names[k]).dim;
        k += 1;
    }
    n
}

/// The number of blocks of kind `kind`.
#[allow(clippy::indexing_slicing)] // k < BLOCKS.len()
pub const fn count_of(kind: Kind) -> usize {
    let mut n = 0;
    let mut k = 0;
    while k < BLOCKS.len() {
        if matches!(
            (BLOCKS[k].kind, kind),
            (Kind::Vector, Kind::Vector) | (Kind::Rotation, Kind::Rotation)
        ) {
            n += 1;
        }
        k += 1;
    }
    n
}

/// The starts of the rotation blocks, in the table's order.
#[allow(clippy::indexing_slicing)] // n < count_of(Rotation) = N
const fn rotation_starts<const N: usize>() -> [usize; N] {
    let mut out = [0; N];
    let (mut n, mut k) = (0, 0);
    while k < BLOCKS.len() {
        if matches!(BLOCKS[k].kind, Kind::Rotation) {
            out[n] = BLOCKS[k].start;
            n += 1;
        }
        k += 1;
    }
    out
}

/// The sum of the blocks' dimensions.
#[allow(clippy::indexing_slicing)] // k < BLOCKS.len()
const fn total_dim() -> usize {
    let (mut n, mut k) = (0, 0);
    while k < BLOCKS.len() {
        n += BLOCKS[k].dim;
        k += 1;
    }
    n
}

/// Error-state index of the IMU position.
pub const P: usize = start("p_wb");
/// Error-state index of the IMU velocity (world frame).
pub const V: usize = start("v_wb");
/// Error-state index of the attitude error (local, body frame).
pub const TH: usize = start("q_wb");
/// Error-state index of the accelerometer bias.
pub const BA: usize = start("accel_bias");
/// Error-state index of the gyroscope bias.
pub const BG: usize = start("gyro_bias");
/// Error-state index of gravity.
pub const G: usize = start("gravity");
/// Error-state index of the gyroscope z scale-factor error.
pub const KG: usize = start("gyro_scale");
/// Error-state index of the left wheel contact point (body frame).
pub const CL: usize = start("p_bl");
/// Error-state index of the right wheel contact point (body frame).
pub const CR: usize = start("p_br");
/// Error-state index of the body-to-robot rotation error.
pub const RB: usize = start("q_rb");
/// Error-state index of the left wheel radius; the right one follows.
pub const RAD: usize = start("radii");
/// Error-state index of the clone position.
pub const CP: usize = start("clone_p_wb");
/// Error-state index of the clone attitude error.
pub const CTH: usize = start("clone_q_wb");
/// Error-state index of the left wheel radius.
pub const RAD_L: usize = RAD;
/// Error-state index of the right wheel radius.
pub const RAD_R: usize = RAD + 1;
/// Dimension of the whole error state: the table's total.
pub const DIM: usize = total_dim();
/// Dimension of the IMU error state (the leading blocks).
pub const IMU_DIM: usize = part_range(Part::Imu).end;
/// Dimension of the states that are not IMU states (clone and robot).
pub const REST_DIM: usize = DIM - IMU_DIM;
/// The error-state rows of the pose clone: the last ones.
pub const CLONE: Range<usize> = part_range(Part::Clone);
/// Number of rotation blocks.
pub const ROTATION_COUNT: usize = count_of(Kind::Rotation);
/// The first indices of the rotation blocks, in the table's order.
pub const ROTATIONS: [usize; ROTATION_COUNT] = rotation_starts::<ROTATION_COUNT>();

// The clone is a copy of the pose: its position and attitude blocks, in
// that order, make up the clone part; the last block of the table is the
// clone's, so `CLONE.end == DIM` (see the module doc).
const _: () =
    assert!(CTH == CP + 3 && CLONE.start == CP && CLONE.end == CTH + 3 && CLONE.end == DIM);
const _: () = assert!(IMU_DIM == part_range(Part::Robot).start);

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
    /// Gyroscope z scale-factor error `k`: the gyro reads
    /// `(1 + k) w_z + b_z` about its z axis (see [`NominalState::corrected_gyro`]).
    pub gyro_scale: f32,
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

    /// The body rate from a raw gyro sample: bias removed, and the z axis
    /// divided by its scale factor, `w = (w_m - b) / (1 + k)` on z (the
    /// model `w_m = (1 + k) w + b + n`; Titterton and Weston, *Strapdown
    /// Inertial Navigation Technology*, 2nd ed., 2004, sec. 4.2.4). A scale
    /// factor at or below `-1` (no physical gyro) leaves the rate unscaled.
    pub fn corrected_gyro(&self, raw: &Vec3) -> Vec3 {
        let mut w = raw - self.gyro_bias;
        let s = 1.0 + self.gyro_scale;
        if s > 0.0 {
            w.z /= s;
        }
        w
    }

    /// `d theta / d k` per second for the corrected rate `gyro`
    /// ([`NominalState::corrected_gyro`]): the z rate error a scale-factor
    /// error `dk` makes, `-w_z / (1 + k)` on the z axis.
    pub fn gyro_scale_jacobian(&self, gyro: &Vec3) -> Vec3 {
        let s = 1.0 + self.gyro_scale;
        let d = if s > 0.0 { -gyro.z / s } else { 0.0 };
        Vec3::new(0.0, 0.0, d)
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
        self.gyro_scale += dx.fixed_rows::<1>(KG).x;
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
            && self.gyro_scale.is_finite()
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

#[cfg(test)]
mod tests;
