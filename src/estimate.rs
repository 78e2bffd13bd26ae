//! The estimator's one answer, [`Estimate`]: the pose of the body frame B
//! (x forward, y left, z up, origin mid-axle on the floor) in the world W,
//! its velocity and yaw rate, the pose covariance and the aids that
//! contributed.
//!
//! The EKF's own body is the IMU (`ego_ekf::state`: `p_wb`, `q_wb` are the
//! IMU's); its robot states place the chassis in the IMU frame: the wheel
//! contact points `p_bl`, `p_br`, whose midpoint is B's origin, and the
//! rotation `R_rb` of IMU vectors into B. They start at the robot
//! description's mounting (`RobotPrior::from_robot`: `p = R_BS^T (p_B -
//! t_BS)`, `R_rb = R_BS`) and the filter refines them. So
//!
//! ```text
//! p_WB = p_WI + R_WI m,   m = (p_bl + p_br) / 2,     R_WB = R_WI R_rb^T.
//! ```
//!
//! The covariance is the EKF's, carried through that map to first order
//! (Solà, "Quaternion kinematics for the error-state Kalman filter", 2017,
//! sec. 7.2: local rotation errors `R = R_hat Exp(dtheta)`): with the
//! error states `dp`, `dtheta` (IMU attitude), `dp_bl`, `dp_br`, `dphi`
//! (of `R_rb`),
//!
//! ```text
//! dp_WB  = dp - R_WI [m]x dtheta + R_WI (dp_bl + dp_br) / 2
//! eps_WB = R_WI (dtheta - dphi)      (B's rotation error, world frame: R_WB = Exp(eps) R_hat_WB)
//! ```
//!
//! The world W is the EKF's: z up, origin where the IMU started, yaw zero
//! at the IMU's start.

use ego_ekf::EgoEkf;
use ego_ekf::aid_status::AidStatus;
use ego_ekf::state::{CL, CR, P, Quat, RB, TH, Vec3};
use nalgebra::{Matrix3, SMatrix};
use vslam_core::Timestamp;

/// An aid counts as contributing while its latest fused sample is at most
/// this old, nanoseconds (several periods of the slowest aid: the wheels
/// at 50 Hz, zero-velocity updates every 40 ms).
pub const AID_RECENT_NS: u64 = 200_000_000;

/// Covariance of B's pose: rows and columns `[x, y, z]` (position error,
/// world frame, m) then `[rx, ry, rz]` (rotation error about the world
/// axes, rad; `rz` is the heading error).
pub type PoseCovariance = SMatrix<f32, 6, 6>;

/// The aids whose measurements reached the state recently (within
/// [`AID_RECENT_NS`] of the estimate), from the EKF's per-aid status records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Aids {
    /// Wheel speeds (the gated forward and differential rows).
    pub wheels: bool,
    /// The optical-flow velocity.
    pub flow: bool,
    /// Zero-velocity updates (the robot stands).
    pub zero_velocity: bool,
    /// The camera's frame pairs (rotation, and translation when scaled).
    pub camera: bool,
}

impl Aids {
    /// Whether any aid contributed (none: the pose is the IMU's dead reckoning).
    pub const fn any(&self) -> bool {
        self.wheels || self.flow || self.zero_velocity || self.camera
    }
}

/// The estimate of the robot's state at one time; see the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Time of the latest IMU step.
    pub t: Timestamp,
    /// B's origin (mid-axle on the floor) in the world, m.
    pub p_wb: Vec3,
    /// B's attitude: body vectors into the world.
    pub q_wb: Quat,
    /// Velocity of B's origin, in B (forward, left, up), m/s.
    pub v_b: Vec3,
    /// Angular rate about B's z axis (bias-corrected), rad/s.
    pub yaw_rate: f32,
    /// Covariance of B's pose ([`PoseCovariance`]).
    pub covariance: PoseCovariance,
    /// Which aids contributed.
    pub aids: Aids,
}

impl Estimate {
    /// B's heading: the yaw of `q_wb` (rotation about world z), rad.
    pub fn yaw(&self) -> f32 {
        self.q_wb.euler_angles().2
    }

