//! The maths of the wheel-odometry measurement.
//!
//! Each wheel's ground-contact point `c` (in the body, i.e. IMU, frame) moves,
//! seen in the robot frame, with `R_rb (R_wb^T v + w x p_bc)`; rolling without
//! slip, that is `[radius * rate, 0, 0]`. From both wheels the filter forms
//! four rows, all with measurement zero:
//!
//! 0. forward: `e_x . R_rb u_mid - (r_l w_l + r_r w_r) / 2` (the robot's
//!    forward speed, gated by the grip);
//! 1. differential: `e_x . R_rb (w x (p_br - p_bl)) - (r_r w_r - r_l w_l)`
//!    (the yaw rate seen by the wheels against the gyro's; gated with row 0);
//! 2. lateral: `e_y . R_rb u_mid` (non-holonomic, always fused);
//! 3. vertical: `e_z . R_rb u_mid` (non-holonomic, always fused);
//!
//! with `u_mid = R_wb^T v + w x p_mid`, `p_mid = (p_bl + p_br) / 2` the robot
//! origin and `w` the bias-corrected gyro rate. Jacobians are taken w.r.t.
//! velocity, attitude, gyro bias, both contact points, the body-to-robot
//! rotation and both radii, so the robot states are estimated; and w.r.t.
//! the gyro's z scale factor `k` ([`WheelRows::scale`]): `w_z` is the
//! corrected rate `(w_m - b) / (1 + k)`, so each row's column on `k` is its
//! column on the z bias times `w_z / (1 + k)`: the wheels' yaw rate
//! (differential row) observes the scale factor while the robot turns.
//!
//! The Jacobians w.r.t. the radii use the predicted wheel rates instead of
//! the measured ones (see the code): the measured ones make the radius an
//! errors-in-variables regression, biased low.
//!
//! The floor's expected slip `s` (seed 004 claim 5: the velocity derived
//! from the grip, [`GripParams::slip`]) scales the wheels' speeds in rows 0
//! and 1: the robot is expected at `(1 - s)` times what the wheels roll.
//! Their radius columns need no factor: evaluated at the predicted wheel
//! rates (which carry `1 / (1 - s)`), the factor cancels. On a floor where
//! the radii are held ([`GripParams::learn_radius`] false), the update
//! treats them as Schmidt consider parameters ([`crate::wheel::update`]).
//!
//! With per-wheel forward noise `s_f`, rows 0 and 1 have variances
//! `s_f^2 / 2` and `2 s_f^2` and are uncorrelated; rows 2 and 3 use the
//! grip's lateral noise.

use nalgebra::{Matrix3, SMatrix, SVector};
use vslam_core::kinematics::{add_lever_arm, differential, mid_axle, rim};
use vslam_core::sensors::WheelRates;

use crate::covariance::skew;
use crate::grip::GripParams;
use crate::kernels::lanes::Lane;
#[cfg(not(target_arch = "arm"))]
use crate::kernels::lanes::{Lanes, starts};
#[cfg(target_arch = "arm")]
use crate::state::CLONE;
use crate::state::{
    BG, CL, CR, Covariance, DIM, KG, NominalState, RAD, RB, TH, V, Vec3, columns, columns_len,
};
use crate::update::Measurement;

/// Row of the forward component.
pub const FORWARD: usize = 0;
/// Row of the differential (yaw-rate) component.
pub const DIFFERENTIAL: usize = 1;
/// Row of the lateral constraint.
pub const LATERAL: usize = 2;
/// Row of the vertical constraint.
pub const VERTICAL: usize = 3;

/// The error-state columns where a wheel row can be nonzero, in the order
/// of [`WheelRows::h`]: velocity, attitude, gyroscope bias, both contact
/// points, body-to-robot rotation, both radii.
pub const SUPPORT: [usize; SUPPORT_LEN] = columns(&SUPPORT_BLOCKS);
/// Number of columns in [`SUPPORT`].
pub const SUPPORT_LEN: usize = columns_len(&SUPPORT_BLOCKS);
/// The state blocks of [`SUPPORT`].
const SUPPORT_BLOCKS: [&str; 7] = ["v_wb", "q_wb", "gyro_bias", "p_bl", "p_br", "q_rb", "radii"];

