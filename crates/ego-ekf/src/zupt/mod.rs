//! Zero-velocity updates: *when to fuse* in [`detector`] (is the robot
//! still, is an update due) and [`fusion`] (the update's bookkeeping), *the
//! maths* in [`model`].

pub mod detector;
pub mod fusion;
pub mod model;

pub use detector::StillDetector;
pub use fusion::ZuptFusion;
