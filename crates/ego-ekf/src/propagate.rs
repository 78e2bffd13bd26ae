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
//! `F_vg = I dt`, `F_thetatheta = Exp(w dt)^T`, `F_thetawb = -I dt`,
//! `F_thetak = -e_z w_z / (1 + k) dt` (the gyro's z scale factor) of the
//! IMU part, and the clone and robot blocks have `F = I`. So `F P F^T` is a
//! few 3-row operations on `P` followed by the same operations on columns:
//! the IMU block and the IMU-to-rest cross terms change, the rest-to-rest
//! block only gains its small `Q`. [`propagate_covariance_dense`] is the
//! dense reference the tests compare against.

use nalgebra::{Matrix3, Rotation3};

use crate::config::{ImuConfig, RobotPrior};
use crate::covariance::skew;
use crate::state::{
    BA, BG, BLOCKS, CLONE, Covariance, DIM, Drive, ErrorState, G, KG, NominalState, P, TH, V, Vec3,
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
    /// `dtheta / dk = -e_z w_z / (1 + k) dt`, the gyro's z scale-factor
    /// error (zero unless [`Transition::with_gyro_scale`] sets it).
    pub f_thk: Vec3,
}

impl Transition {
    /// The transition for one step from the attitude `r_wb` at the start of
    /// the step and the bias-corrected samples.
    pub fn new(r_wb: &Matrix3<f32>, accel: &Vec3, gyro: &Vec3, dt: f32) -> Self {
        Transition {
            dt,
            f_vth: -(r_wb * skew(accel)) * dt,
            f_vba: -r_wb * dt,
            f_thth: exp_so3(&(gyro * dt)).transpose(),
            f_thk: Vec3::zeros(),
        }
    }

    /// The transition with the attitude coupled to the gyro's z scale
    /// factor: `d` is `d w / d k`
    /// ([`NominalState::gyro_scale_jacobian`]), the step's column is
    /// `d dt` (first order, as `F_thetawb = -I dt`).
    pub fn with_gyro_scale(mut self, d: &Vec3) -> Self {
        self.f_thk = d * self.dt;
        self
    }

    /// Whether the attitude depends on the gyro's scale factor (`F_thetak`
    /// not zero). When it does not, the covariance step leaves out the
    /// products with `F_thetak` (zeros: only the sign of a zero sum can
    /// differ).
    pub fn couples_gyro_scale(&self) -> bool {
        self.f_thk.iter().any(|v| *v != 0.0)
    }

    /// The full `F_x` (for the dense reference and tests).
    pub fn dense(&self) -> Covariance {
        let mut f = Covariance::identity();
        let i3 = Matrix3::<f32>::identity();
        f.fixed_view_mut::<3, 3>(P, V).copy_from(&(i3 * self.dt));
        f.fixed_view_mut::<3, 3>(V, TH).copy_from(&self.f_vth);
        f.fixed_view_mut::<3, 3>(V, BA).copy_from(&self.f_vba);
        f.fixed_view_mut::<3, 3>(V, G).copy_from(&(i3 * self.dt));
        f.fixed_view_mut::<3, 3>(TH, TH).copy_from(&self.f_thth);
        f.fixed_view_mut::<3, 3>(TH, BG).copy_from(&(-i3 * self.dt));
        f.fixed_view_mut::<3, 1>(TH, KG).copy_from(&self.f_thk);
        f
    }
}

/// Below this squared angle (rad^2; 0.05 rad) [`exp_so3`] takes the series
/// of `sin(t)/t` and `(1 - cos t)/t^2` to the `t^4` term: the next terms
/// (`t^6/5040`, `t^6/40320`) are below `4e-12`, far under `f32` rounding.
const SERIES_MAX_ANGLE_SQ: f32 = 0.05 * 0.05;

