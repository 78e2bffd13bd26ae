//! The simulated world, robot and sensors of `host-sim simulate`.
pub mod drivers;
pub mod floors;
pub mod flow_accuracy;
pub mod flow_frames;
pub mod forward;
pub mod motion;
pub mod preset;
pub mod render;
pub mod scenario;
pub mod script;
pub mod sensors;
pub mod world;
