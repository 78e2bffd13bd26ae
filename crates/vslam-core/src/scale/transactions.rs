//! Transactions: the displacement each source reports between two camera
//! frames, and the wheel transaction `Tw`.
//!
//! `Tw = K * sum_i |(dx_i, dy_i, dz_i)|` over the odometry deltas inside the
//! frame interval; a delta straddling a frame time stamp is split in
//! proportion to time ([`super::interval`]). `K` is the odometry calibration
//! factor (seed: "the path length of the robot between the two frames").
//!
//! Beside the path, each summary has the chord: the straight displacement of
//! the point from the interval's start to its end, the steps rotated into the
//! start's body frame by the heading accumulated so far ([`Chord`]). The
//! camera's `|T|` is a chord; [`Distance`] says which of the two a pipeline
//! compares with it.
//!
//! The summed point is selectable: the body origin (the robot's path, the
//! default) or another body point such as the camera's optical centre. The
//! camera measures the motion of its own centre, which differs from the body
//! origin's by `dyaw x r` when the robot turns; summing the camera point's
//! path keeps `s = Tw / |T|` equal to the ceiling distance during turns.

use heapless::Deque;

use super::interval::{Coverage, overlap_fraction};
use crate::geometry::Vec3;
use crate::kinematics::planar_point_step;
use crate::reject::{Reject, SampleCounts};
use crate::sensors::OdometryDelta;
use crate::time::Timestamp;

/// What one source reports over one frame interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transaction {
    /// Path length over the interval, metres (uncovered time extrapolated).
    pub metres: f32,
    /// Variance of `metres`, m^2.
    pub variance: f32,
    /// How far to trust the source over this interval, `0..=1`.
    pub confidence: f32,
    /// Fraction of the interval the source's samples covered, `0..=1`.
    pub coverage: f32,
}

impl Transaction {
    /// A source that reported nothing over the interval.
    pub const NONE: Transaction = Transaction {
        metres: 0.0,
        variance: f32::INFINITY,
        confidence: 0.0,
        coverage: 0.0,
    };

    /// Whether the transaction carries information (finite, some coverage and
    /// confidence, finite variance).
    pub fn is_usable(&self, min_confidence: f32) -> bool {
        self.metres.is_finite()
            && self.metres >= 0.0
            && self.variance.is_finite()
            && self.variance > 0.0
            && self.coverage > 0.0
            && self.confidence >= min_confidence
            && self.confidence > 0.0
    }

    /// The variance a path of `metres` gets from a relative and a floor sigma,
    /// inflated by `1 / confidence` (`confidence` clamped to `1e-3..=1`).
    pub fn variance_for(metres: f32, rel_sigma: f32, floor_sigma: f32, confidence: f32) -> f32 {
        let sd = rel_sigma * metres;
        let v = sd * sd + floor_sigma * floor_sigma;
        v / confidence.clamp(1e-3, 1.0)
    }
}

/// Which length of a source's motion over a frame interval is compared with
/// the camera's `|T|`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Distance {
    /// The path length: the sum of the steps' lengths (the seed's wording).
    Path,
    /// The chord: the length of the summed displacement, start to end;
    /// default: it is what `|T|` measures (README, "Scale: path or chord").
    #[default]
    Chord,
}

/// Sums planar steps given in the body frame at each step's start into the
/// displacement in the body frame at the first step's start.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Chord {
    x: f32,
    y: f32,
    heading: f32,
}

impl Chord {
    /// Adds a step `(dx, dy)` followed by a heading change `dyaw`.
    pub fn add(&mut self, dx: f32, dy: f32, dyaw: f32) {
        let (s, c) = libm::sincosf(self.heading);
        self.x += c * dx - s * dy;
        self.y += s * dx + c * dy;
        self.heading += dyaw;
    }

    /// The displacement's length.
    pub fn length(&self) -> f32 {
        libm::hypotf(self.x, self.y)
    }
}