/// The rotation matrix `Exp(phi)` by the Rodrigues formula
/// `I + a [phi]x + b [phi]x^2`, `a = sin(t)/t`, `b = (1 - cos t)/t^2`,
/// `t = |phi|` (Solà 2017, eq. 77): by series below 0.05 rad (an IMU step
/// turns by a few mrad), so no `sinf`/`cosf`; nalgebra's `Rotation3::new`
/// otherwise.
pub fn exp_so3(phi: &Vec3) -> Matrix3<f32> {
    let t2 = phi.norm_squared();
    if t2 >= SERIES_MAX_ANGLE_SQ {
        return *Rotation3::new(*phi).matrix();
    }
    let a = 1.0 - t2 * (1.0 / 6.0) + t2 * t2 * (1.0 / 120.0);
    let b = 0.5 - t2 * (1.0 / 24.0) + t2 * t2 * (1.0 / 720.0);
    let k = skew(phi);
    Matrix3::identity() + k * a + (k * k) * b
}

/// The diagonal of the discrete process noise `Q` for a step of `dt`
/// seconds: `V_i = sigma_a^2 dt`, `Theta_i = sigma_w^2 dt`,
/// `A_i = sigma_aw^2 dt`, `Omega_i = sigma_ww^2 dt` (Solà 2017, eq. 271 with
/// continuous densities), and the robot states' random walks: for each
/// block of the state table, the density its [`Drive`] names.
pub fn process_noise(imu: &ImuConfig, robot: &RobotPrior, dt: f32) -> ErrorState {
    let (scale_walk, imu) = (imu.gyro_scale_random_walk, &imu.noise);
    // One value per kind of drive (in the order of `drive_slot`), then
    // each entry picks its block's: a table lookup per entry instead of a
    // fill per block (the same products, so the same bits).
    let densities = [
        0.0,
        imu.accel_density,
        imu.gyro_density,
        imu.accel_random_walk,
        imu.gyro_random_walk,
        scale_walk,
        robot.contact_random_walk,
        robot.rotation_random_walk,
        robot.radius_random_walk,
    ];
    let values = densities.map(|density| density * density * dt);
    ErrorState::from_fn(|i, _| {
        let slot = DRIVE_OF.get(i).copied().unwrap_or(0);
        values.get(usize::from(slot)).copied().unwrap_or(0.0)
    })
}

/// The slot of a drive in [`process_noise`]'s table of values.
const fn drive_slot(drive: Drive) -> u8 {
    match drive {
        Drive::Zero => 0,
        Drive::AccelNoise => 1,
        Drive::GyroNoise => 2,
        Drive::AccelBiasWalk => 3,
        Drive::GyroBiasWalk => 4,
        Drive::GyroScaleWalk => 5,
        Drive::ContactWalk => 6,
        Drive::RotationWalk => 7,
        Drive::RadiusWalk => 8,
    }
}

/// For each error-state entry, the [`drive_slot`] of its block (from the
/// state table, at compile time).
#[allow(clippy::indexing_slicing)] // i < DIM, k < BLOCKS.len(); evaluated at compile time
const DRIVE_OF: [u8; DIM] = {
    let mut out = [0u8; DIM];
    let mut k = 0;
    while k < BLOCKS.len() {
        let b = BLOCKS[k];
        let mut i = b.start;
        while i < b.start + b.dim {
            out[i] = drive_slot(b.drive);
            i += 1;
        }
        k += 1;
    }
    out
};

/// Integrates the nominal state over one step with bias-corrected samples
/// (Solà 2017, eq. 260). Clone and robot states do not move.
pub fn propagate_nominal(x: &mut NominalState, accel: &Vec3, gyro: &Vec3, dt: f32) {
    let a_w = x.q_wb * accel + x.gravity;
    x.p_wb += x.v_wb * dt + a_w * (0.5 * dt * dt);
    x.v_wb += a_w * dt;
    x.q_wb = crate::state::rotate_local(&x.q_wb, &(gyro * dt));
}

// The block step below relies on position, velocity and attitude being the
// first nine error-state components (the state table's first blocks),
// followed by the accelerometer bias, the gyroscope bias, gravity and the
// gyroscope's scale factor.
const _: () = assert!(P == 0 && V == 3 && TH == 6 && BA == 9 && BG == 12 && G == 15 && KG == 18);

