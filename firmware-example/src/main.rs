//! The smallest complete firmware around `traction::Estimator` (the README's
//! "Use from firmware"): the estimator is a `static` built at compile time
//! by the `const fn` `Estimator::unconfigured`, configured in place at
//! start-up, then fed every sample through `offer` and read through `poll`
//! and `estimate`. The sensors here are stand-ins (a robot standing still);
//! a real board reads its IMU, encoders and flow sensor through the
//! drivers of `traction::wheel_odom` and `traction::flow_sensor`.
//!
//! Build: `cargo build --release` in `firmware-example/` (CI builds it);
//! `memory.x` describes a part with 128 KiB of SRAM.
#![no_std]
#![no_main]

use core::cell::RefCell;

use cortex_m::interrupt::{self, Mutex};
use cortex_m_rt::entry;
use traction::ego_ekf::ImuPlausibility;
use traction::estimator::{Estimator, EstimatorConfig, Processed};
use traction::vslam_core::robot::RobotDescription;
use traction::vslam_core::sensors::{RawImuSample, WheelTicks};
use traction::vslam_core::{Reject, Stream};
use traction::{Estimate, Timestamp};

/// The estimator: built at compile time (no estimator-sized value passes
/// through the stack), shared with interrupt handlers behind a mutex.
static ESTIMATOR: Mutex<RefCell<Estimator<'static>>> =
    Mutex::new(RefCell::new(Estimator::unconfigured()));

/// The robot's description (here the preset; a real robot fills in its
/// wheels, encoders, mountings and noise).
fn robot() -> RobotDescription {
    RobotDescription::robot_vacuum()
}

/// A stand-in IMU read at `t`: a robot standing still, with a real IMU's
/// noise (here the time stamp's low bits), since a reading repeated bit for
/// bit is refused as frozen.
fn read_imu(t: Timestamp) -> RawImuSample {
    let noise = ((t.0 / 4_000_000) % 7) as f32 * 1e-4;
    RawImuSample {
        t,
        gyro: [noise, -noise, 0.5 * noise],
        accel: [noise, 0.0, 9.81 + noise],
    }
}

/// A stand-in encoder read at `t`: the wheels not turning. A real board
/// reads a `traction::wheel_odom::WheelPair` and turns its error into a
/// reason (SPI: `Reject::Bus`; parity, error flag: `Reject::Integrity`; a
/// refused counter jump: `Reject::OutOfRange`).
fn read_wheels(t: Timestamp) -> Result<WheelTicks, Reject> {
    Ok(WheelTicks {
        t,
        left: 0,
        right: 0,
    })
}

/// What the application does with each estimate (here: nothing).
fn use_estimate(e: &Estimate) {
    core::hint::black_box(e);
}

#[entry]
fn main() -> ! {
    let configured = interrupt::free(|cs| {
        let mut est = ESTIMATOR.borrow(cs).borrow_mut();
        EstimatorConfig::from_robot(&robot())
            .map(|mut config| {
                // A real IMU: a reading repeated bit for bit is a frozen output.
                config.filter.imu.plausibility = Some(ImuPlausibility::FIELD);
                est.configure(&config).is_ok()
            })
            .unwrap_or(false)
    });
    if !configured {
        halt();
    }
    // The main loop at the IMU's 250 Hz (a timer interrupt on a real board);
    // the wheels every fifth step (50 Hz).
    let mut step: u64 = 0;
    loop {
        let t = Timestamp(step * 4_000_000);
        interrupt::free(|cs| {
            let mut est = ESTIMATOR.borrow(cs).borrow_mut();
            est.offer_imu(read_imu(t));
            if step.is_multiple_of(5) {
                match read_wheels(t) {
                    Ok(ticks) => est.offer_wheel(ticks),
                    // Counted with its reason; the odometry steps across a
                    // missed read (bus, integrity) only when the counts
                    // continue, never across a refused counter jump.
                    Err(reason) => est.reject_read(Stream::Wheel, t, reason),
                }
            }
            while let Some(p) = est.poll() {
                // Each sample ends fused, gated or rejected with a reason.
                if let Processed::Wheel { outcome: Ok(_), .. } = p
                    && let Some(e) = est.estimate()
                {
                    use_estimate(&e);
                }
            }
        });
        step = step.wrapping_add(1);
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