/// Wheel odometry settings for the transaction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelParams {
    /// Calibration factor `K` applied to the summed path.
    pub k: f32,
    /// Relative standard deviation of the path, no slip.
    pub rel_sigma: f32,
    /// Standard deviation floor, metres.
    pub floor_sigma: f32,
    /// Speeds above this (m/s) are glitches: rejected and counted as discontinuities.
    pub max_speed: f32,
}

impl Default for WheelParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl WheelParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = WheelParams {
        k: 1.0,
        rel_sigma: 0.02,
        floor_sigma: 0.0005,
        max_speed: 3.0,
    };
}

/// The wheel odometry over one interval, before confidences.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelSummary {
    /// `Tw`: path of the chosen point, metres, `K` applied, uncovered time extrapolated.
    pub path: f32,
    /// Chord of the chosen point, metres, `K` applied, uncovered time extrapolated.
    pub chord: f32,
    /// Heading change the wheels report, radians.
    pub yaw: f32,
    /// Fraction of the interval covered by samples.
    pub coverage: f32,
    /// Gaps between samples and rejected glitches inside the interval.
    pub discontinuities: u16,
    /// Forward acceleration from the first to the last overlapping sample, m/s^2.
    pub accel: Option<f32>,
    /// Number of samples that overlapped the interval.
    pub samples: u16,
}

/// A window of recent odometry deltas, queried per camera interval.
///
/// Deltas must arrive in time order without overlap; a full window drops its
/// oldest delta. Capacity `N` must cover the longest camera interval plus the
/// camera latency.
#[derive(Clone, Debug)]
pub struct WheelWindow<const N: usize> {
    params: WheelParams,
    deltas: Deque<OdometryDelta, N>,
    glitches: Deque<Timestamp, 8>,
    last_t1: Option<Timestamp>,
    counts: SampleCounts,
}

impl<const N: usize> WheelWindow<N> {
    /// An empty window.
    pub const fn new(params: WheelParams) -> Self {
        WheelWindow {
            params,
            deltas: Deque::new(),
            glitches: Deque::new(),
            last_t1: None,
            counts: SampleCounts::new(),
        }
    }

    /// Empties the window in place and takes `params`, as [`WheelWindow::new`].
    pub fn reset(&mut self, params: WheelParams) {
        self.params = params;
        self.deltas.clear();
        self.glitches.clear();
        self.last_t1 = None;
        self.counts = SampleCounts::new();
    }

    /// The settings.
    pub fn params(&self) -> &WheelParams {
        &self.params
    }

    /// Fused and rejected deltas by reason.
    pub fn counts(&self) -> &SampleCounts {
        &self.counts
    }

    /// Adds one delta; the outcome is also counted.
    pub fn push(&mut self, d: &OdometryDelta) -> Result<(), Reject> {
        let r = self.check_and_store(d);
        self.counts.record(r);
        r
    }

    fn check_and_store(&mut self, d: &OdometryDelta) -> Result<(), Reject> {
        let finite = d.translation.iter().all(|v| v.is_finite())
            && d.dyaw.is_finite()
            && d.path_length.is_finite();
        if !finite {
            return Err(Reject::NonFinite);
        }
        let Some(dt) = d.t1.seconds_since(d.t0) else {
            return Err(Reject::OutOfOrder);
        };
        if dt <= 0.0 {
            return Err(Reject::Duplicate);
        }
        if let Some(last) = self.last_t1 {
            if d.t1 == last {
                return Err(Reject::Duplicate);
            }
            if d.t0 < last {
                return Err(Reject::OutOfOrder);
            }
        }
        if d.translation.norm() / dt > self.params.max_speed {
            if self.glitches.is_full() {
                self.glitches.pop_front();
            }
            // Cannot fail: a slot was freed above.
            let _ = self.glitches.push_back(d.t1);
            return Err(Reject::OutOfRange);
        }
        if self.deltas.is_full() {
            self.deltas.pop_front();
        }
        let _ = self.deltas.push_back(*d);
        self.last_t1 = Some(d.t1);
        Ok(())
    }

