//! The flow transaction `To`: downward optical-flow counts to metres.
//!
//! Per report, [`FlowOptics`] turns the counts into the sensor-plane
//! displacement and that into the body origin's ([`FlowOptics::to_body`]):
//! a sensor at `r` from the body origin moves by `v + w x r`, so over a
//! report the body origin moved `d_sensor - dyaw * (z x r)`.
//!
//! Not modelled: the angular flow of body pitch and roll rates (PX4 subtracts
//! the gyro's x/y rates); a wheeled robot on a floor has next to none, and
//! over a frame interval they integrate to nearly zero.
//!
//! Reports land in a [`FlowStepWindow`] as [`FlowStep`]s (body-origin
//! displacement, heading change, confidence over the report's own interval);
//! raw-frame flow ([`super::raw_flow`]) produces the same steps.

use heapless::Deque;

use super::confidence::{FlowConfidenceParams, flow_sample_confidence};
use super::interval::{Coverage, ending_after, overlap_fraction};
use super::transactions::{Chord, Distance, Transaction};
use crate::geometry::{Extrinsics, Vec2, Vec3};
use crate::kinematics::{add_lever_arm, sensor_plane_to_body};
use crate::reject::{Reject, SampleCounts};
use crate::sensors::{FlowOptics, FlowSample};
use crate::time::{SampleClock, Timestamp};

/// The body's motion over one flow report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowStep {
    /// Start of the report's interval.
    pub t0: Timestamp,
    /// End of the report's interval.
    pub t1: Timestamp,
    /// Displacement of the body origin, metres, body frame at `t0` (x, y).
    pub d_body: Vec2,
    /// Heading change used for the lever arm, radians.
    pub dyaw: f32,
    /// Confidence of the report, `0..=1`.
    pub confidence: f32,
}

/// A sensor-plane displacement (metres, sensor x/y) to the body origin's
/// (x, y): rotated by the mounting, lever arm `dyaw * (z x t_BS)` removed
/// ([`sensor_plane_to_body`]).
pub fn sensor_to_body(d_sensor: Vec2, mount: &Extrinsics, dyaw: f32) -> Vec2 {
    sensor_plane_to_body(&d_sensor, mount, &yaw_vector(dyaw)).xy()
}

/// A heading change about the body's z axis as a rotation vector.
fn yaw_vector(dyaw: f32) -> Vec3 {
    Vec3::new(0.0, 0.0, dyaw)
}

/// Flow settings for the transaction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlowParams {
    /// Relative standard deviation of the path at full confidence.
    pub rel_sigma: f32,
    /// Standard deviation floor, metres.
    pub floor_sigma: f32,
    /// Longest accepted time between reports, nanoseconds (longer: `Gap`).
    pub max_step_ns: u64,
    /// Quality to confidence.
    pub quality: FlowConfidenceParams,
}

impl Default for FlowParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl FlowParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = FlowParams {
        rel_sigma: 0.02,
        floor_sigma: 0.0005,
        max_step_ns: 100_000_000,
        quality: FlowConfidenceParams::DEFAULT,
    };
}

/// The flow over one interval, before the variance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlowSummary {
    /// `To`: path of the chosen body point, metres, uncovered time extrapolated.
    pub path: f32,
    /// Chord of the chosen body point, metres, uncovered time extrapolated.
    pub chord: f32,
    /// Time-weighted mean report confidence.
    pub confidence: f32,
    /// Fraction of the interval covered by reports.
    pub coverage: f32,
    /// Reports that overlapped the interval.
    pub samples: u16,
    /// Overlapping reports with zero confidence (blank floor, invalid reports).
    pub blank: u16,
}

/// A window of recent flow steps, queried per camera interval.
#[derive(Clone, Debug)]
pub struct FlowStepWindow<const N: usize> {
    params: FlowParams,
    steps: Deque<FlowStep, N>,
    clock: SampleClock,
    last_t1: Option<Timestamp>,
    counts: SampleCounts,
}

impl<const N: usize> FlowStepWindow<N> {
    /// An empty window.
    pub const fn new(params: FlowParams) -> Self {
        FlowStepWindow {
            params,
            steps: Deque::new(),
            clock: SampleClock::new(params.max_step_ns),
            last_t1: None,
            counts: SampleCounts::new(),
        }
    }

    /// Empties the window in place and takes `params`, as [`FlowStepWindow::new`].
    pub fn reset(&mut self, params: FlowParams) {
        self.params = params;
        self.steps.clear();
        self.clock = SampleClock::new(params.max_step_ns);
        self.last_t1 = None;
        self.counts = SampleCounts::new();
    }

