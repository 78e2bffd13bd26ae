//! The maths of the camera's relative-pose measurement.
//!
//! The camera path gives, for frames at `t0` and `t1`, the pose of the
//! camera at `t1` in the camera frame at `t0`: rotation `R_C` and
//! translation `s t/d` (`t/d` from the homography, `s` the metric scale;
//! see `vslam_core::scale::camera`). With the camera mounted in the IMU
//! frame by `T_IC` ([`CameraConfig::q_ic`], [`CameraConfig::t_ic`]), the
//! IMU frame moved by `T_I0I1 = T_IC T_C0C1 T_IC^-1`:
//!
//! - `R_I = R_IC R_C R_IC^T`;
//! - `t_I = R_IC s t/d + t_IC - R_I t_IC`.
//!
//! The filter predicts it from the clone (`p_c`, `R_c`: the pose at `t0`)
//! and the pose (`p`, `R`: at `t1`): `R_rel = R_c^T R`,
//! `t_rel = R_c^T (p - p_c)`. Residuals and Jacobians with respect to the
//! local attitude errors `R = R_hat Exp(dth)`, `R_c = R_c_hat Exp(dth_c)`
//! (first order):
//!
//! - rotation: `y = Log(R_rel^T R_I)`; `H_th = I`, `H_th_c = -R_rel^T`;
//! - translation: `y = t_I - t_rel`; `H_p = R_c^T`, `H_p_c = -R_c^T`,
//!   `H_th_c = [t_rel]x`.
//!
//! Noise: each rotation angle `rotation_std`; the translation
//! `R_IC (var_s u u^T) R_IC^T + (rel^2 |s u|^2 + floor^2) I` with `u = t/d`,
//! `var_s` the scale's variance, `rel` the direction's relative error
//! ([`CameraConfig::translation_rel_std`]) and `floor` its absolute one
//! ([`CameraConfig::translation_std`]). The rotation noise's share of the
//! translation (`R_I t_IC` moves with it: `|t_IC| rotation_std`, a tenth of
//! a millimetre for a camera 10 cm from the IMU) is left out.

use nalgebra::{Matrix3, SMatrix, SVector};
use vslam_core::geometry::{Rot3, Vec3 as CoreVec3};

use crate::config::CameraConfig;
use crate::covariance::skew;
use crate::state::{CP, CTH, DIM, NominalState, P, Quat, TH, Vec3};
use crate::update::Measurement;

/// A frame pair's motion of the IMU frame: the pose at `t1` in the IMU
/// frame at `t0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuMotion {
    /// Rotation `R_I0I1`.
    pub rotation: Quat,
    /// Metric translation and its covariance, m and m^2, if the pair had a
    /// scale.
    pub translation: Option<(Vec3, Matrix3<f32>)>,
}

/// The camera's motion `r`, `t_over_d` (with the metric scale and its
/// variance, if any) as the IMU frame's motion ([`ImuMotion`]).
pub fn imu_motion(
    config: &CameraConfig,
    r: &Rot3,
    t_over_d: &CoreVec3,
    scale: Option<(f32, f32)>,
) -> ImuMotion {
    let r_ic = config.q_ic;
    let rotation = r_ic * Quat::from_rotation_matrix(r) * r_ic.inverse();
    let translation = scale.map(|(s, var_s)| {
        let u = r_ic * t_over_d;
        let t = u * s + config.t_ic - rotation * config.t_ic;
        let len = t_over_d.norm() * s;
        let rel = config.translation_rel_std * len;
        let iso = rel * rel + config.translation_std * config.translation_std;
        let cov = u * u.transpose() * var_s + Matrix3::identity() * iso;
        (t, cov)
    });
    ImuMotion {
        rotation,
        translation,
    }
}

/// The predicted motion of the IMU frame from the clone to the pose:
/// `(R_c^T R, R_c^T (p - p_c))`.
pub fn predicted(x: &NominalState) -> (Quat, Vec3) {
    let inv = x.clone_q_wb.inverse();
    (inv * x.q_wb, inv * (x.p_wb - x.clone_p_wb))
}

/// The three rotation rows (see the module doc).
pub fn rotation_measurement(
    x: &NominalState,
    measured: &Quat,
    config: &CameraConfig,
) -> Measurement<3> {
    let (rel, _) = predicted(x);
    let mut h = SMatrix::<f32, 3, DIM>::zeros();
    h.fixed_view_mut::<3, 3>(0, TH)
        .copy_from(&Matrix3::identity());
    h.fixed_view_mut::<3, 3>(0, CTH)
        .copy_from(&(-rel.to_rotation_matrix().into_inner().transpose()));
    let var = config.rotation_std * config.rotation_std;
    Measurement {
        residual: (rel.inverse() * measured).scaled_axis(),
        h,
        noise: SMatrix::<f32, 3, 3>::identity() * var,
    }
}

/// The six rows, rotation then translation (see the module doc), for a
/// measured translation `t` with covariance `cov`.
pub fn pose_measurement(
    x: &NominalState,
    measured: &Quat,
    t: &Vec3,
    cov: &Matrix3<f32>,
    config: &CameraConfig,
) -> Measurement<6> {
    let rot = rotation_measurement(x, measured, config);
    let (_, t_rel) = predicted(x);
    let r_c_t = x.clone_q_wb.to_rotation_matrix().into_inner().transpose();
    let mut h = SMatrix::<f32, 6, DIM>::zeros();
    h.fixed_rows_mut::<3>(0).copy_from(&rot.h);
    h.fixed_view_mut::<3, 3>(3, P).copy_from(&r_c_t);
    h.fixed_view_mut::<3, 3>(3, CP).copy_from(&(-r_c_t));
    h.fixed_view_mut::<3, 3>(3, CTH).copy_from(&skew(&t_rel));
    let mut residual = SVector::<f32, 6>::zeros();
    residual.fixed_rows_mut::<3>(0).copy_from(&rot.residual);
    residual.fixed_rows_mut::<3>(3).copy_from(&(t - t_rel));
    let mut noise = SMatrix::<f32, 6, 6>::zeros();
    noise.fixed_view_mut::<3, 3>(0, 0).copy_from(&rot.noise);
    noise.fixed_view_mut::<3, 3>(3, 3).copy_from(cov);
    Measurement { residual, h, noise }
}
