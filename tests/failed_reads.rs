//! A failed wheel read breaks the count stream: handed to
//! `Estimator::reject_read` with its time, it is counted with its reason and
//! no odometry step spans it, so counts an encoder's counter extension held
//! across the failure (a refused jump) never become a wheel rate. A missed
//! read (a bus error, an integrity check) leaves the counts continuous: the
//! step across it is kept.

use traction::estimator::{Estimator, Processed};
use traction::reorder::Event;
use traction::vslam_core::sensors::{RawImuSample, WheelTicks};
use traction::vslam_core::{Reject, Stream, Timestamp};

mod common;
use common::estimator;

const MS: u64 = 1_000_000;
/// Counts per 20 ms read on each wheel.
const N: i64 = 60;

/// Each wheel sample's time (ms) and outcome.
type Outcomes = Vec<(u64, Result<(), Reject>)>;

/// The wheel outcomes of a straight drive at constant wheel speed whose
/// reads from 1,020 to 1,100 ms fail, the left encoder's counts held across
/// them; `report`: the failures are handed to the estimator.
fn drive(report: bool) -> (Estimator<'static>, Outcomes) {
    drive_with(report.then_some(Reject::OutOfRange), true)
}

/// [`drive`] with the failures reported with `reason` (or not at all), the
/// left's counts `held` across them or continuous.
fn drive_with(reason: Option<Reject>, held: bool) -> (Estimator<'static>, Outcomes) {
    let mut est = estimator();
    let mut outcomes = Vec::new();
    let failing = |t: u64| (1_020 * MS..=1_100 * MS).contains(&t);
    for k in 1..=500u64 {
        let t = 4 * MS * k;
        est.offer(Event::Imu(RawImuSample {
            t: Timestamp(t),
            gyro: [0.0; 3],
            accel: [0.0, 0.0, 9.81],
        }));
        if t.is_multiple_of(20 * MS) {
            let reads = (t / (20 * MS)) as i64;
            if failing(t) {
                if let Some(reason) = reason {
                    est.reject_read(Stream::Wheel, Timestamp(t), reason);
                }
            } else {
                // The left's extension refused the jump and held: the five
                // failed reads' counts are missing from its position.
                let held = if held && t > 1_100 * MS { 5 * N } else { 0 };
                est.offer(Event::Wheel(WheelTicks {
                    t: Timestamp(t),
                    left: reads * N - held,
                    right: reads * N,
                }));
            }
        }
        while let Some(p) = est.poll() {
            if let Processed::Wheel { t, outcome } = p {
                outcomes.push((t.0 / MS, outcome.map(|_| ())));
            }
        }
    }
    (est, outcomes)
}

fn outcome_at(outcomes: &[(u64, Result<(), Reject>)], ms: u64) -> Option<Result<(), Reject>> {
    outcomes.iter().find(|(t, _)| *t == ms).map(|(_, o)| *o)
}

#[test]
fn the_sample_after_a_failed_read_anchors_the_counts() {
    let (est, outcomes) = drive(true);
    // The first sample after the failures only anchors the counts; the
    // next is a step again.
    assert_eq!(outcome_at(&outcomes, 1_120), Some(Err(Reject::NotReady)));
    assert_eq!(outcome_at(&outcomes, 1_140), Some(Ok(())));
    // The failed reads are counted with their reason.
    assert_eq!(est.counts()[Stream::Wheel].rejected(Reject::OutOfRange), 5);
}

#[test]
fn unreported_the_held_counts_become_a_step() {
    let (_, outcomes) = drive(false);
    // Without the failures reported, the sample after them is measured from
    // the last one before them: a step (fused or gated), not an anchor.
    assert_ne!(outcome_at(&outcomes, 1_120), Some(Err(Reject::NotReady)));
    assert!(outcome_at(&outcomes, 1_120).is_some());
}

#[test]
fn a_step_spans_missed_reads() {
    // A refused counter jump breaks the stream: the sample after it anchors.
    let (broken, outcomes) = drive_with(Some(Reject::OutOfRange), false);
    assert_eq!(outcome_at(&outcomes, 1_120), Some(Err(Reject::NotReady)));
    let not_ready = |e: &Estimator<'_>| e.counts()[Stream::Wheel].rejected(Reject::NotReady);
    for reason in [Reject::Bus, Reject::Integrity] {
        let (est, outcomes) = drive_with(Some(reason), false);
        // The counts continued across the missed reads: the sample after
        // them is a step from the last one before them, with their motion.
        assert_eq!(outcome_at(&outcomes, 1_120), Some(Ok(())), "{reason:?}");
        assert_eq!(est.counts()[Stream::Wheel].rejected(reason), 5);
        // No anchor after them (the others: before the filter started).
        assert_eq!(not_ready(&est) + 1, not_ready(&broken));
    }
}
