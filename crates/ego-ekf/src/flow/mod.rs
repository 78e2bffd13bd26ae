//! Optical flow: *when to fuse* in [`fusion`], *the maths* in [`model`].

pub mod fusion;
pub mod model;

pub use fusion::{FlowFused, FlowFusion};
