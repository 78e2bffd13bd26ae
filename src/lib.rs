//! # traction
//!
//! Slip-aware metric scale for monocular VSLAM and a surface-aware ego-state
//! EKF for ground robots, `#![no_std]` and allocation-free for Cortex-M4F/M7
//! firmware. The type to use is [`Estimator`]: it takes time-stamped samples
//! of every stream ([`Stream`]), puts them in one time order, runs the EKF
//! ([`ego_ekf`]), the wheel odometry ([`wheel_odom`]) and the metric-scale
//! pipeline and camera path ([`vslam_core`], [`FrontEnd`]), and counts every
//! sample as fused, gated or rejected with a reason. Its configuration comes
//! from one [`RobotDescription`] ([`EstimatorConfig::from_robot`]); its answer
//! is one [`Estimate`] ([`Estimator::estimate`]): the pose of the body frame
//! (mid-axle on the floor) in the world, with its covariance.
//!
//! What it will not do: allocate, panic on data, read files or talk to a bus
//! (the drivers in [`flow_sensor`] and [`wheel_odom`] do that, over
//! embedded-hal 1.0). `ARCHITECTURE.md` in the repository maps the crates.
//!
//! # Example: the whole loop
//!
//! ```
//! use traction::{Estimator, EstimatorConfig, RobotDescription, Stream, Timestamp};
//! use traction::vslam_core::sensors::{RawImuSample, WheelTicks};
//!
//! // Configure: one description of the robot, everything else derived from it.
//! let robot = RobotDescription::robot_vacuum();
//! let config = EstimatorConfig::from_robot(&robot)?;
//! let mut estimator = Estimator::new(&config, None)?; // no camera fitted
//!
//! // Offer samples as the drivers deliver them: 2 s of IMU at 250 Hz and wheel
//! // counts at 50 Hz of a robot that stands for 1 s, then speeds up at 0.5 m/s^2
//! // for 0.2 s and rolls on at 0.1 m/s.
//! let counts_per_metre = robot.wheels.counts_per_revolution as f32
//!     / (2.0 * core::f32::consts::PI * robot.wheels.radius_left);
//! for k in 0..500u64 {
//!     let t = Timestamp::from_nanos(k * 4_000_000);
//!     let s = (k as f32 * 0.004 - 1.0).max(0.0); // seconds since it started off
//!     let ax = if s > 0.0 && s <= 0.2 { 0.5 } else { 0.0 };
//!     let x = if s <= 0.2 { 0.25 * s * s } else { 0.01 + 0.1 * (s - 0.2) };
//!     estimator.offer_imu(RawImuSample { t, gyro: [0.0; 3], accel: [ax, 0.0, 9.806_65] });
//!     if k % 5 == 0 {
//!         let ticks = (x * counts_per_metre) as i64;
//!         estimator.offer_wheel(WheelTicks { t, left: ticks, right: ticks });
//!     }
//!     // Poll: process what the ordering window has released.
//!     while let Some(_processed) = estimator.poll() {}
//! }
//! estimator.finish();
//! while estimator.poll().is_some() {}
//!
//! // Read the estimate (the body frame's pose, velocity, covariance, aids)
//! // and the accounting.
//! let estimate = estimator.estimate().expect("the filter has started");
//! assert!((estimate.v_b.x - 0.1).abs() < 0.02, "{}", estimate.v_b);
//! assert!((estimate.p_wb.x - 0.09).abs() < 0.02, "{}", estimate.p_wb);
//! assert!(estimate.aids.wheels);
//! let counts = estimator.counts();
//! assert_eq!(counts[Stream::Imu].seen(), 500); // every sample ends in one count
//! assert_eq!(counts[Stream::Wheel].seen(), 100);
//! # Ok::<(), traction::EstimatorError>(())
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

pub use ego_ekf;
pub use flow_sensor;
pub use vslam_core;
pub use wheel_odom;

pub mod config;
pub mod disagreement;
pub mod estimate;
pub mod estimator;
pub mod flow_demand;
pub mod frontend;
pub mod navigate;
pub mod reorder;

pub use estimate::{Aids, Estimate, PoseCovariance};
pub use estimator::{Estimator, EstimatorConfig, EstimatorError, EstimatorWith, Processed};
pub use frontend::{FrontEnd, FrontEndBuffers, FrontEndConfig};
pub use navigate::{NavConfig, Navigator, Policy};
pub use reorder::Event;
pub use vslam_core::robot::{RobotDescription, RobotError};
pub use vslam_core::{Reject, SampleCounts, Stream, StreamCounts, Timestamp};
