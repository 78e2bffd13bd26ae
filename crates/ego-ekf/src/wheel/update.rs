//! The maths of fusing one wheel sample: the four rows of [`super::model`]
//! with their Jacobian on its 20 nonzero columns, the grip's per-row gate on
//! the forward and differential rows, and the update.
//!
//! Written after PX4 EKF2's generated sparse fusion code: `P H^T` from the
//! nonzero columns of `H` only ([`WheelRows::p_ht`], no search for the
//! support at run time), `S = H P H^T + R` from it, and then
//! `fuse_prepared_in_place`: the rows' noises are uncorrelated (diagonal `R`), so
//! the update is the sequence of scalar updates `P <- P - k k^T s` row by
//! row (Solà 2017, sec. 6.1-6.3; the Cholesky factor of `S` carries the
//! sequence), with all of their rank-one downdates applied in one pass over
//! the upper triangle of `P`, then the error reset on the upper triangle and
//! one mirror: no 36x36 temporary.
//!
//! The gate: the forward and the differential rows are each tested with the
//! grip's 1-DOF chi-square gate on their own variance under the prior `P`.
//! A failed forward row means the wheels slipped along their track (spun,
//! stuck, lifted): neither it nor the differential row is fused. A failed
//! differential row alone means the body did not turn as the wheels did (a
//! skid steer turning in place on snow, one wheel spinning a little): the
//! forward row that passed its gate is still fused, so the wheels' mean
//! speed keeps holding the velocity. The lateral and vertical rows are
//! always fused.
//!
//! The vertical row has a Huber-type weight: an innovation beyond
//! [`VERTICAL_HUBER`] standard deviations has its noise raised until it is
//! at that many. A wheel climbing a cable or a threshold strip lifts the
//! robot at a tenth of a metre per second, which the non-holonomic row
//! (millimetres per second) would otherwise hold at zero against the
//! accelerometer: the climb is then followed by the IMU, pulled only a
//! little.
//!
//! On a low-grip floor ([`WheelRows::holds_radius`]) the wheel radii are
//! Schmidt consider parameters: their uncertainty enters the innovation
//! variance, but their gain is zero and their own covariance block stays
//! (`crate::update::fuse_prepared_holding`), so a floor's slip that the
//! expected slip does not yet explain cannot be learned as a smaller wheel.

use nalgebra::{SMatrix, SVector};
use vslam_core::Reject;

use crate::state::{Covariance, DIM, NominalState, RAD_L, RAD_R};
use crate::update::fuse_prepared_holding;
use crate::wheel::model::{DIFFERENTIAL, FORWARD, LATERAL, VERTICAL, WheelRows};

// The constraint rows are adjacent (their `P H^T` columns are taken as a
// block), and the gated rows come first.
const _: () = assert!(VERTICAL == LATERAL + 1 && FORWARD == 0 && DIFFERENTIAL == 1);

/// Innovations of the vertical row beyond this many standard deviations
/// have their noise raised until they are at this many.
pub const VERTICAL_HUBER: f32 = 3.0;

/// The most one update may shrink a row's predicted variance: a row's
/// noise is raised to at least its prior variance `H P H^T` over this. A
/// filter that has lost its velocity (variance of hundreds of (m/s)^2)
/// fusing a wheel row of 1e-4 (m/s)^2 would otherwise cancel seven digits,
/// all of `f32`'s, and leave a covariance that is not positive definite.
pub const MAX_VARIANCE_REDUCTION: f32 = 1.0e4;

/// The radii's error-state entries, held on low-grip floors.
const RADII: [usize; 2] = [RAD_L, RAD_R];

/// What [`update`] did with a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelUpdate {
    /// Forward innovation (measured minus predicted), m/s.
    pub forward: f32,
    /// Its predicted variance `H P H^T + R` under the prior, (m/s)^2.
    pub forward_var: f32,
    /// Differential innovation, m/s.
    pub differential: f32,
    /// Its predicted variance under the prior, (m/s)^2.
    pub differential_var: f32,
    /// Whether the forward or the differential row failed the gate (then
    /// the differential row was not fused).
    pub gated: bool,
    /// Whether the forward row was fused: it passed its gate and so did
    /// the differential row, or the differential row alone failed.
    pub forward_fused: bool,
}

/// Gates and fuses the wheel rows `rows` into `x` and `p` with the 1-DOF
/// gate `forward_gate` (a chi-square value) on the forward and the
/// differential rows.
///
/// Errors: [`Reject::NonFinite`] for non-finite rows; [`Reject::Degenerate`]
/// for a non-positive predicted variance or an update that would break `P`.
/// On any error the state and covariance are unchanged.
pub fn update(
    x: &mut NominalState,
    p: &mut Covariance,
    rows: &WheelRows,
    forward_gate: f32,
) -> Result<WheelUpdate, Reject> {
    update_gated_on(x, p, rows, forward_gate, 1.0)
}