#[cfg(any(target_arch = "arm", test))]
/// The entries of a covariance column at [`SUPPORT`] (by symmetry, those
/// of the same row of `P`): constant indices, so plain loads.
#[inline(always)]
fn support_of(col: &[f32; DIM]) -> [f32; SUPPORT_LEN] {
    core::array::from_fn(|k| {
        let c = SUPPORT.get(k).copied().unwrap_or(DIM);
        col.get(c).copied().unwrap_or(0.0)
    })
}

/// Within [`SUPPORT`]: the z gyro bias's column.
const BG_Z: usize = 8;
#[allow(clippy::indexing_slicing)] // evaluated at compile time
const _: () = assert!(SUPPORT[BG_Z] == BG + 2);

/// Within [`SUPPORT`]: the differential row is zero on velocity and
/// attitude (the first six), the other rows on nothing but the
/// constraint rows on the radii (the last two).
const DIFFERENTIAL_FROM: usize = 6;
const CONSTRAINT_TO: usize = 18;

/// `h[FROM..TO] . col[SUPPORT[FROM..TO]]` for a row `h` of
/// [`WheelRows::h`] and a column `col` of `P H^T`, in the order of the
/// support.
#[inline(always)]
fn dot_on<const FROM: usize, const TO: usize>(h: &[f32; SUPPORT_LEN], col: &[f32; DIM]) -> f32 {
    let (h, at) = (
        h.get(FROM..TO).unwrap_or(&[]),
        SUPPORT.get(FROM..TO).unwrap_or(&[]),
    );
    h.iter()
        .zip(at)
        .map(|(h, &j)| h * col.get(j).copied().unwrap_or(0.0))
        .sum::<f32>()
}

/// The four wheel rows with their Jacobian kept on its nonzero columns only
/// ([`SUPPORT`]) and their (diagonal) noise: what the fast update needs.
/// [`WheelRows::measurement`] expands it into the dense [`Measurement`].
/// Built by [`wheel_rows`]; [`WheelRows::p_ht`] uses the factors recorded
/// there (not `h`'s mid-point rows), so the fields are for reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelRows {
    /// Residual `z - h(x_hat)` of the four rows.
    pub residual: SVector<f32, 4>,
    /// `h[r][k]` is `dh_r / d(dx)` at column `SUPPORT[k]`.
    pub h: [[f32; SUPPORT_LEN]; 4],
    /// The noise variance of each row (the rows are uncorrelated).
    pub noise: [f32; 4],
    /// `dh_r / dk` at the gyro scale factor's column [`KG`] (outside
    /// [`SUPPORT`]; zero when the scale factor is not estimated).
    pub scale: [f32; 4],
    /// The factors of the mid-point rows (for [`WheelRows::p_ht`]).
    mid: MidFactors,
    /// Whether the update holds the radii (see [`WheelRows::holds_radius`]).
    hold_radius: bool,
}

/// The mid-point rows (forward, lateral, vertical) of `H` are `R_rb` times
/// `[R_wb^T, [v_b]x, [p_mid]x, [w]x / 2, [w]x / 2, -[u_mid]x]` on velocity,
/// attitude, gyro bias, both contact points and `R_rb`: so a row `p` of
/// `P` (on those columns) maps to `H p = R_rb (R_wb^T p_v + v_b x p_th +
/// p_mid x p_bg + (w / 2) x (p_cl + p_cr) - u_mid x p_rb)`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MidFactors {
    r_rb: Matrix3<f32>,
    r_wb_t: Matrix3<f32>,
    v_b: Vec3,
    p_mid: Vec3,
    half_w: Vec3,
    u_mid: Vec3,
}

impl WheelRows {
    /// Whether the update holds the wheel radii as consider parameters
    /// (the floor's grip is too low for its over-count to be the radius).
    pub fn holds_radius(&self) -> bool {
        self.hold_radius
    }

    /// Whether residual, Jacobian and noise are finite: the sum of every
    /// value times zero is zero for finite values and NaN as soon as one is
    /// infinite or NaN (no overflow, whatever the magnitudes; one
    /// multiply-add per value instead of a classification).
    pub fn is_finite(&self) -> bool {
        let zeros = |v: &[f32]| v.iter().fold(0.0f32, |acc, x| acc + x * 0.0);
        let h = self.h.iter().fold(0.0f32, |acc, r| acc + zeros(r));
        zeros(self.residual.as_slice()) + h + zeros(&self.noise) + zeros(&self.scale) == 0.0
    }

