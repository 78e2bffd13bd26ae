//! Zero-velocity updates: *when to fuse* (the still detector, the
//! update's bookkeeping) in [`detector`], *the maths* in [`model`].

pub mod detector;
pub mod model;

pub use detector::StillDetector;
