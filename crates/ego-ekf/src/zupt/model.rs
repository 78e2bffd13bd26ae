//! The maths of the zero-velocity update with the pose clone.
//!
//! While the robot is still, the clone holds the pose from the moment it
//! stopped. Nine rows, all with measurement zero:
//! velocity `v_wb = 0`; position `p_wb - p_clone = 0`; attitude
//! `Log(R_clone^T R_wb) = 0`, with Jacobians `I` and
//! `-(R_clone^T R_wb)^T` w.r.t. the local attitude errors (first order).

use nalgebra::{Matrix3, SMatrix, SVector};

use crate::config::ZuptConfig;
use crate::state::{CP, CTH, DIM, NominalState, P, TH, V};
use crate::update::Measurement;

/// Builds the nine-row zero-velocity and pose-equals-clone measurement.
pub fn zupt_measurement(x: &NominalState, config: &ZuptConfig) -> Measurement<9> {
    let i3 = Matrix3::<f32>::identity();
    let rel = x.clone_q_wb.inverse() * x.q_wb;
    let log = rel.scaled_axis();
    let dp = x.p_wb - x.clone_p_wb;
    let mut h = SMatrix::<f32, 9, DIM>::zeros();
    h.fixed_view_mut::<3, 3>(0, V).copy_from(&i3);
    h.fixed_view_mut::<3, 3>(3, P).copy_from(&i3);
    h.fixed_view_mut::<3, 3>(3, CP).copy_from(&(-i3));
    h.fixed_view_mut::<3, 3>(6, TH).copy_from(&i3);
    h.fixed_view_mut::<3, 3>(6, CTH)
        .copy_from(&(-rel.to_rotation_matrix().into_inner().transpose()));
    let mut residual = SVector::<f32, 9>::zeros();
    residual.fixed_rows_mut::<3>(0).copy_from(&(-x.v_wb));
    residual.fixed_rows_mut::<3>(3).copy_from(&(-dp));
    residual.fixed_rows_mut::<3>(6).copy_from(&(-log));
    let mut d = SVector::<f32, 9>::zeros();
    d.fixed_rows_mut::<3>(0)
        .fill(config.velocity_std * config.velocity_std);
    d.fixed_rows_mut::<3>(3)
        .fill(config.position_std * config.position_std);
    d.fixed_rows_mut::<3>(6)
        .fill(config.attitude_std * config.attitude_std);
    Measurement {
        residual,
        h,
        noise: SMatrix::<f32, 9, 9>::from_diagonal(&d),
    }
}
