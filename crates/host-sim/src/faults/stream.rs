//! [`FaultInjector`]: a wrapper around any sensor stream (an iterator of
//! IMU samples, wheel counts or flow reports) that spoils it as a fault list
//! says, the way smoltcp's `FaultInjector` wraps a network device. It yields
//! [`Delivery`]s: the sample and when it reaches the estimator (a late
//! sample arrives after later ones), and it keeps a record of every sample it
//! spoiled and the outcome that sample must end in.
//!
//! The same injector runs twice in `simulate --faults`: on the generated
//! samples before the log is written ([`Stage::Log`]: values, gaps) and on the
//! samples read back from the log ([`Stage::Stream`]: non-finite values and
//! time stamps that do not strictly increase, which the ASL format refuses).

use super::kind::{FaultKind, Sensor, Stage};
use super::spec::{FaultPlan, FaultSpec};
use std::collections::VecDeque;
use traction::ego_ekf::{FilterConfig, ImuPlausibility};
use traction::vslam_core::Timestamp;
use traction::vslam_core::sensors::{FlowSample, RawImuSample, WheelTicks};
use traction::wheel_odom::odometry::DiffDriveParams;

/// How late a [`FaultKind::Late`] sample arrives, nanoseconds (three times
/// the estimator's 20 ms ordering window).
pub const LATE_NS: u64 = 60_000_000;

/// One sample as it reaches the estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Delivery<S> {
    /// When it arrives (its own time stamp unless it is late).
    pub arrival: Timestamp,
    /// The sample.
    pub sample: S,
}

/// A sample a fault spoiled: which fault, and the spoiled sample's time stamp
/// and its place among the deliveries with that time stamp (0 unless
/// duplicated).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpoiledSample {
    /// Index of the fault in the plan.
    pub fault: usize,
    /// The spoiled sample's time stamp.
    pub t: Timestamp,
    /// Its delivery number in the output of the injector.
    pub delivery: usize,
}

/// A stream sample the injector can spoil.
pub trait SensorSample: Copy {
    /// Which sensor produces it.
    const SENSOR: Sensor;
    /// Its time stamp.
    fn t(&self) -> Timestamp;
    /// Re-stamps it.
    fn set_t(&mut self, t: Timestamp);
    /// Applies value fault `kind`; `before` is the last sample before the
    /// fault began (what a stuck sensor repeats), `previous` the previous
    /// original sample. Returns whether the sample was spoiled (a fault that
    /// needs motion skips a sample without any).
    fn spoil(
        &mut self,
        kind: FaultKind,
        before: Option<&Self>,
        previous: Option<&Self>,
        k: u32,
    ) -> bool;
    /// Whether this spoiled sample is judged against the kind's expected
    /// outcome (the default): a spoiled value the estimator cannot tell
    /// from a true one is not (an IMU repeat within an output period, a
    /// spike within what the robot can do).
    fn judged(&self, _kind: FaultKind, _before: Option<&Self>) -> bool {
        true
    }
}

impl SensorSample for RawImuSample {
    const SENSOR: Sensor = Sensor::Imu;
    fn t(&self) -> Timestamp {
        self.t
    }
    fn set_t(&mut self, t: Timestamp) {
        self.t = t;
    }
    fn spoil(&mut self, kind: FaultKind, before: Option<&Self>, _: Option<&Self>, _: u32) -> bool {
        match kind {
            FaultKind::ImuNan => self.gyro[0] = f32::NAN,
            FaultKind::ImuInf => self.accel[1] = f32::INFINITY,
            FaultKind::ImuOutlier => self.gyro[2] *= 100.0,
            FaultKind::ImuSaturated => self.gyro[2] = FilterConfig::default().imu.gyro_max,
            FaultKind::ImuStuck => match before {
                Some(b) => {
                    self.gyro = b.gyro;
                    self.accel = b.accel;
                }
                None => return false,
            },
            _ => return false,
        }
        true
    }