    /// Covariance of `[x, y, yaw]` (m, m, rad): the planar part of
    /// [`Estimate::covariance`].
    pub fn planar_covariance(&self) -> Matrix3<f32> {
        let c = &self.covariance;
        let idx = [0usize, 1, 5];
        Matrix3::from_fn(|r, k| {
            let (i, j) = (
                idx.get(r).copied().unwrap_or(0),
                idx.get(k).copied().unwrap_or(0),
            );
            c.get((i, j)).copied().unwrap_or(f32::NAN)
        })
    }
}

/// The error-state columns B's pose depends on: `p`, `theta`, `p_bl`,
/// `p_br`, `phi_rb`, three each.
const SUPPORT: [usize; 5] = [P, TH, CL, CR, RB];
/// Number of supporting columns.
const NS: usize = 15;

// Each supporting state's three columns lie inside the error state, and
// the blocks fill the `NS` columns.
#[allow(clippy::indexing_slicing)] // i < SUPPORT.len(), at compile time
const _: () = {
    assert!(NS == 3 * SUPPORT.len());
    let mut i = 0;
    while i < SUPPORT.len() {
        assert!(SUPPORT[i] + 3 <= ego_ekf::state::DIM);
        i += 1;
    }
};

/// `[v]x`, the cross-product matrix.
fn skew(v: &Vec3) -> Matrix3<f32> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The Jacobian of B's pose error `[dp_WB, eps_WB]` with respect to the
/// supporting error states ([`SUPPORT`], in that order).
fn jacobian(r_wi: &Matrix3<f32>, m: &Vec3) -> SMatrix<f32, 6, NS> {
    let mut j = SMatrix::<f32, 6, NS>::zeros();
    j.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::identity());
    j.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&(-(r_wi * skew(m))));
    j.fixed_view_mut::<3, 3>(0, 6).copy_from(&(r_wi * 0.5));
    j.fixed_view_mut::<3, 3>(0, 9).copy_from(&(r_wi * 0.5));
    j.fixed_view_mut::<3, 3>(3, 3).copy_from(r_wi);
    j.fixed_view_mut::<3, 3>(3, 12).copy_from(&(-r_wi));
    j
}

/// The aid's latest fused sample is recent at `t`.
fn recent<const N: usize>(status: Option<&AidStatus<N>>, t: Timestamp) -> bool {
    status
        .and_then(|s| s.last_fused)
        .is_some_and(|f| t.0.saturating_sub(f.0) <= AID_RECENT_NS)
}

/// The estimate of a running filter; `None` before it has started.
pub fn estimate_of(ekf: &EgoEkf) -> Option<Estimate> {
    let t = ekf.time()?;
    let x = ekf.state();
    let r_wi = x.q_wb.to_rotation_matrix().into_inner();
    let m = x.p_b_robot();
    let p_wb = x.p_wb + r_wi * m;
    let q_wb = x.q_wb * x.q_rb.inverse();

    let p = ekf.covariance();
    // The 3x3 blocks of the supporting states, a block at a time (every
    // block lies inside `P`: checked at compile time below).
    let mut sub = SMatrix::<f32, NS, NS>::zeros();
    for (bc, &c) in SUPPORT.iter().enumerate() {
        for (br, &r) in SUPPORT.iter().enumerate() {
            sub.fixed_view_mut::<3, 3>(3 * br, 3 * bc)
                .copy_from(&p.fixed_view::<3, 3>(r, c));
        }
    }
    let j = jacobian(&r_wi, &m);
    let cov = j * sub * j.transpose();
    let covariance = (cov + cov.transpose()) * 0.5;

    let gyro_b = x.q_rb * ekf.angular_velocity();
    Some(Estimate {
        t,
        p_wb,
        q_wb,
        v_b: ekf.robot_velocity(),
        yaw_rate: gyro_b.z,
        covariance,
        aids: Aids {
            wheels: recent(ekf.wheel_status(), t),
            flow: recent(ekf.flow_status(), t),
            zero_velocity: recent(ekf.zupt_status(), t),
            camera: recent(ekf.camera_status(), t),
        },
    })
}

#[cfg(test)]
mod tests;