    /// The settings.
    pub fn params(&self) -> &FlowParams {
        &self.params
    }

    /// Fused and rejected reports by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Counts a report that was rejected before it reached the window.
    pub fn count_rejected(&mut self, reason: Reject) {
        self.counts.rejected_one(reason);
    }

    /// Time of the previous accepted report (start of the next one's interval).
    pub fn last_report(&self) -> Option<Timestamp> {
        self.clock.last()
    }

    /// Adds one report of the counting sensor; `dyaw` is the heading change
    /// since the previous report (gyro or wheels). The first report only
    /// anchors the interval ([`Reject::NotReady`]).
    pub fn push_sample(
        &mut self,
        s: &FlowSample,
        optics: &FlowOptics,
        dyaw: f32,
    ) -> Result<FlowStep, Reject> {
        let r = self.sample_step(s, optics, dyaw);
        if let Err(e) = r {
            self.counts.rejected_one(e);
        }
        r
    }

    fn sample_step(
        &mut self,
        s: &FlowSample,
        optics: &FlowOptics,
        dyaw: f32,
    ) -> Result<FlowStep, Reject> {
        if !dyaw.is_finite() {
            return Err(Reject::NonFinite);
        }
        let t0 = self.clock.last();
        self.clock.accept(s.t)?.ok_or(Reject::NotReady)?;
        let t0 = t0.ok_or(Reject::NotReady)?;
        let d = optics.floor_displacement(s);
        let step = FlowStep {
            t0,
            t1: s.t,
            d_body: optics.to_body(&d, &yaw_vector(dyaw)).xy(),
            dyaw,
            confidence: flow_sample_confidence(s, &self.params.quality),
        };
        self.push_step(&step)?;
        Ok(step)
    }

    /// Adds a step made elsewhere (raw-frame flow); counted.
    pub fn push_step(&mut self, step: &FlowStep) -> Result<(), Reject> {
        let r = self.store(step);
        self.counts.record(r);
        r
    }

    fn store(&mut self, step: &FlowStep) -> Result<(), Reject> {
        let finite = step.d_body.iter().all(|v| v.is_finite())
            && step.dyaw.is_finite()
            && step.confidence.is_finite();
        if !finite {
            return Err(Reject::NonFinite);
        }
        if step.t1 <= step.t0 {
            return Err(Reject::Duplicate);
        }
        if let Some(last) = self.last_t1 {
            if step.t1 == last {
                return Err(Reject::Duplicate);
            }
            if step.t0 < last {
                return Err(Reject::OutOfOrder);
            }
        }
        if self.steps.is_full() {
            self.steps.pop_front();
        }
        let _ = self.steps.push_back(*step);
        self.last_t1 = Some(step.t1);
        Ok(())
    }

    /// Sums the path of the body point `point_b` over `[t0, t1]`: each step's
    /// body-origin displacement plus `dyaw * (z x p)`.
    pub fn summarize(&self, t0: Timestamp, t1: Timestamp, point_b: &Vec3) -> FlowSummary {
        let mut cov = Coverage::new(t0, t1);
        let mut path = 0.0f32;
        let mut chord = Chord::default();
        let mut conf = 0.0f32;
        let mut weight = 0.0f32;
        let mut samples = 0u16;
        let mut blank = 0u16;
        // Steps are in time order; those ended by `t0` add nothing.
        for st in ending_after(&self.steps, t0, |st| st.t1) {
            let f = overlap_fraction(st.t0, st.t1, t0, t1);
            if f <= 0.0 {
                continue;
            }
            cov.add(st.t0, st.t1, t0, t1);
            samples = samples.saturating_add(1);
            if st.confidence <= 0.0 {
                blank = blank.saturating_add(1);
            }
            let origin = Vec3::new(st.d_body.x, st.d_body.y, 0.0);
            let d = add_lever_arm(&origin, &yaw_vector(st.dyaw), point_b).xy();
            path += f * d.norm();
            chord.add(f * d.x, f * d.y, f * st.dyaw);
            let w = f * st.t1.seconds_since(st.t0).unwrap_or(0.0);
            conf += w * st.confidence.clamp(0.0, 1.0);
            weight += w;
        }
        let coverage = cov.fraction();
        let scale = if coverage > 0.0 { 1.0 / coverage } else { 0.0 };
        FlowSummary {
            path: path * scale,
            chord: chord.length() * scale,
            confidence: if weight > 0.0 { conf / weight } else { 0.0 },
            coverage,
            samples,
            blank,
        }
    }