    /// A frozen reading is judged once the filter's plausibility check
    /// can tell (more than `frozen_after_ns` after the reading it repeats);
    /// a spike once it lies beyond twice the rate change the check allows
    /// since the last reading before the fault (the whole rate's, or the
    /// yaw rate's about the simulated IMU's vertical z axis), or at full
    /// scale.
    fn judged(&self, kind: FaultKind, before: Option<&Self>) -> bool {
        let check = ImuPlausibility::FIELD;
        let since = |b: &Self| self.t.0.saturating_sub(b.t.0);
        match (kind, before) {
            (FaultKind::ImuStuck, Some(b)) => check.frozen_after_ns.is_some_and(|f| since(b) > f),
            (FaultKind::ImuOutlier, Some(b)) => {
                let jump = (0..3)
                    .map(|i| (self.gyro[i] - b.gyro[i]).powi(2))
                    .sum::<f32>()
                    .sqrt();
                let full_scale = FilterConfig::default().imu.gyro_max;
                let yaw_jump = (self.gyro[2] - b.gyro[2]).abs();
                self.gyro[2].abs() >= full_scale
                    || jump > 2.0 * check.allowance(since(b))
                    || yaw_jump > 2.0 * check.yaw_allowance(since(b))
            }
            _ => true,
        }
    }
}

impl SensorSample for WheelTicks {
    const SENSOR: Sensor = Sensor::Wheel;
    fn t(&self) -> Timestamp {
        self.t
    }
    fn set_t(&mut self, t: Timestamp) {
        self.t = t;
    }
    fn spoil(
        &mut self,
        kind: FaultKind,
        before: Option<&Self>,
        previous: Option<&Self>,
        _: u32,
    ) -> bool {
        match (kind, before, previous) {
            // Every increment from the last count before the fault x100, so
            // each spoiled sample's own increment is x100 (the counts after
            // the fault are the true ones again: one jump back, not judged).
            (FaultKind::WheelOutlier, Some(b), Some(p)) => {
                if self.left == p.left && self.right == p.right {
                    return false;
                }
                self.left = b.left + 100 * (self.left - b.left);
                self.right = b.right + 100 * (self.right - b.right);
            }
            (FaultKind::WheelStuck, Some(b), _) => {
                self.left = b.left;
                self.right = b.right;
            }
            _ => return false,
        }
        true
    }
}

impl SensorSample for FlowSample {
    const SENSOR: Sensor = Sensor::Flow;
    fn t(&self) -> Timestamp {
        self.t
    }
    fn set_t(&mut self, t: Timestamp) {
        self.t = t;
    }
    fn spoil(&mut self, kind: FaultKind, before: Option<&Self>, _: Option<&Self>, k: u32) -> bool {
        let clamp = |v: i32| v.clamp(i16::MIN as i32 + 1, i16::MAX as i32 - 1) as i16;
        match kind {
            FaultKind::FlowOutlier => {
                if self.dx == 0 && self.dy == 0 {
                    return false;
                }
                self.dx = clamp(100 * self.dx as i32);
                self.dy = clamp(100 * self.dy as i32);
            }
            FaultKind::FlowStuck => match before {
                Some(b) => {
                    let t = self.t;
                    *self = *b;
                    self.t = t;
                }
                None => return false,
            },
            FaultKind::FlowLimit => self.dx = i16::MAX,
            FaultKind::FlowLowSqual => {
                // 10..=24: below the datasheet's 0x19, with a normal shutter
                // the report stays valid: low quality is noise.
                self.squal = 10 + (k % 15) as u8;
                if (self.shutter >> 8) as u8 >= FlowSample::SHUTTER_UPPER_MAX {
                    self.shutter = 0x0C00;
                }
            }
            FaultKind::FlowTextureless => {
                self.dx = 0;
                self.dy = 0;
                self.squal = 5;
                self.shutter = 0x1F80;
            }
            _ => return false,
        }
        self.motion = self.dx != 0 || self.dy != 0;
        true
    }
}

/// Whether `kind` is a value fault (it changes fields, not time).
fn is_value_fault(kind: FaultKind) -> bool {
    !matches!(
        kind,
        FaultKind::Duplicate(_) | FaultKind::ZeroDt(_) | FaultKind::Late(_) | FaultKind::Gap(_)
    )
}