    /// Time of the newest stored delta's end.
    pub fn newest(&self) -> Option<Timestamp> {
        self.last_t1
    }

    /// Sums the path of the body point `point_b` over `[t0, t1]`.
    pub fn summarize(&self, t0: Timestamp, t1: Timestamp, point_b: &Vec3) -> WheelSummary {
        let mut cov = Coverage::new(t0, t1);
        let mut path = 0.0f32;
        let mut chord = Chord::default();
        let mut yaw = 0.0f32;
        let mut samples = 0u16;
        let mut discontinuities = 0u16;
        let mut prev_end: Option<Timestamp> = None;
        let mut first: Option<(f32, Timestamp)> = None;
        let mut last: Option<(f32, Timestamp)> = None;
        for d in self.deltas.iter() {
            let f = overlap_fraction(d.t0, d.t1, t0, t1);
            if f <= 0.0 {
                prev_end = Some(d.t1);
                continue;
            }
            if let Some(pe) = prev_end
                && d.t0 != pe
                && d.t0 > t0
            {
                discontinuities = discontinuities.saturating_add(1);
            }
            prev_end = Some(d.t1);
            cov.add(d.t0, d.t1, t0, t1);
            samples = samples.saturating_add(1);
            let step = f * point_step(d, point_b);
            path += step.norm();
            chord.add(step.x, step.y, f * d.dyaw);
            yaw += f * d.dyaw;
            let dt = d.t1.seconds_since(d.t0).unwrap_or(0.0);
            if dt > 0.0 {
                let v = d.translation.x / dt;
                let mid = Timestamp(d.t0.0 / 2 + d.t1.0 / 2);
                if first.is_none() {
                    first = Some((v, mid));
                }
                last = Some((v, mid));
            }
        }
        discontinuities = discontinuities.saturating_add(
            self.glitches
                .iter()
                .filter(|g| **g > t0 && **g <= t1)
                .count() as u16,
        );
        let coverage = cov.fraction();
        let accel = match (first, last) {
            (Some((v0, m0)), Some((v1, m1))) => m1
                .seconds_since(m0)
                .filter(|dt| *dt > 0.0)
                .map(|dt| (v1 - v0) / dt),
            _ => None,
        };
        let scale = if coverage > 0.0 { 1.0 / coverage } else { 0.0 };
        WheelSummary {
            path: path * scale * self.params.k,
            chord: chord.length() * scale * self.params.k,
            yaw: yaw * scale,
            coverage,
            discontinuities,
            accel,
            samples,
        }
    }
}

