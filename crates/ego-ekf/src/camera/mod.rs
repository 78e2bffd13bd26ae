//! The camera in the filter: each frame pair's relative motion (rotation
//! always, metric translation when the scale pipeline gave the pair a
//! scale) as a relative-pose measurement between the pose clone, taken at
//! the previous frame's time, and the pose at the current frame's time.
//! *When to fuse* (the clone schedule shared with the zero-velocity update,
//! the gates, the counts) in [`fusion`], *the maths* in [`model`].
//!
//! Stochastic cloning (Roumeliotis & Burdick, "Stochastic cloning: a
//! generalized framework for processing relative state measurements",
//! ICRA 2002): the clone's rows of the covariance keep its correlation with
//! the current pose, so the relative measurement corrects both
//! consistently, as the MSCKF and OpenVINS do with their clones.

pub mod fusion;
pub mod model;

pub use fusion::{CameraFusion, CameraSkips};