struct Active {
    index: usize,
    spec: FaultSpec,
    /// Samples still to spoil (count faults).
    remaining: u32,
    /// Samples spoiled so far.
    done: u32,
    /// The last original sample before the window (stuck sensors).
    before_fill: bool,
    /// Samples after a gap still to be marked (the sample that ends it).
    after_gap: u32,
    /// Samples dropped by a gap.
    dropped: u32,
}

/// The fault injector; see the module documentation.
pub struct FaultInjector<I: Iterator> {
    inner: I,
    active: Vec<Active>,
    before: Vec<Option<I::Item>>,
    previous: Option<I::Item>,
    previous_out: Option<Timestamp>,
    out: VecDeque<Delivery<I::Item>>,
    delivered: usize,
    spoiled: Vec<SpoiledSample>,
}

impl<S: SensorSample, I: Iterator<Item = S>> FaultInjector<I> {
    /// Wraps `inner` with the faults of `plan` on this sensor's stream that
    /// belong to `stage`.
    pub fn new(inner: I, plan: &FaultPlan, stage: Stage) -> Self {
        let active: Vec<Active> = plan
            .select(|f| f.kind.stage() == stage && f.kind.stream() == Some(S::SENSOR.stream()))
            .map(|(index, spec)| Active {
                index,
                spec: *spec,
                remaining: spec.count,
                done: 0,
                before_fill: false,
                // After a gap longer than the odometry's largest step the
                // odometry re-anchors on the first wheel sample and the
                // filter's own clock refuses the second: both are the gap's.
                after_gap: if S::SENSOR == Sensor::Wheel { 2 } else { 1 },
                dropped: 0,
            })
            .collect();
        let n = active.len();
        FaultInjector {
            inner,
            active,
            before: vec![None; n],
            previous: None,
            previous_out: None,
            out: VecDeque::new(),
            delivered: 0,
            spoiled: Vec::new(),
        }
    }

    /// Every sample spoiled so far.
    pub fn spoiled(&self) -> &[SpoiledSample] {
        &self.spoiled
    }

    /// Samples each fault (by plan index) removed from the stream.
    pub fn dropped(&self) -> Vec<(usize, u32)> {
        self.active
            .iter()
            .filter(|a| a.dropped > 0)
            .map(|a| (a.index, a.dropped))
            .collect()
    }

    fn emit(&mut self, arrival: Timestamp, sample: S, spoiled_by: &[usize]) {
        for f in spoiled_by {
            self.spoiled.push(SpoiledSample {
                fault: *f,
                t: sample.t(),
                delivery: self.delivered,
            });
        }
        self.out.push_back(Delivery { arrival, sample });
        self.delivered += 1;
        self.previous_out = Some(sample.t());
    }

