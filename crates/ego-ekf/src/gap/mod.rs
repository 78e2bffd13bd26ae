//! Bridging an IMU gap.
//!
//! When the IMU stream breaks for longer than the configured step
//! (`ImuConfig::max_dt_ns`; a silent or saturated IMU), the sample
//! after the break is refused ([`vslam_core::Reject::Gap`]) and first bridges
//! the gap: the robot kept moving, and turning, unmeasured by the IMU. Left
//! alone, the filter would keep its old pose with its old confidence and gate
//! every update that tells it otherwise (a lockout); bridged with a heading
//! it cannot know, later updates pull the yaw the wrong way and nothing
//! observes the absolute yaw again.
//!
//! - [`odometry`]: *when* — the wheel samples that arrive while the IMU is
//!   silent are integrated ([`GapOdometry`]), bad ones refused and counted;
//! - [`dead_reckoning`]: the maths of that integration (differential drive,
//!   midpoint heading, noise and Jacobians);
//! - [`wheel_bridge`]: moving the filter's pose and covariance by it
//!   ([`bridge_with_wheels`]): heading, path, the velocity the wheels measure
//!   at the end (along the new heading), a yaw variance grown by the wheels'
//!   yaw-rate noise and the radius and track uncertainty;
//! - [`constant_velocity`]: the fallback when the wheels did not cover the
//!   gap ([`bridge_gap`]): `p += v T`, the heading turned at the last
//!   measured yaw rate, its variance grown by the turn that rate may miss.

pub mod constant_velocity;
pub mod dead_reckoning;
pub mod odometry;
pub mod wheel_bridge;

#[cfg(test)]
pub(crate) mod test_support;

pub use constant_velocity::bridge_gap;
pub use dead_reckoning::{DeadReckoning, WheelGeometry};
pub use odometry::GapOdometry;
pub use wheel_bridge::{bridge_with_wheels, wheel_geometry};