    /// The dense measurement (35 columns, 4x4 noise).
    pub fn measurement(&self) -> Measurement<4> {
        let mut h = SMatrix::<f32, 4, DIM>::zeros();
        for (r, row) in self.h.iter().enumerate() {
            for (&j, &v) in SUPPORT.iter().zip(row) {
                if let Some(e) = h.get_mut((r, j)) {
                    *e = v;
                }
            }
        }
        for (r, v) in self.scale.iter().enumerate() {
            if let Some(e) = h.get_mut((r, KG)) {
                *e = *v;
            }
        }
        Measurement {
            residual: self.residual,
            h,
            noise: SMatrix::<f32, 4, 4>::from_diagonal(&SVector::<f32, 4>::from(self.noise)),
        }
    }

    /// `P H^T` for a symmetric `P` from the nonzero columns of `H` only,
    /// one row `p` of `P` at a time (its 20 entries at [`SUPPORT`], each
    /// read once): the mid-point rows from their factors (`MidFactors`:
    /// two 3x3 products and four cross products), the differential row
    /// from its coefficients on gyro bias, contact-point difference,
    /// `R_rb` and radii. About 75 operations and 20 loads per row of `P`,
    /// against 70 multiply-adds with 140 loads over `H`'s columns.
    pub fn p_ht(&self, p: &Covariance) -> SMatrix<f32, DIM, 4> {
        let mut out = SMatrix::<f32, DIM, 4>::zeros();
        self.p_ht_to(p, &mut out);
        out
    }

    /// [`WheelRows::p_ht`] into `out` (every entry written). The in-place
    /// form saves the copy of the returned `DIM x 4` block (about 490
    /// instructions on Cortex-M, where a returned matrix is built in a
    /// local and copied out).
    ///
    /// Not inlined: inlined into the update, the host build spends about
    /// 500 more instructions on it (callgrind, `examples/ekf_steps`).
    #[inline(never)]
    pub fn p_ht_to(&self, p: &Covariance, out: &mut SMatrix<f32, DIM, 4>) {
        self.p_ht_support(p, out);
        // The scale factor's column (outside the support): `P[:, k] h_k`,
        // skipped where it is zero (not turning, or not estimated).
        if let Some(p_k) = p.data.0.get(KG) {
            for (o, h_k) in out.data.0.iter_mut().zip(self.scale) {
                if h_k != 0.0 {
                    for (o, p) in o.iter_mut().zip(p_k) {
                        *o += p * h_k;
                    }
                }
            }
        }
    }

    /// `P H^T` on the columns of [`SUPPORT`] (see [`WheelRows::p_ht_to`]).
    #[inline(always)]
    fn p_ht_support(&self, p: &Covariance, out: &mut SMatrix<f32, DIM, 4>) {
        #[cfg(not(target_arch = "arm"))]
        {
            // By symmetry, rows `at..at + N` of the support's columns are
            // the entries of rows `at..at + N` of `P` at the support.
            const N: usize = P_HT_LANES;
            const STARTS: [usize; DIM.div_ceil(N)] = starts::<N, { DIM.div_ceil(N) }>();
            let cols = &p.data.0;
            for at in STARTS {
                let x = SUPPORT.map(|k| Lanes::<N>::load(cols.get(k).unwrap_or(&[0.0; DIM]), at));
                for (o, v) in out.data.0.iter_mut().zip(self.rows_of_p(x)) {
                    v.store(o, at);
                }
            }
        }
        #[cfg(target_arch = "arm")]
        {
            let [o0, o1, o2, o3] = &mut out.data.0;
            let outs = o0.iter_mut().zip(o1.iter_mut()).zip(o2.iter_mut());
            let rows = p.data.0.iter().zip(outs.zip(o3.iter_mut())).enumerate();
            for (i, (col, (((f0, f1), f2), f3))) in rows {
                // Row i of P is column i (symmetry), entries at the support.
                let x = support_of(col);
                // A decoupled clone's rows are zero at the support: their
                // products are zero (the sign of a zero aside) and skipped.
                // Only there: elsewhere the test costs more than it saves.
                if CLONE.contains(&i) && x.iter().fold(0u32, |a, v| a | v.to_bits()) << 1 == 0 {
                    [*f0, *f1, *f2, *f3] = [0.0; 4];
                    continue;
                }
                [*f0, *f1, *f2, *f3] = self.rows_of_p(x);
            }
        }
    }