/// Entry `i` of a covariance column (`0.0` outside; never outside for the
/// loops below, whose `i` runs over `0..DIM`, so the check compiles away).
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn at(column: &[f32; DIM], i: usize) -> f32 {
    column.get(i).copied().unwrap_or(0.0)
}

/// `P <- F P F^T + Q` for a symmetric `P`, using only the non-identity
/// blocks of `F`.
///
/// `F` changes only the block rows and columns of position, velocity and
/// attitude. So: those nine columns are replaced by `P F^T` over all rows
/// (contiguous columns in nalgebra's column-major storage, one pass per
/// block with every product in registers); the nine rows of every other
/// column follow by symmetry (a transposed copy); only the 9x9 block of
/// those rows and columns needs the row operations `F (P F^T)`, computed on
/// its upper triangle and mirrored. About 1,700 multiply-adds instead of the
/// dense 93,000. The result is exactly symmetric if `P` was. On Cortex-M the
/// same operations run row by row, each row of `P F^T` also stored at its
/// mirror image instead of the transposed copy (`propagate_rows`): the
/// same bits.
pub fn propagate_covariance(p: &mut Covariance, f: &Transition, q: &ErrorState) {
    if f.couples_gyro_scale() {
        propagate_blocks::<false, true>(p, f, q);
    } else {
        propagate_blocks::<false, false>(p, f, q);
    }
}

/// [`propagate_covariance`] for a `P` whose clone is decoupled (its rows
/// and columns zero outside the clone's own block, see
/// [`crate::covariance::decouple_clone`]): `F` has no clone terms and `Q`
/// none on the clone, so those zeros stay zero, and this skips them: the
/// same result bit for bit, without the clone's six rows in the column
/// passes and its six columns in the symmetric copy.
pub fn propagate_covariance_clone_decoupled(p: &mut Covariance, f: &Transition, q: &ErrorState) {
    if f.couples_gyro_scale() {
        propagate_blocks::<true, true>(p, f, q);
    } else {
        propagate_blocks::<true, false>(p, f, q);
    }
}

/// The first `rows` rows of a column (empty past its end).
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn rows_of(rows: usize, column: &[f32; DIM]) -> &[f32] {
    column.get(..rows).unwrap_or(&[])
}

/// How many rows the column passes visit: all, or all but the clone's
/// (the clone is the last block of the state, [`CLONE`]).
const fn rows_visited(skip_clone: bool) -> usize {
    if skip_clone { CLONE.start } else { DIM }
}

