//! The flow-demand policy read from a running estimator
//! (`FlowDemand::observe`): a robot stands, its wheels suddenly spin while
//! the IMU feels no motion (slip), then they stop. The policy stays off
//! while all agree, wakes the flow sensor on the wheels' disagreement with
//! the IMU-propagated state, and releases it the quiet period after the
//! spin ends.

use traction::flow_demand::{Command, Cue, FlowDemand, FlowDemandConfig};
use traction::reorder::Event;
use traction::vslam_core::Timestamp;
use traction::vslam_core::sensors::{RawImuSample, WheelTicks};

mod common;
use common::estimator;

const SPIN_START_NS: u64 = 2_000_000_000;
const SPIN_END_NS: u64 = 3_000_000_000;

#[test]
fn wheels_spinning_against_a_still_imu_wake_the_sensor_and_quiet_releases_it() {
    let mut est = estimator();
    let mut demand = FlowDemand::new(FlowDemandConfig::default()).unwrap();
    let mut commands: Vec<(u64, Command)> = Vec::new();
    let mut counts = 0i64;
    for k in 0..2000u64 {
        let t = 4_000_000 * (k + 1);
        est.offer(Event::Imu(RawImuSample {
            t: Timestamp(t),
            gyro: [0.0; 3],
            accel: [0.0, 0.0, 9.81],
        }));
        if t % 20_000_000 == 0 {
            if (SPIN_START_NS..SPIN_END_NS).contains(&t) {
                counts += 100; // ~0.27 m/s of wheel surface speed
            }
            est.offer(Event::Wheel(WheelTicks {
                t: Timestamp(t),
                left: counts,
                right: counts,
            }));
        }
        while let Some(p) = est.poll() {
            if let Some(c) = demand.observe(&est, &p) {
                commands.push((p.t().0, c));
            }
        }
    }
    assert_eq!(commands.len(), 2, "{commands:?}");
    let (wake_t, wake) = commands[0];
    assert_eq!(wake, Command::Wake(Cue::WheelsVsImu));
    assert!(
        (SPIN_START_NS..SPIN_START_NS + 200_000_000).contains(&wake_t),
        "woken at {wake_t} ns"
    );
    let (off_t, off) = commands[1];
    assert_eq!(off, Command::Shutdown);
    // Released 3 s after the last disagreement, which is during the spin or
    // just after it.
    assert!(
        (SPIN_END_NS + 2_900_000_000..SPIN_END_NS + 3_300_000_000).contains(&off_t),
        "released at {off_t} ns"
    );
    assert!(!demand.is_on());
    assert_eq!(demand.wakes(), 1);
    let on = demand.on_seconds(Timestamp(8_000_000_000));
    assert!((3.9..4.3).contains(&on), "on for {on} s");
}
