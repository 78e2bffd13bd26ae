//! # ego-ekf
//!
//! `#![no_std]` 250 Hz error-state EKF for a ground robot (Solà, "Quaternion
//! kinematics for the error-state Kalman filter", 2017): IMU state, a pose
//! clone and robot state (wheel contact points, body-to-robot rotation, wheel
//! radii), with surface-aware wheel-velocity fusion, optical flow and
//! zero-velocity updates, a floor constraint and the camera's frame pairs
//! (stochastic cloning). No allocator, `f32`.
//!
//! - [`state`]: the state and its indices, defined once;
//! - [`propagate`]: IMU propagation, block-structured covariance;
//!   [`observability`]: the heading about gravity kept unobservable after
//!   updates (on by default, `ImuConfig::constrain_heading`);
//! - [`update`]: the shared gated update; [`covariance`]: reset, clone,
//!   checks, and the velocity reset;
//!   [`mod@reference`]: the dense textbook formulas the fast ones are tested against;
//! - [`wheel`], [`flow`], [`zupt`], [`floor`], [`camera`]: one module per measurement, *when to
//!   fuse* apart from *the maths*; [`aid_status`]: the one status record
//!   each of them leaves (PX4 EKF2 `estimator_aid_source` style);
//! - [`recovery`]: cross-sensor policy (the flow as a witness, the way out
//!   of a lockout from the most trusted source); [`impact`]: the wheels
//!   gated strictly where the robot hit something;
//!   [`gap`]: bridging an IMU gap;
//! - [`filter`]: [`EgoEkf`], the type users call; an aid written outside
//!   the crate fuses through [`EgoEkf::fuse_external`] (a worked example:
//!   `tests/new_aid.rs`).
//!
//! # Example
//!
//! A filter for a typical robot vacuum, started from still IMU samples
//! (250 Hz, gravity only), then read:
//!
//! ```
//! use ego_ekf::{EgoEkf, FilterConfig};
//! use vslam_core::{Reject, RobotDescription, Timestamp};
//! use vslam_core::sensors::ImuSample;
//!
//! let config = FilterConfig::from_robot(&RobotDescription::robot_vacuum())?;
//! let mut ekf = EgoEkf::new(config).expect("a valid config");
//! for k in 0..300u64 {
//!     let t = Timestamp(k * 4_000_000);
//!     let imu = ImuSample::new(t, [0.0; 3], [0.0, 0.0, 9.806_65])?;
//!     // The first still samples initialise the filter (`NotReady` meanwhile).
//!     match ekf.propagate(&imu) {
//!         Ok(_) | Err(Reject::NotReady) => {}
//!         Err(other) => panic!("IMU sample refused: {other}"),
//!     }
//! }
//! assert!(ekf.is_initialised());
//! assert!(ekf.velocity().norm() < 1e-3);
//! println!("position {:?} +- {:?} m", ekf.position(), ekf.position_std());
//! println!("gyro bias std {:?} rad/s", ekf.gyro_bias_std());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![no_std]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod aid_status;
pub mod camera;
pub mod config;
pub mod covariance;
pub mod events;
pub mod filter;
pub mod floor;
pub mod flow;
pub mod gap;
pub mod grip;
pub mod impact;
pub mod init;
mod kernels;
pub mod observability;
pub mod plausibility;
pub mod propagate;
pub mod recovery;
pub mod reference;
pub mod state;
pub mod surface;
pub mod update;
pub mod vibration;
pub mod wheel;
pub mod zupt;

#[cfg(test)]
mod test_rng;

pub use aid_status::{
    AidOutcome, AidStatus, CameraStatus, FloorStatus, FlowStatus, WheelStatus, ZuptStatus,
};
pub use config::{
    CameraConfig, ConfigError, FilterConfig, FloorConfig, FlowConfig, GapConfig, ImuConfig,
    ImuNoise, InitConfig, RecoveryConfig, RobotPrior, WheelConfig, ZuptConfig,
};
pub use filter::{
    EgoEkf, ExplicitStart, Filter, GapCounts, ImuStep, RelativeMotion, SensorWeights,
};
pub use flow::FlowFused;
pub use grip::{GripError, GripParams};
pub use plausibility::ImuPlausibility;
pub use recovery::{RecoveryCounts, ResetSource, Verdict};
pub use wheel::WheelInnovation;
