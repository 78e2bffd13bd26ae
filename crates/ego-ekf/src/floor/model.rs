//! The maths of the floor constraint.
//!
//! The robot origin `o` (mid-axle on the floor: the midpoint `c` of the
//! wheel contact points, body frame) is at `p_o = p_wb + R_wb c` in the
//! world and moves at `v_o = v_wb + R_wb (w x c)` (`w` the bias-corrected
//! body rate). Two rows, world z:
//!
//! - height: `z = h_floor`, `h(x) = p_z + (R_wb c)_z`, noise `height_std`;
//! - vertical velocity: `z = 0`, `h(x) = (v_o)_z`, noise
//!   `sqrt(vertical_velocity_std^2 + (max_slope * |v_o,xy|)^2)`: a floor
//!   inclined by up to `max_slope` (rise over run) lifts the robot at up to
//!   that fraction of its horizontal speed.
//!
//! Jacobians with respect to the local attitude error `R = R_hat Exp(dth)`
//! (first order): `d(R u)/d(dth) = -R [u]x`; `d(w x c)/d(b_g) = [c]x`;
//! `d(w x c)/d(c) = [w]x`, and `c` moves by half of each contact point.

use nalgebra::{Matrix3, RowVector3, SMatrix, SVector};

use crate::config::FloorConfig;
use crate::covariance::skew;
use crate::state::{BG, CL, CR, DIM, NominalState, P, TH, V, Vec3};
use crate::update::Measurement;

/// The robot origin's world height and vertical velocity, and its
/// horizontal speed, for `x` and the bias-corrected body rate `gyro`.
pub fn origin_height_and_climb(x: &NominalState, gyro: &Vec3) -> (f32, f32, f32) {
    let r_wb = x.q_wb.to_rotation_matrix().into_inner();
    let c = x.p_b_robot();
    let p_o = x.p_wb + r_wb * c;
    let v_o = x.v_wb + r_wb * gyro.cross(&c);
    (p_o.z, v_o.z, libm::hypotf(v_o.x, v_o.y))
}

/// Builds the two-row floor measurement against the floor height `floor`
/// (world z of the floor plane, m).
pub fn floor_measurement(
    x: &NominalState,
    gyro: &Vec3,
    floor: f32,
    config: &FloorConfig,
) -> Measurement<2> {
    let r_wb = x.q_wb.to_rotation_matrix().into_inner();
    let c = x.p_b_robot();
    let u = gyro.cross(&c);
    let (height, climb, speed) = origin_height_and_climb(x, gyro);
    let ez_r: RowVector3<f32> = r_wb.row(2).into_owned();
    let half = ez_r * 0.5;
    let height_blocks: [(usize, RowVector3<f32>); 4] = [
        (P, RowVector3::new(0.0, 0.0, 1.0)),
        (TH, -ez_r * skew(&c)),
        (CL, half),
        (CR, half),
    ];
    let w_half: Matrix3<f32> = skew(gyro) * 0.5;
    let climb_blocks: [(usize, RowVector3<f32>); 5] = [
        (V, RowVector3::new(0.0, 0.0, 1.0)),
        (TH, -ez_r * skew(&u)),
        (BG, ez_r * skew(&c)),
        (CL, ez_r * w_half),
        (CR, ez_r * w_half),
    ];
    let mut h = SMatrix::<f32, 2, DIM>::zeros();
    for (col, d) in height_blocks.iter() {
        h.fixed_view_mut::<1, 3>(0, *col).copy_from(d);
    }
    for (col, d) in climb_blocks.iter() {
        h.fixed_view_mut::<1, 3>(1, *col).copy_from(d);
    }
    let slope = config.max_slope * speed;
    let climb_var = config.vertical_velocity_std * config.vertical_velocity_std + slope * slope;
    Measurement {
        residual: SVector::<f32, 2>::new(floor - height, -climb),
        h,
        noise: SMatrix::<f32, 2, 2>::from_diagonal(&SVector::<f32, 2>::new(
            config.height_std * config.height_std,
            climb_var,
        )),
    }
}