/// The columns of `P F^T` for position, velocity and attitude over the
/// first `rows` rows (all, or all but a decoupled clone's: skipping them
/// measured cheaper on Cortex-M; on hosts the whole columns vectorise
/// better), in the order that reads only old values. `SCALE`: whether the
/// attitude reads the gyro scale factor's column (`F_thetak` nonzero).
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn column_passes<const SCALE: bool>(p: &mut Covariance, f: &Transition, rows: usize) {
    let dt = f.dt;
    let (fvt, fva, ftt, ftk) = (&f.f_vth, &f.f_vba, &f.f_thth, &f.f_thk);
    {
        let [
            p0,
            p1,
            p2,
            v0,
            v1,
            v2,
            t0,
            t1,
            t2,
            a0,
            a1,
            a2,
            w0,
            w1,
            w2,
            g0,
            g1,
            g2,
            k0,
            ..,
        ] = &mut p.data.0;
        // Columns of `P F^T`, in the order that reads only old values:
        // position (reads velocity), velocity (reads attitude), attitude.
        'pass: {
            let (Some(c0), Some(c1), Some(c2)) =
                (p0.get_mut(..rows), p1.get_mut(..rows), p2.get_mut(..rows))
            else {
                break 'pass;
            };
            let sources = rows_of(rows, v0)
                .iter()
                .zip(rows_of(rows, v1))
                .zip(rows_of(rows, v2));
            for (((c0, c1), c2), ((s0, s1), s2)) in c0
                .iter_mut()
                .zip(c1.iter_mut())
                .zip(c2.iter_mut())
                .zip(sources)
            {
                *c0 += dt * s0;
                *c1 += dt * s1;
                *c2 += dt * s2;
            }
        }
        'pass: {
            let (Some(c0), Some(c1), Some(c2)) =
                (v0.get_mut(..rows), v1.get_mut(..rows), v2.get_mut(..rows))
            else {
                break 'pass;
            };
            let t_rows = rows_of(rows, t0)
                .iter()
                .zip(rows_of(rows, t1))
                .zip(rows_of(rows, t2));
            let a_rows = rows_of(rows, a0)
                .iter()
                .zip(rows_of(rows, a1))
                .zip(rows_of(rows, a2));
            let g_rows = rows_of(rows, g0)
                .iter()
                .zip(rows_of(rows, g1))
                .zip(rows_of(rows, g2));
            for (((c0, c1), c2), ((((t0, t1), t2), ((a0, a1), a2)), ((g0, g1), g2))) in c0
                .iter_mut()
                .zip(c1.iter_mut())
                .zip(c2.iter_mut())
                .zip(t_rows.zip(a_rows).zip(g_rows))
            {
                let t = Vec3::new(*t0, *t1, *t2);
                let a = Vec3::new(*a0, *a1, *a2);
                let g = Vec3::new(*g0, *g1, *g2);
                let v = Vec3::new(*c0, *c1, *c2) + fvt * t + fva * a + g * dt;
                (*c0, *c1, *c2) = (v.x, v.y, v.z);
            }
        }
        'pass: {
            let (Some(c0), Some(c1), Some(c2)) =
                (t0.get_mut(..rows), t1.get_mut(..rows), t2.get_mut(..rows))
            else {
                break 'pass;
            };
            let w_rows = rows_of(rows, w0)
                .iter()
                .zip(rows_of(rows, w1))
                .zip(rows_of(rows, w2))
                .zip(rows_of(rows, k0));
            for (((c0, c1), c2), (((w0, w1), w2), k)) in c0
                .iter_mut()
                .zip(c1.iter_mut())
                .zip(c2.iter_mut())
                .zip(w_rows)
            {
                let w = Vec3::new(*w0, *w1, *w2);
                let t = ftt * Vec3::new(*c0, *c1, *c2) - w * dt;
                let t = if SCALE { t + ftk * *k } else { t };
                (*c0, *c1, *c2) = (t.x, t.y, t.z);
            }
        }
    }
}

/// The block step; `SCALE` as in [`column_passes`]. On Cortex-M row by
/// row ([`propagate_rows`]), on hosts by columns (which vectorise).
fn propagate_blocks<const SKIP_CLONE: bool, const SCALE: bool>(
    p: &mut Covariance,
    f: &Transition,
    q: &ErrorState,
) {
    #[cfg(target_arch = "arm")]
    propagate_rows::<SKIP_CLONE, SCALE>(p, f);
    #[cfg(not(target_arch = "arm"))]
    propagate_columns::<SKIP_CLONE, SCALE>(p, f);
    // `Q` has no clone entries.
    let end = rows_visited(SKIP_CLONE);
    let [q] = &q.data.0;
    for (i, (col, qi)) in p.data.0.iter_mut().zip(q).enumerate().take(end) {
        if let Some(d) = col.get_mut(i) {
            *d += qi;
        }
    }
}