    /// The transaction `To` over `[t0, t1]` for the body point `point_b`,
    /// its length measured as `distance` says.
    pub fn transaction(
        &self,
        t0: Timestamp,
        t1: Timestamp,
        point_b: &Vec3,
        distance: Distance,
    ) -> (Transaction, FlowSummary) {
        let s = self.summarize(t0, t1, point_b);
        let confidence = (s.confidence * s.coverage).clamp(0.0, 1.0);
        let metres = match distance {
            Distance::Path => s.path,
            Distance::Chord => s.chord,
        };
        let t = Transaction {
            metres,
            variance: Transaction::variance_for(
                metres,
                self.params.rel_sigma,
                self.params.floor_sigma,
                confidence,
            ),
            confidence,
            coverage: s.coverage,
        };
        (t, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Rot3;

    fn optics(mount: Extrinsics) -> FlowOptics {
        FlowOptics::new(500.0, 0.02, mount).unwrap()
    }

    fn sample(t: u64, dx: i16, dy: i16) -> FlowSample {
        FlowSample {
            t: Timestamp(t),
            dx,
            dy,
            squal: 0x80,
            shutter: 0x100,
            ..FlowSample::default()
        }
    }

    #[test]
    fn counts_become_metres_in_the_body_frame() {
        // Sensor x along body y.
        let mount = Extrinsics::new(
            Rot3::from_euler_angles(0.0, 0.0, core::f32::consts::FRAC_PI_2),
            Vec3::zeros(),
        )
        .unwrap();
        let o = optics(mount);
        let mut w: FlowStepWindow<8> = FlowStepWindow::new(FlowParams::default());
        assert_eq!(
            w.push_sample(&sample(0, 0, 0), &o, 0.0),
            Err(Reject::NotReady)
        );
        let st = w.push_sample(&sample(10_000_000, 250, 0), &o, 0.0).unwrap();
        // 250 counts / 500 per rad * 0.02 m = 0.01 m along body +y.
        assert!((st.d_body - Vec2::new(0.0, 0.01)).norm() < 1e-6);
    }

    #[test]
    fn lever_arm_of_yaw_is_removed() {
        // Sensor 0.1 m ahead of the body origin; the robot turns in place by
        // 0.05 rad: the sensor moves 0.005 m to the left, the body not at all.
        let mount = Extrinsics::new(Rot3::identity(), Vec3::new(0.1, 0.0, 0.0)).unwrap();
        let o = optics(mount);
        let d = sensor_to_body(Vec2::new(0.0, 0.005), o.mount(), 0.05);
        assert!(d.norm() < 1e-6);
        // The same step, summed for a point 0.1 m ahead, is the sensor's motion again.
        let mut w: FlowStepWindow<8> = FlowStepWindow::new(FlowParams::default());
        w.push_sample(&sample(0, 0, 0), &o, 0.0).unwrap_err();
        w.push_sample(&sample(10, 0, 125), &o, 0.05).unwrap();
        let s = w.summarize(Timestamp(0), Timestamp(10), &Vec3::new(0.1, 0.0, 0.0));
        assert!((s.path - 0.005).abs() < 1e-6);
        let s0 = w.summarize(Timestamp(0), Timestamp(10), &Vec3::zeros());
        assert!(s0.path < 1e-6);
    }

    #[test]
    fn low_quality_lowers_confidence_not_the_sample() {
        let o = optics(Extrinsics::identity());
        let mut w: FlowStepWindow<8> = FlowStepWindow::new(FlowParams::default());
        let _ = w.push_sample(&sample(0, 0, 0), &o, 0.0);
        w.push_sample(&sample(100, 100, 0), &o, 0.0).unwrap();
        let dark = FlowSample {
            squal: 0x10,
            shutter: 0x1F40,
            ..sample(200, 100, 0)
        };
        w.push_sample(&dark, &o, 0.0).unwrap();
        let (t, s) = w.transaction(Timestamp(0), Timestamp(200), &Vec3::zeros(), Distance::Path);
        assert_eq!(s.blank, 1);
        assert!((t.confidence - 0.5).abs() < 1e-6);
        assert!((t.metres - 0.008).abs() < 1e-6);
        assert_eq!(w.counts().fused(), 2);
        assert_eq!(w.counts().rejected(Reject::NotReady), 1);
    }
}
