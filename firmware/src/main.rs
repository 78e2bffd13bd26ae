//! Links traction's no_std crates into a bare-metal Cortex-M4F image: no std,
//! no allocator. It builds the whole `Estimator` (EKF, odometry, scale
//! pipeline, surface model, jolt monitor) and feeds it a still robot, so the
//! linker has to keep every part. Built by `.ci/run`.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use traction::ego_ekf::FilterConfig;
use traction::ego_ekf::events::JoltConfig;
use traction::ego_ekf::surface::{ClassConfig, SurfaceConfig, SurfaceKind, WheelType};
use traction::estimator::{Estimator, EstimatorConfig};
use traction::vslam_core::Timestamp;
use traction::vslam_core::scale::PipelineConfig;
use traction::vslam_core::sensors::{RawImuSample, WheelTicks};
use traction::wheel_odom::odometry::DiffDriveParams;

#[entry]
fn main() -> ! {
    let Ok(odometry) = DiffDriveParams::new(1024, 0.035, 0.035, 0.23, 3.0, 500_000_000) else {
        halt();
    };
    let classes =
        ClassConfig::from_lists(&[(2, SurfaceKind::Wood), (3, SurfaceKind::Carpet)], &[2, 3]);
    let config = EstimatorConfig {
        filter: FilterConfig::default(),
        odometry,
        scale: PipelineConfig::default(),
        surface: Some(SurfaceConfig::new(WheelType::SoftTreaded, classes)),
        jolts: JoltConfig::default(),
        reorder_window_ns: 20_000_000,
    };
    let Ok(mut est) = Estimator::new(&config, None) else {
        halt();
    };
    let mut t = 0u64;
    loop {
        t = t.wrapping_add(4_000_000);
        est.offer_imu(RawImuSample {
            t: Timestamp(t),
            gyro: [0.0; 3],
            accel: black_box([0.0, 0.0, 9.81]),
        });
        if t.is_multiple_of(20_000_000) {
            est.offer_wheel(WheelTicks {
                t: Timestamp(t),
                left: 0,
                right: 0,
            });
        }
        while let Some(p) = est.poll() {
            black_box(p);
        }
        black_box(est.ekf().position());
    }
}

fn halt() -> ! {
    loop {
        core::hint::spin_loop();
    }
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo) -> ! {
    halt()
}