/// [`update`] whose gate counts only `gate_noise` (in `(0, 1]`) of the
/// forward and differential rows' noise: rows whose noise was inflated by a
/// distrust factor `f` (the adverse-event memory's weight, the scale
/// pipeline's verdict) are fused with the inflated noise but gated as the
/// uninflated ones would be (`gate_noise = 1 / f^2`), so that distrust
/// lowers what a sample counts and never lets a larger innovation pass.
/// A value outside `(0, 1]` counts the whole noise.
pub fn update_gated_on(
    x: &mut NominalState,
    p: &mut Covariance,
    rows: &WheelRows,
    forward_gate: f32,
    gate_noise: f32,
) -> Result<WheelUpdate, Reject> {
    if !rows.is_finite() {
        return Err(Reject::NonFinite);
    }
    let mut pht = SMatrix::<f32, DIM, 4>::zeros();
    rows.p_ht_to(p, &mut pht);
    let mut s = rows.innovation_covariance(&pht);
    let [forward, diff, _, vertical] = rows.residual.data.0[0];
    for (i, n) in rows.noise.iter().enumerate() {
        if let Some(s_i) = s.get_mut((i, i)) {
            let prior = *s_i - n;
            if *n * MAX_VARIANCE_REDUCTION < prior {
                *s_i = prior * (1.0 + 1.0 / MAX_VARIANCE_REDUCTION);
            }
        }
    }
    if let Some(s_v) = s.get_mut((VERTICAL, VERTICAL)) {
        // Raise R so that y^2 / (H P H^T + R) = huber^2.
        let huber2 = VERTICAL_HUBER * VERTICAL_HUBER;
        if vertical * vertical > huber2 * *s_v {
            *s_v = vertical * vertical / huber2;
        }
    }
    let var_fwd = s.get((FORWARD, FORWARD)).copied().unwrap_or(0.0);
    let var_diff = s.get((DIFFERENTIAL, DIFFERENTIAL)).copied().unwrap_or(0.0);
    if !(var_fwd > 0.0 && var_diff > 0.0) {
        return Err(Reject::Degenerate);
    }
    // The gate's variances: the rows' noise counted at `gate_noise`.
    let shrink = if gate_noise > 0.0 && gate_noise <= 1.0 {
        1.0 - gate_noise
    } else {
        0.0
    };
    let [n_fwd, n_diff, ..] = rows.noise;
    let test_fwd = var_fwd - shrink * n_fwd;
    let test_diff = var_diff - shrink * n_diff;
    if !(test_fwd > 0.0 && test_diff > 0.0) {
        return Err(Reject::Degenerate);
    }
    let forward_passes = forward * forward / test_fwd <= forward_gate;
    let differential_passes = diff * diff / test_diff <= forward_gate;
    let hold: &[usize] = if rows.holds_radius() { &RADII } else { &[] };
    match (forward_passes, differential_passes) {
        (true, true) => fuse_holding(x, p, &mut pht, &s, &rows.residual, hold)?,
        (true, false) => {
            // The forward, lateral and vertical rows.
            const KEEP: [usize; 3] = [FORWARD, LATERAL, VERTICAL];
            let pick = |k: usize| KEEP.get(k).copied().unwrap_or(FORWARD);
            let mut pht_c = SMatrix::<f32, DIM, 3>::from_fn(|r, c| {
                pht.get((r, pick(c))).copied().unwrap_or(0.0)
            });
            let s_c = SMatrix::<f32, 3, 3>::from_fn(|r, c| {
                s.get((pick(r), pick(c))).copied().unwrap_or(0.0)
            });
            let y_c = SVector::<f32, 3>::from_fn(|r, _| {
                rows.residual.get(pick(r)).copied().unwrap_or(0.0)
            });
            fuse_holding(x, p, &mut pht_c, &s_c, &y_c, hold)?;
        }
        _ => {
            let mut pht_c: SMatrix<f32, DIM, 2> = pht.fixed_columns::<2>(LATERAL).into_owned();
            let s_c = s.fixed_view::<2, 2>(LATERAL, LATERAL).into_owned();
            let y_c = rows.residual.fixed_rows::<2>(LATERAL).into_owned();
            fuse_holding(x, p, &mut pht_c, &s_c, &y_c, hold)?;
        }
    }
    Ok(WheelUpdate {
        forward,
        forward_var: var_fwd,
        differential: diff,
        differential_var: var_diff,
        gated: !(forward_passes && differential_passes),
        forward_fused: forward_passes,
    })
}

/// [`fuse_prepared_holding`] with the radii held (`hold` = [`RADII`]) or not.
fn fuse_holding<const M: usize>(
    x: &mut NominalState,
    p: &mut Covariance,
    pht: &mut SMatrix<f32, DIM, M>,
    s: &SMatrix<f32, M, M>,
    y: &SVector<f32, M>,
    hold: &[usize],
) -> Result<(), Reject> {
    match hold {
        [a, b] => fuse_prepared_holding(x, p, pht, s, y, None, &[*a, *b]).map(|_| ()),
        _ => fuse_prepared_holding(x, p, pht, s, y, None, &[]).map(|_| ()),
    }
}