    fn take(&mut self, original: S) {
        let t = original.t().0;
        let mut sample = original;
        let mut by = Vec::new();
        let mut drop = false;
        let mut late = false;
        let mut dup = false;
        for (i, a) in self.active.iter_mut().enumerate() {
            let kind = a.spec.kind;
            let windowed = kind.has_window();
            if t < a.spec.start_ns() {
                // Remember the last sample before the fault (what a stuck sensor repeats).
                if let Some(slot) = self.before.get_mut(i) {
                    *slot = Some(original);
                }
                continue;
            }
            a.before_fill = true;
            let before = self.before.get(i).copied().flatten();
            match kind {
                FaultKind::Gap(_) => {
                    if a.spec.covers(t) {
                        drop = true;
                        a.dropped += 1;
                    } else if a.dropped > 0 && a.after_gap > 0 {
                        // A wheel gap no longer than the odometry's largest
                        // step is integrated across by the odometry (no
                        // re-anchoring): only the filter's clock refuses it.
                        let within_odometry_step = before.is_some_and(|b| {
                            t.saturating_sub(b.t().0) <= DiffDriveParams::MAX_STEP_NS
                        });
                        if S::SENSOR == Sensor::Wheel && a.after_gap == 2 && within_odometry_step {
                            a.after_gap = 1;
                        }
                        a.after_gap -= 1;
                        by.push(a.index);
                    }
                }
                _ if windowed
                    && a.spec.covers(t)
                    && sample.spoil(kind, before.as_ref(), self.previous.as_ref(), a.done) =>
                {
                    a.done += 1;
                    if sample.judged(kind, before.as_ref()) {
                        by.push(a.index);
                    }
                }
                _ if windowed => {}
                _ if a.remaining == 0 => {}
                FaultKind::Duplicate(_) => {
                    dup = true;
                    a.remaining -= 1;
                }
                FaultKind::ZeroDt(_) => {
                    if let Some(p) = self.previous_out {
                        sample.set_t(p);
                        a.remaining -= 1;
                        by.push(a.index);
                    }
                }
                FaultKind::Late(_) => {
                    late = true;
                    a.remaining -= 1;
                    by.push(a.index);
                }
                _ if is_value_fault(kind)
                    && sample.spoil(kind, before.as_ref(), self.previous.as_ref(), a.done) =>
                {
                    a.done += 1;
                    a.remaining -= 1;
                    if sample.judged(kind, before.as_ref()) {
                        by.push(a.index);
                    }
                }
                _ => {}
            }
        }
        self.previous = Some(original);
        if drop {
            return;
        }
        let arrival = if late {
            Timestamp(sample.t().0 + LATE_NS)
        } else {
            sample.t()
        };
        if late {
            // A late sample is held back until its arrival; everything
            // earlier goes out first (see `next`).
            let previous_out = self.previous_out;
            self.emit(arrival, sample, &by);
            self.previous_out = previous_out;
            return;
        }
        self.emit(arrival, sample, &by);
        if dup {
            let dup_by: Vec<usize> = self
                .active
                .iter()
                .filter(|a| {
                    matches!(a.spec.kind, FaultKind::Duplicate(_)) && a.spec.start_ns() <= t
                })
                .map(|a| a.index)
                .take(1)
                .collect();
            self.emit(sample.t(), sample, &dup_by);
        }
    }
}

impl<S: SensorSample, I: Iterator<Item = S>> Iterator for FaultInjector<I> {
    type Item = Delivery<S>;

    fn next(&mut self) -> Option<Delivery<S>> {
        while self.out.is_empty() {
            let s = self.inner.next()?;
            self.take(s);
        }
        self.out.pop_front()
    }
}

/// What [`inject`] gives: the deliveries, the spoiled samples, and the
/// samples each fault (by plan index) removed.
pub type Injection<S> = (Vec<Delivery<S>>, Vec<SpoiledSample>, Vec<(usize, u32)>);