    /// `H p` for the entries `x` of a row `p` of `P` at [`SUPPORT`]: the
    /// mid-point rows from their factors, the differential row from its
    /// coefficients. Over [`Lane`]s, so one row (`f32`) or a block of rows
    /// gives the same bits.
    #[inline(always)]
    fn rows_of_p<T: Lane>(&self, x: [T; SUPPORT_LEN]) -> [T; 4] {
        let f = &self.mid;
        let [h_f, d, ..] = &self.h;
        let [.., rad_f0, rad_f1] = *h_f;
        let [
            _,
            _,
            _,
            _,
            _,
            _,
            dg0,
            dg1,
            dg2,
            _,
            _,
            _,
            dc0,
            dc1,
            dc2,
            dr0,
            dr1,
            dr2,
            rad_d0,
            rad_d1,
        ] = *d;
        let [
            v0,
            v1,
            v2,
            t0,
            t1,
            t2,
            g0,
            g1,
            g2,
            l0,
            l1,
            l2,
            r0,
            r1,
            r2,
            b0,
            b1,
            b2,
            a0,
            a1,
        ] = x;
        let (t_bg, t_cl, t_cr, t_rb) = ([g0, g1, g2], [l0, l1, l2], [r0, r1, r2], [b0, b1, b2]);
        // The order of nalgebra's operators, so that the results do not
        // depend on the form: `R_wb^T v + v_b x t + p_mid x g
        // + (w / 2) x (l + r) - u_mid x b`, then `R_rb` times it.
        let u = sub3(
            add3(
                add3(
                    add3(
                        mat_vec(&f.r_wb_t, [v0, v1, v2]),
                        cross(&f.v_b, [t0, t1, t2]),
                    ),
                    cross(&f.p_mid, t_bg),
                ),
                cross(&f.half_w, add3(t_cl, t_cr)),
            ),
            cross(&f.u_mid, t_rb),
        );
        let [mx, my, mz] = mat_vec(&f.r_rb, u);
        let c = T::from;
        let forward = mx + (c(rad_f0) * a0 + c(rad_f1) * a1);
        let differential = dot([dg0, dg1, dg2], t_bg)
            + dot([dc0, dc1, dc2], sub3(t_cr, t_cl))
            + dot([dr0, dr1, dr2], t_rb)
            + (c(rad_d0) * a0 + c(rad_d1) * a1);
        [forward, differential, my, mz]
    }

    /// `S = H P H^T + R` from `pht = P H^T` (its rows at [`SUPPORT`]):
    /// the upper triangle computed, the lower mirrored. Each row of `H`
    /// only where it can be nonzero (the differential row from the gyro
    /// bias on, the constraint rows up to the radii): the products left
    /// out are exact zeros at the ends of the sum, so the bits are those of
    /// the full sum (unless the sum itself is zero: then maybe its sign).
    pub fn innovation_covariance(&self, pht: &SMatrix<f32, DIM, 4>) -> SMatrix<f32, 4, 4> {
        let mut s = SMatrix::<f32, 4, 4>::zeros();
        // The rows of `pht` at the support read in place (gathering them
        // into an array first cost a call and a copy per column on
        // Cortex-M: about 140 instructions each).
        for (c, pht_c) in pht.data.0.iter().enumerate() {
            for (r, h_r) in self.h.iter().enumerate().take(c + 1) {
                let mut v = match r {
                    DIFFERENTIAL => dot_on::<DIFFERENTIAL_FROM, SUPPORT_LEN>(h_r, pht_c),
                    LATERAL | VERTICAL => dot_on::<0, CONSTRAINT_TO>(h_r, pht_c),
                    _ => dot_on::<0, SUPPORT_LEN>(h_r, pht_c),
                };
                let h_k = self.scale.get(r).copied().unwrap_or(0.0);
                if h_k != 0.0 {
                    v += h_k * pht_c.get(KG).copied().unwrap_or(0.0);
                }
                if let Some(e) = s.get_mut((r, c)) {
                    *e = v;
                }
            }
        }
        for c in 0..4 {
            for r in (c + 1)..4 {
                if let Some(v) = s.get((c, r)).copied()
                    && let Some(e) = s.get_mut((r, c))
                {
                    *e = v;
                }
            }
        }
        for (i, n) in self.noise.iter().enumerate() {
            if let Some(e) = s.get_mut((i, i)) {
                *e += n;
            }
        }
        s
    }
}

