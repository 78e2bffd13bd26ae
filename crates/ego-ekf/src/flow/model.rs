//! The maths of the optical-flow velocity measurement.
//!
//! A downward flow sensor (PixArt PMW3901 / PAA5100JE family) reports counts
//! `(dx, dy)` of the floor's apparent motion since its previous report. Over
//! the step `dt`: counts -> metres at the sensor height
//! (`FlowOptics::floor_displacement`) -> metres/s, taken here as the sensor's
//! velocity over the floor along its own x and y (the flow-sensor driver's
//! sign convention). Rotated into the robot frame by the mounting `R_RS`, with
//! the lever arm removed using the gyro rate (`v_sensor = v_robot + w x t_RS`,
//! `FlowOptics::to_body`), it measures the robot origin's horizontal
//! velocity, robot frame:
//!
//! `z = [R_RS v_S - (R_rb w) x t_RS]_xy`, `h = [R_rb (R_wb^T v + w x p_mid)]_xy`
//!
//! (Jacobians as for the wheel's mid-point rows). The optics' height is taken
//! as constant; the tilt rates of a ground robot are small and not removed.
//!
//! Noise from quality: the standard deviation is `base_std` times
//! `max(1, squal_good / squal)` times `max(1, shutter / shutter_good)`, plus
//! `relative_std` of the speed (height and resolution errors); added to it in
//! quadrature, the counts' quantization: the chip reports whole counts and
//! carries the remainder, so a report's count is off by the difference of two
//! remainders, each uniform over one count (variance `q^2 / 6`, `q` one
//! count's floor travel over `dt`; Widrow & Kollar 2008, ch. 4). At 30 mm and
//! 48.8 counts per radian, over 10 ms, that is 25 mm/s: at 0.3 m/s a report
//! holds 4 or 5 counts, and a gate that did not know it refused the 4s and
//! kept the 5s, biasing the speed 2.5 % high.

use nalgebra::{Matrix3, SMatrix, SVector, Vector2};
use vslam_core::kinematics::add_lever_arm;
use vslam_core::sensors::FlowSample;

use crate::config::FlowConfig;
use crate::covariance::skew;
use crate::state::{BG, CL, CR, DIM, NominalState, RB, TH, V, Vec3};
use crate::update::Measurement;

/// The robot-origin horizontal velocity, robot frame, m/s, a flow report
/// implies over `dt` seconds, given the body rate `gyro` (body frame).
pub fn flow_velocity(
    sample: &FlowSample,
    config: &FlowConfig,
    q_rb: &crate::state::Quat,
    gyro: &Vec3,
    dt: f32,
) -> Vector2<f32> {
    let optics = &config.optics;
    let v_s = optics.floor_displacement(sample) / dt;
    let w_r = q_rb * gyro;
    optics.to_body(&v_s, &w_r).xy()
}

/// Standard deviation of each velocity component, m/s, for a report's
/// quality, the measured speed and the report's interval `dt` (s, positive):
/// the quality's and the speed's share and the quantization of the counts
/// (see the module doc).
pub fn flow_std(sample: &FlowSample, config: &FlowConfig, speed: f32, dt: f32) -> f32 {
    let squal = f32::from(sample.squal.max(1));
    let squal_factor = (f32::from(config.squal_good) / squal).max(1.0);
    let shutter_factor =
        (f32::from(sample.shutter) / f32::from(config.shutter_good.max(1))).max(1.0);
    let quality = config.base_std * squal_factor * shutter_factor + config.relative_std * speed;
    let q = config.optics.counts_to_metres(1.0) / dt;
    libm::sqrtf(quality * quality + q * q / 6.0)
}

/// Builds the two-row flow measurement for the measured velocity `z` with
/// per-component standard deviation `std`.
pub fn flow_measurement(
    x: &NominalState,
    gyro: &Vec3,
    z: &Vector2<f32>,
    std: f32,
) -> Measurement<2> {
    let r_rb = x.q_rb.to_rotation_matrix().into_inner();
    let r_wb = x.q_wb.to_rotation_matrix().into_inner();
    let v_b = r_wb.transpose() * x.v_wb;
    let p_mid = x.p_b_robot();
    let u_mid = add_lever_arm(&v_b, gyro, &p_mid);
    let w_mid = r_rb * u_mid;
    let blocks: [(usize, Matrix3<f32>); 6] = [
        (V, r_rb * r_wb.transpose()),
        (TH, r_rb * skew(&v_b)),
        (BG, r_rb * skew(&p_mid)),
        (CL, r_rb * skew(gyro) * 0.5),
        (CR, r_rb * skew(gyro) * 0.5),
        (RB, -r_rb * skew(&u_mid)),
    ];
    let mut h = SMatrix::<f32, 2, DIM>::zeros();
    for (col, d) in blocks.iter() {
        h.fixed_view_mut::<2, 3>(0, *col)
            .copy_from(&d.fixed_rows::<2>(0));
    }
    let residual = SVector::<f32, 2>::new(z.x - w_mid.x, z.y - w_mid.y);
    Measurement {
        residual,
        h,
        noise: SMatrix::<f32, 2, 2>::identity() * (std * std),
    }
}
