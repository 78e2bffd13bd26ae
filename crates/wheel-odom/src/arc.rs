//! Exact differential-drive integration over one step: the arc of the
//! mid-axle point from both wheels' travel. The maths lives in
//! [`vslam_core::kinematics::diff_drive`], the one home of the
//! differential-drive formulas (the EKF's wheel rows and gap dead reckoning
//! use it too); this module names it for the odometry.

pub use vslam_core::kinematics::diff_drive::{ArcStep, integrate_arc, sinc};