/// Builds the four-row wheel measurement at the current state (dense; see
/// [`wheel_rows`]).
///
/// `gyro` is the latest bias-corrected angular rate of the body.
pub fn wheel_measurement(
    x: &NominalState,
    gyro: &Vec3,
    rates: &WheelRates,
    grip: &GripParams,
) -> Measurement<4> {
    wheel_rows(x, gyro, rates, grip).measurement()
}

/// Builds the four wheel rows at the current state, Jacobian on
/// [`SUPPORT`] only.
///
/// `gyro` is the latest bias-corrected angular rate of the body.
///
/// Inlined: called out of line, the rows (about 480 bytes) are built in
/// the callee and copied to the caller (about 480 instructions on
/// Cortex-M; `firmware/run-qemu`).
#[inline(always)]
pub fn wheel_rows(
    x: &NominalState,
    gyro: &Vec3,
    rates: &WheelRates,
    grip: &GripParams,
) -> WheelRows {
    let r_rb = x.q_rb.to_rotation_matrix().into_inner();
    let r_wb = x.q_wb.to_rotation_matrix().into_inner();
    let v_b = r_wb.transpose() * x.v_wb;
    let p_mid = x.p_b_robot();
    let lever = x.p_br - x.p_bl;
    let u_mid = add_lever_arm(&v_b, gyro, &p_mid);
    let u_diff = gyro.cross(&lever);
    let w_mid = r_rb * u_mid;
    let w_diff = r_rb * u_diff;
    let (wl, wr) = (rates.left(), rates.right());
    let (rl, rr) = (x.radius_left, x.radius_right);

    let (vl, vr) = (rim(rl, wl), rim(rr, wr));
    // The floor's expected slip: the ground takes `1 - s` of the wheels'
    // speed (exactly the wheels' speed when `s` is 0).
    let keep = 1.0 - grip.slip();
    let h_val = SVector::<f32, 4>::new(
        w_mid.x - keep * mid_axle(vl, vr),
        w_diff.x - keep * differential(vl, vr),
        w_mid.y,
        w_mid.z,
    );

    // Jacobians of R_rb u_mid and R_rb u_diff (3 rows each).
    let d_v = r_rb * r_wb.transpose();
    let d_th = r_rb * skew(&v_b);
    let d_bg_mid = r_rb * skew(&p_mid);
    let d_c = r_rb * skew(gyro);
    let d_rb_mid = -r_rb * skew(&u_mid);
    // Row x only of the differential blocks.
    let r_x = r_rb.row(0);
    let d_bg_diff = r_x * skew(&lever);
    let d_rb_diff = -(r_x * skew(&u_diff));

    // Rows 0, 2, 3 are rows x, y, z of the mid-point velocity; all four
    // written in place (rows built as values and then gathered cost three
    // calls and a copy of the whole Jacobian on Cortex-M).
    let sf2 = grip.forward_std() * grip.forward_std();
    let sl2 = grip.lateral_std() * grip.lateral_std();
    // Built where it is returned from, the Jacobian rows written into it
    // (the copy out of the function is avoided by inlining, see above).
    let mut out = WheelRows {
        residual: -h_val,
        h: [[0.0f32; SUPPORT_LEN]; 4],
        noise: [0.5 * sf2, 2.0 * sf2, sl2, sl2],
        scale: [0.0; 4],
        mid: MidFactors {
            r_rb,
            r_wb_t: r_wb.transpose(),
            v_b,
            p_mid,
            half_w: gyro * 0.5,
            u_mid,
        },
        hold_radius: !grip.learn_radius(),
    };
    let h = &mut out.h;
    let d_c_x = d_c.row(0);
    let diff_blocks = [d_bg_diff, -d_c_x, d_c_x.into_owned(), d_rb_diff];
    for (axis, row) in [FORWARD, LATERAL, VERTICAL].into_iter().enumerate() {
        let blocks = [
            d_v.row(axis).into_owned(),
            d_th.row(axis).into_owned(),
            d_bg_mid.row(axis).into_owned(),
            d_c.row(axis) * 0.5,
            d_c.row(axis) * 0.5,
            d_rb_mid.row(axis).into_owned(),
        ];
        if let Some(row) = h.get_mut(row) {
            for (dst, v) in row.chunks_exact_mut(3).zip(blocks) {
                dst.copy_from_slice(v.as_slice());
            }
        }
    }
    if let Some(diff) = h.get_mut(DIFFERENTIAL) {
        for (dst, v) in diff
            .chunks_exact_mut(3)
            .skip(DIFFERENTIAL_FROM / 3)
            .zip(diff_blocks)
        {
            dst.copy_from_slice(v.as_slice());
        }
    }
    // Radius columns. With the mean radius and the radius difference,
    // `r_l w_l + r_r w_r = 2 r_mean w_mean + dr dw / 2` and
    // `r_r w_r - r_l w_l = r_mean dw + dr w_mean`. The regressors are
    // evaluated at the *predicted* wheel rates (`w_mid.x / r_mean`,
    // `w_diff.x / r_mean`), as an EKF whose measurement is the wheel rate
    // itself would: with the measured, noisy rates the radius becomes an
    // errors-in-variables regression biased low (by 2-5 % in the Monte
    // Carlo test at 5-20 mm/s wheel noise). Equal to the exact Jacobian
    // of the rows when the wheels agree with the prediction.
    let r_mean = 0.5 * (rl + rr);
    let (w_mean, dw) = if r_mean > 0.0 {
        (w_mid.x / r_mean, w_diff.x / r_mean)
    } else {
        (0.5 * (wl + wr), wr - wl)
    };
    let [f, d, ..] = h;
    if let Some([a, b]) = f.get_mut(CONSTRAINT_TO..) {
        (*a, *b) = (-0.5 * w_mean + 0.25 * dw, -0.5 * w_mean - 0.25 * dw);
    }
    if let Some([a, b]) = d.get_mut(CONSTRAINT_TO..) {
        (*a, *b) = (w_mean - 0.5 * dw, -w_mean - 0.5 * dw);
    }
    // `dw_z / dk = -w_z / (1 + k)`, `dw_z / db_z = -1`: the scale
    // factor's column is the z bias's times `w_z / (1 + k)`.
    let d_k = -x.gyro_scale_jacobian(gyro).z;
    for (s, row) in out.scale.iter_mut().zip(out.h.iter()) {
        *s = row.get(BG_Z).copied().unwrap_or(0.0) * d_k;
    }
    out
}

