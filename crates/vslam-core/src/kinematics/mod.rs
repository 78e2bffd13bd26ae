//! Rigid-body and differential-drive kinematics shared by every crate that
//! turns a sensor's motion into the robot's: the one home of each formula.
//!
//! - [`diff_drive`]: wheel rim motion to the mid-axle point's forward motion
//!   and the heading change (or their rates), and the exact arc of one step
//!   (used by `wheel-odom`'s odometry, the EKF's wheel rows and its gap dead
//!   reckoning);
//! - [`lever_arm`]: a sensor's motion to the body origin's and back under a
//!   rotation (used by the EKF's flow velocity, the scale pipeline's flow
//!   steps and transactions).

pub mod diff_drive;
pub mod lever_arm;

pub use diff_drive::{ArcStep, differential, integrate_arc, mid_axle, rim, sinc, turn};
pub use lever_arm::{add_lever_arm, planar_point_step, remove_lever_arm, sensor_plane_to_body};