/// The displacement of the body point `p` over one odometry delta, in the
/// body frame at the delta's start: `t + (Rz(dyaw) - I) p`
/// ([`planar_point_step`]).
pub fn point_step(d: &OdometryDelta, p: &Vec3) -> Vec3 {
    planar_point_step(&d.translation, d.dyaw, p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn delta(t0: u64, t1: u64, dx: f32, dyaw: f32) -> OdometryDelta {
        OdometryDelta {
            t0: Timestamp(t0 * 1_000_000),
            t1: Timestamp(t1 * 1_000_000),
            translation: Vec3::new(dx, 0.0, 0.0),
            dyaw,
            path_length: dx,
        }
    }

    #[test]
    fn straddling_deltas_are_split_and_k_applied() {
        let mut w: WheelWindow<8> = WheelWindow::new(WheelParams {
            k: 2.0,
            ..WheelParams::default()
        });
        for i in 0..4u64 {
            w.push(&delta(i * 100, (i + 1) * 100, 0.01, 0.0)).unwrap();
        }
        // [50, 250]: half of the first, the second fully, half of the third.
        let s = w.summarize(
            Timestamp(50_000_000),
            Timestamp(250_000_000),
            &Vec3::zeros(),
        );
        assert!((s.path - 2.0 * 0.02).abs() < 1e-6, "{}", s.path);
        assert_eq!(s.coverage, 1.0);
        assert_eq!(s.samples, 3);
        assert_eq!(s.discontinuities, 0);
    }

    #[test]
    fn rejects_with_reasons_and_counts_gaps() {
        let mut w: WheelWindow<8> = WheelWindow::new(WheelParams::default());
        assert_eq!(
            w.push(&delta(0, 100, f32::NAN, 0.0)),
            Err(Reject::NonFinite)
        );
        w.push(&delta(0, 100, 0.0, 0.0)).unwrap();
        assert_eq!(w.push(&delta(50, 150, 0.0, 0.0)), Err(Reject::OutOfOrder));
        assert_eq!(w.push(&delta(0, 100, 0.0, 0.0)), Err(Reject::Duplicate));
        // 1 m in 0.1 s is a glitch.
        assert_eq!(w.push(&delta(100, 200, 1.0, 0.0)), Err(Reject::OutOfRange));
        w.push(&delta(300, 400, 0.0, 0.0)).unwrap();
        let s = w.summarize(Timestamp(0), Timestamp(400_000_000), &Vec3::zeros());
        assert_eq!(s.discontinuities, 2, "one gap and one glitch");
        assert_eq!(s.coverage, 0.5);
        assert_eq!(w.counts().fused(), 2);
        assert_eq!(w.counts().rejected_total(), 4);
    }

    #[test]
    fn turning_in_place_moves_an_offset_point() {
        let mut w: WheelWindow<8> = WheelWindow::new(WheelParams::default());
        w.push(&delta(0, 1_000, 0.0, 0.5)).unwrap();
        let origin = w.summarize(Timestamp(0), Timestamp(1_000_000_000), &Vec3::zeros());
        assert_eq!(origin.path, 0.0);
        let cam = w.summarize(
            Timestamp(0),
            Timestamp(1_000_000_000),
            &Vec3::new(0.1, 0.0, 0.3),
        );
        let chord = 2.0 * 0.1 * libm::sinf(0.25);
        assert!((cam.path - chord).abs() < 1e-6);
        assert!((cam.yaw - 0.5).abs() < 1e-6);
    }

    /// An arc of radius 0.5 m turning 0.6 rad in 20 odometry deltas (the
    /// robot's origin; a frame interval while turning hard): the chord is
    /// what the camera's `|T|` measures, `2 R sin(theta / 2)`; the path is
    /// `R theta`, 1.5 % longer.
    #[test]
    fn on_an_arc_the_chord_is_the_straight_displacement() {
        let (r, theta, n) = (0.5f32, 0.6f32, 20u64);
        let step_yaw = theta / n as f32;
        let step_len = 2.0 * r * libm::sinf(step_yaw / 2.0);
        let mut w: WheelWindow<32> = WheelWindow::new(WheelParams::default());
        for i in 0..n {
            // Each delta's translation in the body frame at its start.
            let (sn, c) = libm::sincosf(step_yaw / 2.0);
            w.push(&OdometryDelta {
                t0: Timestamp(i * 10_000_000),
                t1: Timestamp((i + 1) * 10_000_000),
                translation: Vec3::new(c * step_len, sn * step_len, 0.0),
                dyaw: step_yaw,
                path_length: step_len,
            })
            .unwrap();
        }
        let s = w.summarize(Timestamp(0), Timestamp(n * 10_000_000), &Vec3::zeros());
        let chord = 2.0 * r * libm::sinf(theta / 2.0);
        assert!((s.chord - chord).abs() < 1e-5, "{} vs {chord}", s.chord);
        assert!((s.path - r * theta).abs() < 1e-4, "{}", s.path);
        assert!(s.path / s.chord > 1.014);
    }

    #[test]
    fn a_chord_of_a_straight_line_is_its_path() {
        let mut c = Chord::default();
        for _ in 0..5 {
            c.add(0.01, 0.0, 0.0);
        }
        assert!((c.length() - 0.05).abs() < 1e-7);
        // Out and back: path 0.1 m, chord zero.
        c.add(0.0, 0.0, core::f32::consts::PI);
        for _ in 0..5 {
            c.add(0.01, 0.0, 0.0);
        }
        assert!(c.length() < 1e-6, "{}", c.length());
    }
}
