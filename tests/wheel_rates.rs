//! Wheel angular rates (`Event::WheelRates`, for robots that report rates
//! instead of counts) take the same way through the estimator as counts: on
//! a drive at constant wheel speeds the counts and the equivalent rates give
//! the same filter state, and bad rates are counted by reason in the wheel
//! stream.

use traction::estimator::Estimator;
use traction::reorder::Event;
use traction::vslam_core::sensors::{RawImuSample, RawWheelRates, WheelTicks};
use traction::vslam_core::{Reject, Stream, Timestamp};

mod common;
use common::estimator;

const TPR: u32 = 4096;

/// 1 s standing, then 3 s at constant wheel speeds (`n` counts per 20 ms on
/// the left, `n + 4` on the right); IMU at 250 Hz reading a gentle turn.
/// `rates`: the wheels as angular rates instead of counts.
fn drive(rates: bool, n: i64) -> Estimator<'static> {
    let mut est = estimator();
    let step_ns = 20_000_000u64;
    let (wl, wr) = (
        n as f64 * std::f64::consts::TAU / f64::from(TPR) / 0.02,
        (n + 4) as f64 * std::f64::consts::TAU / f64::from(TPR) / 0.02,
    );
    let yaw_rate = 0.035 * (wr - wl) / 0.23;
    for k in 0..1000u64 {
        let t = 4_000_000 * (k + 1);
        let moving = t > 1_000_000_000;
        est.offer(Event::Imu(RawImuSample {
            t: Timestamp(t),
            gyro: [0.0, 0.0, if moving { yaw_rate as f32 } else { 0.0 }],
            accel: [0.0, 0.0, 9.81],
        }));
        if t % step_ns == 0 {
            let moved = (t.saturating_sub(1_000_000_000) / step_ns) as i64;
            est.offer(if rates {
                let on = if moving { 1.0 } else { 0.0 };
                Event::WheelRates(RawWheelRates {
                    t: Timestamp(t),
                    left: (on * wl) as f32,
                    right: (on * wr) as f32,
                })
            } else {
                Event::Wheel(WheelTicks {
                    t: Timestamp(t),
                    left: moved * n,
                    right: moved * (n + 4),
                })
            });
        }
        while est.poll().is_some() {}
    }
    est.finish();
    while est.poll().is_some() {}
    est
}

#[test]
fn rates_and_counts_of_the_same_drive_give_the_same_estimate() {
    let ticks = drive(false, 40);
    let rates = drive(true, 40);
    let (a, b) = (ticks.ekf().position(), rates.ekf().position());
    assert!(a.x > 0.1, "the robot drove: {a:?}");
    assert!((a - b).norm() < 1e-3, "counts {a:?}, rates {b:?}");
    let (ca, cb) = (ticks.counts()[Stream::Wheel], rates.counts()[Stream::Wheel]);
    assert_eq!(
        (ca.seen(), ca.fused()),
        (cb.seen(), cb.fused()),
        "{ca} / {cb}"
    );
    assert!(cb.fused() + cb.gated() > 150 && cb.fused() > 0, "{cb}");
}

#[test]
fn bad_rates_are_counted_by_reason_in_the_wheel_stream() {
    let mut est = estimator();
    let rate = |t: u64, left: f32| {
        Event::WheelRates(RawWheelRates {
            t: Timestamp(t),
            left,
            right: 0.0,
        })
    };
    est.offer(rate(10_000_000, 0.0));
    est.offer(rate(20_000_000, f32::NAN));
    est.offer(rate(30_000_000, 1.0e4));
    est.offer(rate(30_000_000, 0.0));
    est.finish();
    while est.poll().is_some() {}
    let c = est.counts()[Stream::Wheel];
    assert_eq!(c.seen(), 4);
    assert_eq!(c.rejected(Reject::NonFinite), 1, "{c}");
    assert_eq!(c.rejected(Reject::OutOfRange), 1, "{c}");
}
