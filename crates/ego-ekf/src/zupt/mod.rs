//! Zero-velocity updates: *when to fuse* in [`detector`], *the maths* in [`model`].

pub mod detector;
pub mod model;

pub use detector::StillDetector;