/// Row `i` of `P F^T` on the position, velocity and attitude columns from
/// the first 19 entries `r` of row `i` of `P` (all the columns `F` reads):
/// the same operations in the same order as [`column_passes`]. Applied to
/// a column of `P F^T` instead, it is that column of `F (P F^T)`.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn row_of_pft<const SCALE: bool>(f: &Transition, r: &[f32; 19]) -> [f32; 9] {
    let &[
        p0,
        p1,
        p2,
        v0,
        v1,
        v2,
        t0,
        t1,
        t2,
        a0,
        a1,
        a2,
        w0,
        w1,
        w2,
        g0,
        g1,
        g2,
        k,
    ] = r;
    let dt = f.dt;
    let t = Vec3::new(t0, t1, t2);
    let v = Vec3::new(v0, v1, v2)
        + f.f_vth * t
        + f.f_vba * Vec3::new(a0, a1, a2)
        + Vec3::new(g0, g1, g2) * dt;
    let th = f.f_thth * t - Vec3::new(w0, w1, w2) * dt;
    let th = if SCALE { th + f.f_thk * k } else { th };
    [
        p0 + dt * v0,
        p1 + dt * v1,
        p2 + dt * v2,
        v.x,
        v.y,
        v.z,
        th.x,
        th.y,
        th.z,
    ]
}

/// The covariance step on Cortex-M, row by row: rows `0..9` of `P F^T`
/// first (their entries in the columns `9..19` are still `P`'s), then the
/// rows below, each also stored at its mirror image (rows `0..9` of its
/// column, contiguous: no separate transposed copy); the clone's rows
/// skipped when decoupled. Then the 9x9 block `F (P F^T)`: each column's
/// entries down to the diagonal, each also stored at its mirror image. The
/// same bits as the column passes.
#[cfg(target_arch = "arm")]
fn propagate_rows<const SKIP_CLONE: bool, const SCALE: bool>(p: &mut Covariance, f: &Transition) {
    let end = rows_visited(SKIP_CLONE);
    let cols = &mut p.data.0;
    for i in 0..9 {
        let new = row_of_pft::<SCALE>(f, &row_head(cols, i));
        for (j, v) in new.into_iter().enumerate() {
            set(cols, j, i, v);
        }
    }
    for i in 9..end {
        let new = row_of_pft::<SCALE>(f, &row_head(cols, i));
        for (j, v) in new.into_iter().enumerate() {
            set(cols, j, i, v);
        }
        if let Some(top) = cols.get_mut(i).and_then(|c| c.first_chunk_mut::<9>()) {
            *top = new;
        }
    }
    // The 9x9 block, column `c` from rows 0..19 of the new column `c`:
    // position rows for every column, velocity rows from column 3 on,
    // attitude rows from column 6 on (the upper triangle; the unused
    // products are not computed once inlined).
    for c in 0..9 {
        let Some(src) = cols.get(c).and_then(|col| col.first_chunk::<19>()) else {
            continue;
        };
        let new = row_of_pft::<SCALE>(f, src);
        for (r, v) in new.into_iter().enumerate().take(c + 1) {
            set(cols, c, r, v);
            set(cols, r, c, v);
        }
    }
}

/// Entry `(i, j)` of `P` (`0.0` outside; `j` is a constant at every use).
#[cfg(target_arch = "arm")]
#[inline(always)]
fn entry(cols: &[[f32; DIM]; DIM], j: usize, i: usize) -> f32 {
    cols.get(j).and_then(|c| c.get(i)).copied().unwrap_or(0.0)
}

/// Sets entry `(i, j)` of `P` (nothing outside).
#[cfg(target_arch = "arm")]
#[inline(always)]
fn set(cols: &mut [[f32; DIM]; DIM], j: usize, i: usize, v: f32) {
    if let Some(e) = cols.get_mut(j).and_then(|c| c.get_mut(i)) {
        *e = v;
    }
}

/// The first 19 entries of row `i` of `P` (by constant columns).
#[cfg(target_arch = "arm")]
#[inline(always)]
fn row_head(cols: &[[f32; DIM]; DIM], i: usize) -> [f32; 19] {
    [
        entry(cols, 0, i),
        entry(cols, 1, i),
        entry(cols, 2, i),
        entry(cols, 3, i),
        entry(cols, 4, i),
        entry(cols, 5, i),
        entry(cols, 6, i),
        entry(cols, 7, i),
        entry(cols, 8, i),
        entry(cols, 9, i),
        entry(cols, 10, i),
        entry(cols, 11, i),
        entry(cols, 12, i),
        entry(cols, 13, i),
        entry(cols, 14, i),
        entry(cols, 15, i),
        entry(cols, 16, i),
        entry(cols, 17, i),
        entry(cols, 18, i),
    ]
}