/// Runs `samples` through an injector of `plan` at `stage`: the deliveries
/// (in the order the injector produced them; sort by arrival, stably, to
/// get the order they reach the estimator) and the spoiled samples.
pub fn inject<S: SensorSample>(samples: &[S], plan: &FaultPlan, stage: Stage) -> Injection<S> {
    let mut inj = FaultInjector::new(samples.iter().copied(), plan, stage);
    let out: Vec<Delivery<S>> = inj.by_ref().collect();
    let spoiled = inj.spoiled().to_vec();
    let dropped = inj.dropped();
    (out, spoiled, dropped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::faults::kind::FaultKind;

    fn imu(n: u64) -> Vec<RawImuSample> {
        (0..n)
            .map(|i| RawImuSample {
                t: Timestamp(i * 4_000_000),
                gyro: [0.01, 0.02, 0.03],
                accel: [0.1, 0.2, 9.81],
            })
            .collect()
    }

    #[test]
    fn nan_dup_dt0_and_late_are_recorded() {
        let plan: FaultPlan = "imu-nan@0.1x2,imu-dup@0.2,imu-dt0@0.3,imu-late@0.4"
            .parse()
            .unwrap();
        let input = imu(200);
        let (out, spoiled, _) = inject(&input, &plan, Stage::Stream);
        assert_eq!(out.len(), 201, "one duplicate added");
        assert_eq!(spoiled.len(), 5);
        let nan: Vec<_> = out.iter().filter(|d| d.sample.gyro[0].is_nan()).collect();
        assert_eq!(nan.len(), 2);
        assert_eq!(nan[0].sample.t, Timestamp(100_000_000));
        let t = |k: u64| Timestamp(k * 4_000_000);
        assert_eq!(out.iter().filter(|d| d.sample.t == t(50)).count(), 2);
        // dt0: sample 75 carries 74's time stamp.
        assert_eq!(out.iter().filter(|d| d.sample.t == t(74)).count(), 2);
        assert!(out.iter().all(|d| d.sample.t != t(75)));
        let late = out.iter().find(|d| d.sample.t == t(100)).unwrap();
        assert_eq!(late.arrival, Timestamp(t(100).0 + LATE_NS));
        // Value faults are not applied at the stream stage of the log faults.
        let (out, spoiled, _) = inject(&input, &"imu-stuck@0.1".parse().unwrap(), Stage::Stream);
        assert_eq!((out.len(), spoiled.len()), (200, 0));
    }

    #[test]
    fn gaps_drop_and_mark_the_samples_that_end_them() {
        let plan: FaultPlan = "imu-gap@0.1+0.5".parse().unwrap();
        let (out, spoiled, dropped) = inject(&imu(400), &plan, Stage::Log);
        assert_eq!(dropped, vec![(0, 125)]);
        assert_eq!(out.len(), 275);
        assert_eq!(spoiled.len(), 1);
        assert_eq!(spoiled[0].t, Timestamp(600_000_000));
        let wheels: Vec<WheelTicks> = (0..100)
            .map(|i| WheelTicks {
                t: Timestamp(i * 20_000_000),
                left: 10 * i as i64,
                right: 10 * i as i64,
            })
            .collect();
        let (_, spoiled, _) = inject(&wheels, &"wheel-gap@0.5+0.5".parse().unwrap(), Stage::Log);
        assert_eq!(spoiled.len(), 2, "the odometry's and the filter's");
    }

    #[test]
    fn stuck_repeats_and_outliers_scale() {
        let mut input = imu(200);
        for (i, s) in input.iter_mut().enumerate() {
            s.gyro[2] = i as f32;
        }
        let (out, spoiled, _) = inject(&input, &"imu-stuck@0.2+0.1".parse().unwrap(), Stage::Log);
        // All 25 repeat sample 49 (196 ms); judged are those more than
        // 20 ms after it: from sample 55 (220 ms) on.
        assert_eq!(spoiled.len(), 20);
        assert_eq!(spoiled[0].t, Timestamp(220_000_000));
        // A hundredfold rate is judged when it lies beyond twice the change
        // the filter allows (0.7 rad/s a 4 ms step; about the vertical 0.18
        // rad/s, then 0.26, 0.34 .. since the reading before): turning at
        // 0.2 rad/s all three, at 0.005 rad/s the first (0.495 rad/s), at
        // 0.001 rad/s none; the sample is spoiled either way.
        for (rate, judged) in [(0.2f32, 3), (0.005, 1), (0.001, 0)] {
            let mut input = imu(200);
            input.iter_mut().for_each(|s| s.gyro[2] = rate);
            let (out, spoiled, _) =
                inject(&input, &"imu-outlier@0.2x3".parse().unwrap(), Stage::Log);
            assert_eq!(spoiled.len(), judged, "{rate}");
            assert_eq!(out[50].sample.gyro[2], 100.0 * rate);
        }
        assert!(out[50..75].iter().all(|d| d.sample.gyro[2] == 49.0));
        assert_eq!(out[75].sample.gyro[2], 75.0);
        let wheels: Vec<WheelTicks> = (0..10)
            .map(|i| WheelTicks {
                t: Timestamp(i * 20_000_000),
                left: 10 * i as i64,
                right: 5 * i as i64,
            })
            .collect();
        let (out, spoiled, _) = inject(&wheels, &"wheel-outlier@0.1".parse().unwrap(), Stage::Log);
        assert_eq!(spoiled.len(), 1);
        assert_eq!(
            (out[5].sample.left, out[5].sample.right),
            (40 + 1000, 20 + 500)
        );
        assert_eq!(out[6].sample.left, 60);
        // Several: each spoiled sample's own increment is x100.
        let (out, spoiled, _) =
            inject(&wheels, &"wheel-outlier@0.1x3".parse().unwrap(), Stage::Log);
        assert_eq!(spoiled.len(), 3);
        for k in 5..8 {
            let (a, b) = (&out[k - 1].sample, &out[k].sample);
            assert_eq!((b.left - a.left, b.right - a.right), (1000, 500), "{k}");
        }
        assert_eq!(out[8].sample.left, 80);
        assert_eq!(FaultKind::WheelOutlier.stage(), Stage::Log);
    }

    mod props {
        use super::super::*;
        use crate::faults::kind::{FaultKind, Sensor};
        use crate::faults::spec::FaultSpec;
        use proptest::prelude::*;
        use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, RngSeed};

        fn config() -> Config {
            Config {
                cases: 128,
                rng_algorithm: RngAlgorithm::ChaCha,
                rng_seed: RngSeed::Fixed(0x6661_756c_7473),
                failure_persistence: Some(Box::new(FileFailurePersistence::Off)),
                ..Config::default()
            }
        }

        fn flow_kind() -> impl Strategy<Value = FaultKind> {
            prop::sample::select(vec![
                FaultKind::FlowOutlier,
                FaultKind::FlowStuck,
                FaultKind::FlowLimit,
                FaultKind::FlowLowSqual,
                FaultKind::FlowTextureless,
                FaultKind::Duplicate(Sensor::Flow),
                FaultKind::ZeroDt(Sensor::Flow),
                FaultKind::Late(Sensor::Flow),
                FaultKind::Gap(Sensor::Flow),
            ])
        }

        fn plan() -> impl Strategy<Value = FaultPlan> {
            prop::collection::vec((flow_kind(), 0.0..1.2f64, 0.01..0.6f64, 1u32..4), 0..5).prop_map(
                |v| FaultPlan {
                    faults: v
                        .into_iter()
                        .map(|(k, start, d, n)| {
                            let f = FaultSpec::new(k, start);
                            if k.has_window() {
                                f.lasting(d)
                            } else {
                                f.times(n)
                            }
                        })
                        .collect(),
                },
            )
        }

        proptest! {
            #![proptest_config(config())]

            /// Whatever the plan: no panic; every record names a delivered
            /// sample with its time stamp; only gaps remove samples, only
            /// duplicates add them; both stages together see every fault.
            #[test]
            fn every_record_names_a_delivered_sample(plan in plan(), n in 1usize..150) {
                let input: Vec<FlowSample> = (0..n as u64)
                    .map(|i| FlowSample {
                        t: Timestamp(10_000_000 * (i + 1)),
                        dx: (i % 7) as i16 - 3,
                        dy: 2,
                        squal: 90,
                        shutter: 0x0200,
                        motion: true,
                        ..FlowSample::default()
                    })
                    .collect();
                let mut total_dropped = 0u32;
                let mut samples = input.clone();
                for stage in [Stage::Log, Stage::Stream] {
                    let (out, spoiled, dropped) = inject(&samples, &plan, stage);
                    for s in &spoiled {
                        prop_assert!(plan.faults.get(s.fault).is_some());
                        let d = out.get(s.delivery);
                        prop_assert!(d.is_some_and(|d| d.sample.t == s.t), "{s:?}");
                    }
                    let dropped: u32 = dropped.iter().map(|d| d.1).sum();
                    total_dropped += dropped;
                    let dups = out.len() + dropped as usize - samples.len();
                    prop_assert!(dups <= plan.faults.iter().filter(|f| matches!(f.kind, FaultKind::Duplicate(_))).map(|f| f.count as usize).sum::<usize>());
                    prop_assert!(out.iter().all(|d| d.arrival >= d.sample.t));
                    samples = out.into_iter().map(|d| d.sample).collect();
                }
                prop_assert!(samples.len() + total_dropped as usize >= input.len());
            }
        }
    }
}
