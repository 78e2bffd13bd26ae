//! # ego-ekf
//!
//! `#![no_std]` 250 Hz error-state EKF for a ground robot (Solà, "Quaternion
//! kinematics for the error-state Kalman filter", 2017): IMU state, a pose
//! clone and robot state (wheel contact points, body-to-robot rotation, wheel
//! radii), with surface-aware wheel-velocity fusion, optical flow and
//! zero-velocity updates. No allocator, `f32`.
//!
//! - [`state`]: the state and its indices, defined once;
//! - [`propagate`]: IMU propagation, block-structured covariance;
//! - [`update`]: the shared gated update; [`covariance`]: reset, clone, checks;
//!   [`mod@reference`]: the dense textbook formulas the fast ones are tested against;
//! - [`wheel`], [`flow`], [`zupt`]: one module per measurement, *when to
//!   fuse* apart from *the maths*;
//! - [`recovery`]: out of a wheel lockout from the most trusted source;
//!   [`gap`]: bridging an IMU gap;
//! - [`filter`]: [`EgoEkf`], the type users call.
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

pub mod config;
pub mod covariance;
pub mod events;
pub mod filter;
pub mod flow;
pub mod gap;
pub mod grip;
pub mod init;
mod lanes;
pub mod propagate;
pub mod recovery;
pub mod reference;
pub mod state;
pub mod surface;
pub mod update;
pub mod wheel;
pub mod zupt;

pub use config::{
    ConfigError, FilterConfig, FlowConfig, GapConfig, ImuNoise, InitConfig, RecoveryConfig,
    RobotPrior, WheelConfig, ZuptConfig,
};
pub use filter::{EgoEkf, ExplicitStart, Filter, GapCounts, ImuStep};
pub use flow::FlowFused;
pub use grip::{GripError, GripParams};
pub use recovery::{RecoveryCounts, ResetSource, Verdict};
pub use wheel::WheelInnovation;
