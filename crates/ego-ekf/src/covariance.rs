//! Covariance bookkeeping shared by propagation and updates: symmetry, the
//! error-reset Jacobian (Solà 2017, sec. 6.3), the pose clone, and the
//! positive-definiteness check used in debug builds and tests.

use nalgebra::Matrix3;

use crate::config::{InitConfig, RobotPrior};
use crate::state::{
    BLOCKS, CLONE, CP, CTH, Covariance, DIM, ErrorState, P, Prior, ROTATION_COUNT, ROTATIONS, TH,
    Vec3,
};

/// Makes `p` exactly symmetric by averaging it with its transpose.
pub fn symmetrize(p: &mut Covariance) {
    *p = (*p + p.transpose()) * 0.5;
}

/// Skew-symmetric (cross-product) matrix `[v]x`.
pub fn skew(v: &nalgebra::Vector3<f32>) -> Matrix3<f32> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The error-state indices of the rotation blocks ([`ROTATIONS`], three
/// each), in the table's order.
#[allow(clippy::indexing_slicing)] // k < ROTATION_COUNT; evaluated at compile time
const ROTATION_INDICES: [usize; 3 * ROTATION_COUNT] = {
    let mut out = [0; 3 * ROTATION_COUNT];
    let mut k = 0;
    while k < ROTATION_COUNT {
        out[3 * k] = ROTATIONS[k];
        out[3 * k + 1] = ROTATIONS[k] + 1;
        out[3 * k + 2] = ROTATIONS[k] + 2;
        k += 1;
    }
    out
};

/// Whether each error-state index lies in a rotation block. Evaluated at
/// compile time: an index out of range is a build error, never a panic.
#[allow(clippy::indexing_slicing)]
const IS_ROTATION: [bool; DIM] = {
    let mut t = [false; DIM];
    let mut k = 0;
    while k < ROTATION_INDICES.len() {
        t[ROTATION_INDICES[k]] = true;
        k += 1;
    }
    t
};

/// The error reset after an update: `P <- G P G^T` with `G = I` except
/// `I - [dtheta/2]x` on every rotation block ([`ROTATIONS`]: IMU
/// attitude, body-to-robot rotation, clone attitude); Solà 2017, eq. 287.
///
/// `G` touches only the rotation rows and columns (nine for the three
/// blocks): the rotation
/// columns become `P G^T` in place (six multiply-adds a row and block); the
/// rotation rows of the other columns are, by symmetry, those columns'
/// entries (copied); only the rotation-rotation entries need the row
/// operation `G (P G^T)`, and their upper triangle is copied to the lower,
/// so the result is exactly symmetric if `P` was. About 800 multiply-adds.
pub fn reset(p: &mut Covariance, dx: &ErrorState) {
    let halves = ROTATIONS.map(|b| dx.fixed_rows::<3>(b) * 0.5);
    let cols = &mut p.data.0;
    // (x, y, z) -> (I - [a]x) (x, y, z); the same expression (and order of
    // operations) in both passes.
    let rotate = |a: &Vec3, x: f32, y: f32, z: f32| {
        (
            x + a.z * y - a.y * z,
            y - a.z * x + a.x * z,
            z + a.y * x - a.x * y,
        )
    };
    for (b, a) in ROTATIONS.iter().zip(halves.iter()) {
        let Some([c0, c1, c2]) = cols.get_mut(*b..*b + 3) else {
            continue;
        };
        let (ax, ay, az) = (a.x, a.y, a.z);
        for i in 0..DIM {
            if let (Some(x), Some(y), Some(z)) = (c0.get_mut(i), c1.get_mut(i), c2.get_mut(i)) {
                let (x0, y0, z0) = (*x, *y, *z);
                *x = x0 + az * y0 - ay * z0;
                *y = y0 - az * x0 + ax * z0;
                *z = z0 + ay * x0 - ax * y0;
            }
        }
    }
    // Rotation rows: in the other columns, by symmetry, the new rotation
    // columns' entries (copied from a snapshot of those columns); in the
    // rotation columns, `G (P G^T)`.
    let snapshot = ROTATION_INDICES.map(|c| cols.get(c).copied().unwrap_or([0.0; DIM]));
    for (j, (col, rotation)) in cols.iter_mut().zip(IS_ROTATION).enumerate() {
        if rotation {
            for (b, a) in ROTATIONS.iter().zip(halves.iter()) {
                if let Some([x, y, z]) = col.get_mut(*b..*b + 3) {
                    (*x, *y, *z) = rotate(a, *x, *y, *z);
                }
            }
        } else {
            for (&r, src) in ROTATION_INDICES.iter().zip(snapshot.iter()) {
                if let (Some(dst), Some(v)) = (col.get_mut(r), src.get(j)) {
                    *dst = *v;
                }
            }
        }
    }
    // Mirror the rotation-rotation entries (the earlier block's row to the
    // later one's, whatever their index order).
    for (k, &c) in ROTATION_INDICES.iter().enumerate() {
        for &r in ROTATION_INDICES.iter().skip(k + 1) {
            let upper = cols.get(r).and_then(|col| col.get(c)).copied();
            if let (Some(v), Some(dst)) = (upper, cols.get_mut(c).and_then(|col| col.get_mut(r))) {
                *dst = v;
            }
        }
    }
}

/// Below this rotation correction (rad, on every axis of every rotation
/// block) an update skips the error reset (`G = I`).
///
/// `G = I - [dtheta/2]x` changes the covariance by relative terms of order
/// `|dtheta| / 2`; for the small corrections of routine updates many
/// error-state filters take `G = I` (Solà 2017, sec. 7.2; PX4 EKF2 never
/// resets its covariance). Below 1e-4 rad the neglected change is at most
/// about 1e-4 of `sqrt(P_ii P_jj)` per entry, and the measured effect on
/// the simulated office drive is nil (see the accuracy notes of
/// `benches/README.md`); larger corrections (a first fix, a reset after a
/// lockout, a gap) still get the exact reset.
pub const RESET_MIN_ANGLE: f32 = 1.0e-4;

/// Whether the correction `dx` rotates any rotation block by more than
/// [`RESET_MIN_ANGLE`] on some axis (then [`reset`] is applied).
pub fn reset_needed(dx: &ErrorState) -> bool {
    ROTATIONS
        .iter()
        .any(|b| dx.fixed_rows::<3>(*b).amax() > RESET_MIN_ANGLE)
}

/// [`reset`] on the upper triangle only (entries `(i, j)`, `i <= j`), for
/// a covariance whose lower triangle is stale (after [`crate::update::downdate_upper`]);
/// [`crate::update::mirror_upper_to_lower`] completes it afterwards.
///
/// For `i <= j`, `(G P G^T)[i, j]` is `P[i, j]` rotated on the column side
/// when `j` is a rotation index and on the row side when `i` is: first the
/// rotation columns over the rows up to their block's end (the 3x3
/// diagonal blocks are made whole first, since their lower part is read),
/// then the rotation rows over the columns from their block's start. About
/// 700 multiply-adds and no copies (the full-matrix [`reset`] also copies
/// nine rows through a snapshot).
pub fn reset_upper(p: &mut Covariance, dx: &ErrorState) {
    let halves = ROTATIONS.map(|b| dx.fixed_rows::<3>(b) * 0.5);
    let cols = &mut p.data.0;
    // The diagonal blocks' lower parts, from their upper parts.
    for b in ROTATIONS {
        if let Some([c0, c1, c2]) = cols.get_mut(b..b + 3) {
            // Column c holds rows b..=b+c of the block's upper part.
            let (u01, u02, u12) = (c1.get(b), c2.get(b), c2.get(b + 1));
            let (u01, u02, u12) = (u01.copied(), u02.copied(), u12.copied());
            for (dst, v) in [(c0.get_mut(b + 1), u01), (c1.get_mut(b + 2), u12)] {
                if let (Some(dst), Some(v)) = (dst, v) {
                    *dst = v;
                }
            }
            if let (Some(dst), Some(v)) = (c0.get_mut(b + 2), u02) {
                *dst = v;
            }
        }
    }
    // Column side: the rotation columns, rows up to the block's end.
    for (b, a) in ROTATIONS.iter().zip(halves.iter()) {
        let Some([c0, c1, c2]) = cols.get_mut(*b..*b + 3) else {
            continue;
        };
        let (ax, ay, az) = (a.x, a.y, a.z);
        let rows = c0.iter_mut().zip(c1.iter_mut()).zip(c2.iter_mut());
        for ((x, y), z) in rows.take(*b + 3) {
            let (x0, y0, z0) = (*x, *y, *z);
            *x = x0 + az * y0 - ay * z0;
            *y = y0 - az * x0 + ax * z0;
            *z = z0 + ay * x0 - ax * y0;
        }
    }
    // Row side: the rotation rows, columns from the block's start.
    for (b, a) in ROTATIONS.iter().zip(halves.iter()) {
        let (ax, ay, az) = (a.x, a.y, a.z);
        for col in cols.iter_mut().skip(*b) {
            if let Some([x, y, z]) = col.get_mut(*b..*b + 3) {
                let (x0, y0, z0) = (*x, *y, *z);
                *x = x0 + az * y0 - ay * z0;
                *y = y0 - az * x0 + ax * z0;
                *z = z0 + ay * x0 - ax * y0;
            }
        }
    }
}

/// The reset written as the dense product `G P G^T` (the reference the
/// tests compare [`reset`] against).
pub fn reset_dense(p: &mut Covariance, dx: &ErrorState) {
    let mut g = Covariance::identity();
    for b in ROTATIONS {
        let block = Matrix3::identity() - skew(&(dx.fixed_rows::<3>(b) * 0.5));
        g.fixed_view_mut::<3, 3>(b, b).copy_from(&block);
    }
    *p = g * *p * g.transpose();
}

/// Replaces the clone's rows and columns by the current pose's, so that the
/// clone is the pose, plus `copy_var` on the clone's diagonal: the copy is
/// taken as a measurement of the pose with that tiny variance, which keeps
/// `P` positive definite in `f32` (an exact copy makes it singular).
pub fn clone_pose(p: &mut Covariance, copy_var_position: f32, copy_var_attitude: f32) {
    let cols = &mut p.data.0;
    // Columns: the clone's columns are the pose's (all rows): two runs of
    // three whole columns.
    if let Some((head, clone)) = cols.split_at_mut_checked(CP)
        && let Some((clone_p, clone_th)) = clone.split_at_mut_checked(3)
    {
        for (dst, src) in [(clone_p, P), (clone_th, TH)] {
            if let (Some(dst), Some(src)) = (dst.get_mut(..3), head.get(src..src + 3)) {
                dst.copy_from_slice(src);
            }
        }
    }
    // Rows: every column's clone rows are its pose rows (by symmetry, the
    // pose columns' entries); for the clone columns themselves that gives
    // the pose-pose block. Two runs of three entries per column.
    for col in cols.iter_mut() {
        let Some((head, clone)) = col.split_at_mut_checked(CP) else {
            continue;
        };
        let Some((clone_p, clone_th)) = clone.split_at_mut_checked(3) else {
            continue;
        };
        for (dst, src) in [(clone_p, P), (clone_th, TH)] {
            if let (Some(dst), Some(src)) = (dst.get_mut(..3), head.get(src..src + 3)) {
                dst.copy_from_slice(src);
            }
        }
    }
    let vars = [
        copy_var_position,
        copy_var_position,
        copy_var_position,
        copy_var_attitude,
        copy_var_attitude,
        copy_var_attitude,
    ];
    for (k, (col, var)) in cols.iter_mut().skip(CP).zip(vars).enumerate() {
        if let Some(d) = col.get_mut(CP + k) {
            *d += var;
        }
    }
}

/// Keeps the clone at least `min_var_position` / `min_var_attitude` apart
/// from the pose on each axis: where the variance of the difference
/// `P_ii + P_cc - 2 P_ic` (pose axis `i`, its clone axis `c`) has fallen
/// below the minimum, the clone's diagonal gets the rest. Repeated
/// pose-equals-clone updates (the zero-velocity update while the robot
/// stands) shrink that difference as `R / n` while the pose's own variance
/// stays; once it is below `f32`'s resolution of that variance, `P` is no
/// longer positive definite in `f32`. Adding to a diagonal entry keeps `P`
/// symmetric positive (semi-)definite; the clone is then known as well as a
/// fresh copy ([`clone_pose`]) would be.
pub fn keep_clone_apart(p: &mut Covariance, min_var_position: f32, min_var_attitude: f32) {
    for k in 0..6 {
        let (i, c, min) = if k < 3 {
            (P + k, CP + k, min_var_position)
        } else {
            (TH + k - 3, CTH + k - 3, min_var_attitude)
        };
        let (Some(&pi), Some(&pc), Some(&x)) = (p.get((i, i)), p.get((c, c)), p.get((i, c))) else {
            continue;
        };
        let apart = pi + pc - 2.0 * x;
        // NaN compares false: nothing changes.
        if apart < min
            && let Some(d) = p.get_mut((c, c))
        {
            *d += min - apart;
        }
    }
}

/// Zeroes the clone's covariance with every other state (its rows and
/// columns outside its own 6x6 block), which stays as it is: `P` stays
/// positive (semi-)definite, and the clone no longer takes part in
/// propagation or updates (its cross terms stay zero, see
/// [`crate::propagate::propagate_covariance_clone_decoupled`]). For a clone
/// that will be overwritten by [`clone_pose`] before anything reads it.
pub fn decouple_clone(p: &mut Covariance) {
    let clone = CLONE;
    for (j, col) in p.data.0.iter_mut().enumerate() {
        if clone.contains(&j) {
            for (i, v) in col.iter_mut().enumerate() {
                if !clone.contains(&i) {
                    *v = 0.0;
                }
            }
        } else if let Some(rows) = col.get_mut(clone.clone()) {
            rows.fill(0.0);
        }
    }
}

/// The diagonal of the initial covariance: each block's variance the
/// square of the standard deviation its [`Prior`] names in the state table
/// (the attitude's tilt on its first two components, yaw on the third);
/// zero on the clone, which the caller sets by copying the pose
/// ([`clone_pose`]).
pub fn initial_variances(init: &InitConfig, robot: &RobotPrior) -> ErrorState {
    let mut d = ErrorState::zeros();
    for b in BLOCKS {
        let std = match b.prior {
            Prior::Copied => continue,
            Prior::Position => init.position_std,
            Prior::Velocity => init.velocity_std,
            Prior::Attitude => {
                d.rows_mut(b.start, 2).fill(init.tilt_std * init.tilt_std);
                d.rows_mut(b.start + 2, 1).fill(init.yaw_std * init.yaw_std);
                continue;
            }
            Prior::AccelBias => init.accel_bias_std,
            Prior::GyroBias => init.gyro_bias_std,
            Prior::GyroScale => init.gyro_scale_std,
            Prior::Gravity => init.gravity_std,
            Prior::Contact => robot.contact_std,
            Prior::BodyToRobot => robot.rotation_std,
            Prior::Radius => robot.radius_std,
        };
        d.rows_mut(b.start, b.dim).fill(std * std);
    }
    d
}

// The clone's position and attitude are adjacent.
const _: () = assert!(CTH == CP + 3 && P + 3 <= CP && TH + 3 <= CP && CTH + 3 <= DIM);

/// Whether `p` is finite, symmetric (relative tolerance `1e-5`) and has a
/// positive diagonal: the cheap check run after every step in debug builds.
pub fn looks_valid(p: &Covariance) -> bool {
    if !p.iter().all(|v| v.is_finite()) || !p.diagonal().iter().all(|d| *d > 0.0) {
        return false;
    }
    let s = p.diagonal().map(libm::sqrtf);
    let scale = s * s.transpose();
    let asym = (p - p.transpose()).abs();
    // Asymmetry small against the scale, and no correlation outside [-1, 1]
    // (impossible for a positive semi-definite matrix).
    asym.iter().zip(scale.iter()).all(|(a, s)| *a <= 1e-5 * s)
        && p.iter()
            .zip(scale.iter())
            .all(|(c, s)| libm::fabsf(*c) <= 1.001 * s)
}

/// Whether `p` is symmetric positive definite: a Cholesky factorisation of
/// the diagonally normalised matrix (correlations) exists.
pub fn is_positive_definite(p: &Covariance) -> bool {
    if !looks_valid(p) {
        return false;
    }
    let d = p.diagonal().map(|v| 1.0 / libm::sqrtf(v));
    let c = p.component_mul(&(d * d.transpose()));
    nalgebra::Cholesky::new(c).is_some()
}

// Resets: a block of the state replaced by a measurement, its covariance
// replaced by the measurement's variance with no correlation to the rest
// (PX4 EKF2's `resetHorizontalVelocityTo` and friends). Used by the lockout
// recovery ([`crate::recovery`]) and the flow's own reset
// ([`crate::flow::fusion`]).

/// Replaces the covariance of the `N` states from `START` by `var` on the
/// diagonal and zero elsewhere in their rows and columns: the block becomes
/// uncorrelated with the rest, which keeps `P` symmetric positive definite
/// (for `var > 0`).
pub fn reset_block<const START: usize, const N: usize>(p: &mut Covariance, var: f32) {
    const { assert!(START + N <= DIM) };
    p.fixed_rows_mut::<N>(START).fill(0.0);
    p.fixed_columns_mut::<N>(START).fill(0.0);
    for i in START..START + N {
        if let Some(d) = p.get_mut((i, i)) {
            *d = var;
        }
    }
}

/// Resets the velocity so that the robot-origin horizontal velocity, robot
/// frame, equals `z` (m/s; the vertical robot-frame component is kept),
/// given the body rate `gyro` (bias-corrected, body frame), and replaces the
/// velocity's covariance by `std^2` per component, uncorrelated
/// ([`reset_block`]).
pub fn reset_velocity(
    x: &mut crate::state::NominalState,
    p: &mut Covariance,
    gyro: &Vec3,
    z: &nalgebra::Vector2<f32>,
    std: f32,
) {
    let r_rb = x.q_rb.to_rotation_matrix().into_inner();
    let r_wb = x.q_wb.to_rotation_matrix().into_inner();
    let p_mid = x.p_b_robot();
    let v_b = r_wb.transpose() * x.v_wb;
    let w_mid = r_rb * (v_b + gyro.cross(&p_mid));
    let u_new = r_rb.transpose() * Vec3::new(z.x, z.y, w_mid.z);
    x.v_wb = r_wb * (u_new - gyro.cross(&p_mid));
    reset_block::<{ crate::state::V }, 3>(p, std * std);
}