/// Lanes per block of rows in [`WheelRows::p_ht`] on hosts.
#[cfg(not(target_arch = "arm"))]
const P_HT_LANES: usize = 4;

/// `m v` in nalgebra's order: `(m0 v0 + m1 v1) + m2 v2` by columns.
#[inline(always)]
fn mat_vec<T: Lane>(m: &Matrix3<f32>, [v0, v1, v2]: [T; 3]) -> [T; 3] {
    let [[m00, m10, m20], [m01, m11, m21], [m02, m12, m22]] = m.data.0;
    let row = |a: f32, b: f32, c: f32| T::from(a) * v0 + T::from(b) * v1 + T::from(c) * v2;
    [row(m00, m01, m02), row(m10, m11, m12), row(m20, m21, m22)]
}

/// `a x b` for a constant `a`, in nalgebra's order.
#[inline(always)]
fn cross<T: Lane>(a: &Vec3, [bx, by, bz]: [T; 3]) -> [T; 3] {
    let (ax, ay, az) = (T::from(a.x), T::from(a.y), T::from(a.z));
    [ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx]
}

/// `a . b` for a constant `a`, in nalgebra's order.
#[inline(always)]
fn dot<T: Lane>([a0, a1, a2]: [f32; 3], [b0, b1, b2]: [T; 3]) -> T {
    T::from(a0) * b0 + T::from(a1) * b1 + T::from(a2) * b2
}

#[inline(always)]
fn add3<T: Lane>([a0, a1, a2]: [T; 3], [b0, b1, b2]: [T; 3]) -> [T; 3] {
    [a0 + b0, a1 + b1, a2 + b2]
}

#[inline(always)]
fn sub3<T: Lane>([a0, a1, a2]: [T; 3], [b0, b1, b2]: [T; 3]) -> [T; 3] {
    [a0 - b0, a1 - b1, a2 - b2]
}

// The support's blocks: three columns each, radii last.
const _: () = assert!(
    V + 3 == TH
        && CR == CL + 3
        && RB == CR + 3
        && RAD == RB + 3
        && DIFFERENTIAL_FROM == 6
        && CONSTRAINT_TO + 2 == SUPPORT_LEN
);

#[cfg(test)]
mod tests;
