//! Covariance bookkeeping shared by propagation and updates: symmetry, the
//! error-reset Jacobian (Solà 2017, sec. 6.3), the pose clone, and the
//! positive-definiteness check used in debug builds and tests.

use nalgebra::Matrix3;

use crate::state::{CP, CTH, Covariance, DIM, ErrorState, P, RB, TH};

/// Makes `p` exactly symmetric by averaging it with its transpose.
pub fn symmetrize(p: &mut Covariance) {
    *p = (*p + p.transpose()) * 0.5;
}

/// Skew-symmetric (cross-product) matrix `[v]x`.
pub fn skew(v: &nalgebra::Vector3<f32>) -> Matrix3<f32> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The rotation blocks of the error state, whose errors the reset rotates.
const ROTATIONS: [usize; 3] = [TH, CTH, RB];

/// The nine error-state indices of the rotation blocks.
const ROTATION_INDICES: [usize; 9] = [
    TH,
    TH + 1,
    TH + 2,
    CTH,
    CTH + 1,
    CTH + 2,
    RB,
    RB + 1,
    RB + 2,
];

/// Whether error-state index `i` lies in a rotation block.
fn is_rotation(i: usize) -> bool {
    ROTATIONS.iter().any(|&b| (b..b + 3).contains(&i))
}

/// The error reset after an update: `P <- G P G^T` with `G = I` except
/// `I - [dtheta/2]x` on every rotation block (IMU attitude, clone attitude,
/// body-to-robot rotation); Solà 2017, eq. 287.
///
/// `G` touches only the nine rotation rows and columns. Their new columns
/// `P G^T` are computed over all rows (six multiply-adds a row and block);
/// the rotation rows of every other column follow by symmetry, and only the
/// 9x9 rotation-rotation entries need the row operation `G (P G^T)`
/// (computed on the upper triangle and mirrored, so the result is exactly
/// symmetric if `P` was). About 800 multiply-adds and no 35x35 temporary.
pub fn reset(p: &mut Covariance, dx: &ErrorState) {
    let halves = ROTATIONS.map(|b| dx.fixed_rows::<3>(b) * 0.5);
    let cols = &mut p.data.0;
    // New rotation columns `P G^T`: row (x, y, z) -> (I - [a]x) (x, y, z).
    let mut new_cols = [[0.0f32; DIM]; 9];
    for (k, (b, a)) in ROTATIONS.iter().zip(halves.iter()).enumerate() {
        let (Some(src), Some(dst)) = (cols.get(*b..*b + 3), new_cols.get_mut(3 * k..3 * k + 3))
        else {
            continue;
        };
        let ([c0, c1, c2], [d0, d1, d2]) = (src, dst) else {
            continue;
        };
        for ((((x, y), z), (o0, o1)), o2) in c0
            .iter()
            .zip(c1.iter())
            .zip(c2.iter())
            .zip(d0.iter_mut().zip(d1.iter_mut()))
            .zip(d2.iter_mut())
        {
            *o0 = x + a.z * y - a.y * z;
            *o1 = y - a.z * x + a.x * z;
            *o2 = z + a.y * x - a.x * y;
        }
    }
    // The rotation-rotation entries: `G (P G^T)` on the rotation rows of the
    // new columns, upper triangle (row index <= column index), mirrored.
    let mut block = [[0.0f32; 9]; 9];
    for (out, col) in block.iter_mut().zip(new_cols.iter()) {
        for ((o, a), b) in out.chunks_exact_mut(3).zip(halves.iter()).zip(ROTATIONS) {
            let m = |k: usize| col.get(b + k).copied().unwrap_or(0.0);
            let (x, y, z) = (m(0), m(1), m(2));
            if let [o0, o1, o2] = o {
                *o0 = x + a.z * y - a.y * z;
                *o1 = y - a.z * x + a.x * z;
                *o2 = z + a.y * x - a.x * y;
            }
        }
    }
    for (c, out) in block.iter().enumerate() {
        for (r, v) in out.iter().enumerate() {
            let upper = if r <= c {
                *v
            } else {
                block.get(r).and_then(|o| o.get(c)).copied().unwrap_or(*v)
            };
            let Some(&ri) = ROTATION_INDICES.get(r) else {
                continue;
            };
            if let Some(n) = new_cols.get_mut(c).and_then(|col| col.get_mut(ri)) {
                *n = upper;
            }
        }
    }
    // Write the rotation columns, and their transpose into the rotation rows
    // of every other column.
    for (j, col) in cols.iter_mut().enumerate() {
        if is_rotation(j) {
            continue;
        }
        for (&c, new) in ROTATION_INDICES.iter().zip(new_cols.iter()) {
            if let (Some(dst), Some(v)) = (col.get_mut(c), new.get(j)) {
                *dst = *v;
            }
        }
    }
    for (&c, new) in ROTATION_INDICES.iter().zip(new_cols.iter()) {
        if let Some(col) = cols.get_mut(c) {
            *col = *new;
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
    // Columns: the clone's columns are the pose's (all rows).
    let (head, clone) = cols.split_at_mut(CP);
    let pose = head
        .iter()
        .skip(P)
        .take(3)
        .chain(head.iter().skip(TH).take(3));
    for (dst, src) in clone.iter_mut().zip(pose) {
        *dst = *src;
    }
    // Rows: every column's clone rows are its pose rows (by symmetry, the
    // pose columns' entries); for the clone columns themselves that gives
    // the pose-pose block.
    const POSE_INDICES: [usize; 6] = [P, P + 1, P + 2, TH, TH + 1, TH + 2];
    for col in cols.iter_mut() {
        let vals = POSE_INDICES.map(|i| col.get(i).copied().unwrap_or(0.0));
        for (dst, v) in col.iter_mut().skip(CP).zip(vals) {
            *dst = v;
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

// The clone's position and attitude are adjacent.
const _: () = assert!(CTH == CP + 3);

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