/// The covariance step on hosts: the column passes, the 9x9 block, the
/// transposed copy.
#[cfg(not(target_arch = "arm"))]
fn propagate_columns<const SKIP_CLONE: bool, const SCALE: bool>(
    p: &mut Covariance,
    f: &Transition,
) {
    let dt = f.dt;
    let (fvt, fva, ftt, ftk) = (&f.f_vth, &f.f_vba, &f.f_thth, &f.f_thk);
    column_passes::<SCALE>(p, f, rows_visited(SKIP_CLONE && cfg!(target_arch = "arm")));
    let cols = &mut p.data.0;
    // The 9x9 block: F (P F^T) on its rows, column by column, from rows
    // 0..19 of the new columns (the rows BA, BG, G, KG are final already).
    let mut block = [[0.0f32; 9]; 9];
    for (out, col) in block.iter_mut().zip(cols.iter()) {
        // By reference: a pattern on `*col` copies the whole column first
        // (a `memcpy` of 144 bytes per column on Cortex-M).
        let &[
            m0,
            m1,
            m2,
            m3,
            m4,
            m5,
            m6,
            m7,
            m8,
            m9,
            m10,
            m11,
            m12,
            m13,
            m14,
            m15,
            m16,
            m17,
            m18,
            ..,
        ] = col;
        let t = Vec3::new(m6, m7, m8);
        let new_p = Vec3::new(m0, m1, m2) + Vec3::new(m3, m4, m5) * dt;
        let new_v = Vec3::new(m3, m4, m5)
            + fvt * t
            + fva * Vec3::new(m9, m10, m11)
            + Vec3::new(m15, m16, m17) * dt;
        let new_t = ftt * t - Vec3::new(m12, m13, m14) * dt;
        let new_t = if SCALE { new_t + ftk * m18 } else { new_t };
        *out = [
            new_p.x, new_p.y, new_p.z, new_v.x, new_v.y, new_v.z, new_t.x, new_t.y, new_t.z,
        ];
    }
    // Write the block's upper triangle (row <= column) and its mirror, so
    // the block is exactly symmetric despite the rounding of two products.
    for (c, (col, out)) in cols.iter_mut().zip(block.iter()).enumerate() {
        for (r, (dst, src)) in col.iter_mut().zip(out.iter()).enumerate() {
            *dst = if r <= c {
                *src
            } else {
                block.get(r).and_then(|o| o.get(c)).copied().unwrap_or(*src)
            };
        }
    }
    // Rows 0..9 of the other columns: by symmetry, the new columns' entries
    // (a decoupled clone's columns, the last ones, stay zero there).
    let end = rows_visited(SKIP_CLONE);
    let (imu, rest) = cols.split_at_mut(9);
    for (j, col) in rest.iter_mut().enumerate().take(end - 9) {
        let j = j + 9;
        for (dst, src) in col.iter_mut().zip(imu.iter()) {
            *dst = at(src, j);
        }
    }
}

/// The dense reference `P <- F P F^T + Q` (about 93 000 multiply-adds).
pub fn propagate_covariance_dense(p: &mut Covariance, f: &Transition, q: &ErrorState) {
    let fd = f.dense();
    *p = fd * *p * fd.transpose() + Covariance::from_diagonal(q);
}

/// The gravity-compensated specific force `R (a_m - a_b) + g` in the world
/// frame, m/s^2: the body's acceleration.
pub fn world_acceleration(x: &NominalState, accel: &Vec3) -> Vec3 {
    x.q_wb * accel + x.gravity
}

/// The gravity-compensated vertical specific force `|(R (a_m - a_b) + g)_z|`,
/// m/s^2: zero at rest and in level motion, large on bumps and thresholds.
pub fn vertical_deviation(x: &NominalState, accel: &Vec3) -> f32 {
    libm::fabsf(world_acceleration(x, accel).z)
}
