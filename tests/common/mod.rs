//! The estimator the root tests drive: the default filter, scale pipeline
//! and jolt settings, no surface model, no scale->EKF wheel distrust, a
//! 20 ms reorder window, and the robot vacuum's odometry (4096 ticks per
//! revolution, 35 mm wheels, 0.23 m track).

use traction::ego_ekf::FilterConfig;
use traction::ego_ekf::events::JoltConfig;
use traction::estimator::{Estimator, EstimatorConfig};
use traction::vslam_core::scale::PipelineConfig;
use traction::wheel_odom::odometry::DiffDriveParams;

/// Encoder ticks per wheel revolution.
pub const TICKS_PER_REV: u32 = 4096;

/// A fresh estimator with the settings above.
pub fn estimator() -> Estimator<'static> {
    let config = EstimatorConfig {
        filter: FilterConfig::default(),
        odometry: DiffDriveParams::new(TICKS_PER_REV, 0.035, 0.035, 0.23, 3.0, 500_000_000)
            .unwrap(),
        scale: PipelineConfig::default(),
        surface: None,
        jolts: JoltConfig::default(),
        reorder_window_ns: 20_000_000,
        wheel_distrust: None,
    };
    Estimator::new(&config, None).unwrap()
}
