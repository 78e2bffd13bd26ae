//! Scale selection: the seed's five methods, each selectable, plus wheel-only
//! and flow-only baselines for comparison.
//!
//! A source's scale is `s_x = T_x / |T|` (metres per unit of `t/d`: the
//! ceiling distance). Its variance propagates the source's and the camera's:
//! `var(s) = var(T_x) / |T|^2 + s^2 * cam_rel_sigma^2 / c_cam`.
//!
//! 1. [`SelectionMethod::SlipThreshold`]: flow when slip exceeds the threshold, wheel otherwise.
//! 2. [`SelectionMethod::Outlier`]: flow when the wheel data are erroneous or an outlier.
//! 3. [`SelectionMethod::SourceConfidence`]: the source with the higher
//!    confidence; equal confidences pick the flow sensor.
//! 4. [`SelectionMethod::ScaleConfidence`]: each scale value gets a confidence
//!    (source, camera, agreement with the running scale); the better wins,
//!    the flow sensor's on a tie.
//! 5. [`SelectionMethod::Fusion`] (default): inverse-variance combination of the
//!    sources that pass the slip and outlier gates.
//!
//! No scale is produced for a too-small baseline (pure rotation) or when no
//! source is usable; the caller gets a [`NoScale`] reason.

use core::fmt;

use super::robust::RobustEstimate;
use super::slip::SlipReport;
use super::transactions::Transaction;

/// The scale selection policy.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SelectionMethod {
    /// 1. Flow when slip exceeds the threshold, wheel otherwise.
    SlipThreshold,
    /// 2. Flow when the wheel data are erroneous or an outlier.
    Outlier,
    /// 3. The source with the higher confidence (equal: the flow sensor).
    SourceConfidence,
    /// 4. The scale value with the higher confidence (equal: the flow sensor).
    ScaleConfidence,
    /// 5. Inverse-variance fusion with slip and outlier gating.
    #[default]
    Fusion,
    /// Baseline: the wheels only, whatever happens.
    WheelOnly,
    /// Baseline: the flow sensor only.
    FlowOnly,
}

/// Where a scale came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScaleSource {
    /// Wheel odometry `Tw`.
    Wheel,
    /// Optical flow `To`.
    Flow,
    /// Inverse-variance combination of both.
    Fused,
}

/// A scale with its variance and source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaleEstimate {
    /// Metres per unit of `t/d` (positive, finite).
    pub scale: f32,
    /// Variance of `scale`.
    pub variance: f32,
    /// Where it came from.
    pub source: ScaleSource,
}

/// Why a frame got no scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoScale {
    /// `|T|` below the minimum baseline: pure rotation, the scale is unobservable.
    BaselineTooSmall,
    /// The camera's confidence is zero (too few inliers).
    CameraUnreliable,
    /// The method's source(s) gave nothing usable (no data, zero confidence, zero path).
    NoUsableSource,
    /// The chosen value was not positive and finite.
    Degenerate,
}

impl fmt::Display for NoScale {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NoScale::BaselineTooSmall => "camera baseline too small (pure rotation)",
            NoScale::CameraUnreliable => "camera motion unreliable",
            NoScale::NoUsableSource => "no usable metric source",
            NoScale::Degenerate => "scale not positive and finite",
        })
    }
}

impl core::error::Error for NoScale {}

/// Settings of the selection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectParams {
    /// `|T|` below this gives [`NoScale::BaselineTooSmall`].
    pub min_baseline: f32,
    /// Relative sigma of `|T|` at full camera confidence.
    pub camera_rel_sigma: f32,
    /// Source confidence below which a source is unusable.
    pub min_source_confidence: f32,
    /// Transactions shorter than this (metres) give no scale value.
    pub min_path: f32,
    /// Sigmas from the running scale at which the agreement factor is one half.
    pub agreement_sigmas: f32,
}

impl Default for SelectParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SelectParams {
    /// The defaults ([`Default::default`]) as a constant, for `const` construction.
    pub const DEFAULT: Self = SelectParams {
        min_baseline: 0.004,
        camera_rel_sigma: 0.02,
        min_source_confidence: 0.05,
        min_path: 0.001,
        agreement_sigmas: 3.0,
    };
}

/// What the selection sees for one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectionInput {
    /// Camera baseline `|T|`.
    pub baseline: f32,
    /// Camera confidence, `0..=1`.
    pub camera_confidence: f32,
    /// Wheel transaction `Tw`.
    pub wheel: Transaction,
    /// Flow transaction `To`.
    pub flow: Transaction,
    /// Slip verdict.
    pub slip: SlipReport,
    /// The wheel data are erroneous or their scale is an outlier.
    pub wheel_outlier: bool,
    /// The running scale before this frame.
    pub robust: Option<RobustEstimate>,
}

/// One source's scale value and its confidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaleCandidate {
    /// `T_x / |T|`.
    pub scale: f32,
    /// Its variance.
    pub variance: f32,
    /// Source confidence times camera confidence times agreement, `0..=1`.
    pub confidence: f32,
}

fn positive_finite(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

/// A source's scale value, if the transaction is usable.
pub fn candidate(
    t: &Transaction,
    input: &SelectionInput,
    p: &SelectParams,
) -> Option<ScaleCandidate> {
    if !t.is_usable(p.min_source_confidence) || t.metres < p.min_path {
        return None;
    }
    let b = input.baseline;
    let scale = t.metres / b;
    let cam = input.camera_confidence.clamp(1e-3, 1.0);
    let variance =
        t.variance / (b * b) + scale * scale * p.camera_rel_sigma * p.camera_rel_sigma / cam;
    let agreement = match input.robust {
        Some(r) => {
            let x = r.z(scale) / p.agreement_sigmas.max(1e-3);
            1.0 / (1.0 + x * x)
        }
        None => 1.0,
    };
    let confidence = (t.confidence * input.camera_confidence * agreement).clamp(0.0, 1.0);
    (positive_finite(scale) && positive_finite(variance)).then_some(ScaleCandidate {
        scale,
        variance,
        confidence,
    })
}

fn estimate(c: Option<ScaleCandidate>, source: ScaleSource) -> Result<ScaleEstimate, NoScale> {
    let c = c.ok_or(NoScale::NoUsableSource)?;
    Ok(ScaleEstimate {
        scale: c.scale,
        variance: c.variance,
        source,
    })
}

fn prefer_wheel_unless(
    use_flow: bool,
    w: Option<ScaleCandidate>,
    o: Option<ScaleCandidate>,
) -> Result<ScaleEstimate, NoScale> {
    if use_flow {
        estimate(o, ScaleSource::Flow)
    } else if w.is_some() {
        estimate(w, ScaleSource::Wheel)
    } else {
        estimate(o, ScaleSource::Flow)
    }
}

/// Inverse-variance combination of the candidates present.
pub fn fuse(
    w: Option<ScaleCandidate>,
    o: Option<ScaleCandidate>,
) -> Result<ScaleEstimate, NoScale> {
    match (w, o) {
        (Some(w), Some(o)) => {
            let (iw, io) = (1.0 / w.variance, 1.0 / o.variance);
            let info = iw + io;
            Ok(ScaleEstimate {
                scale: (w.scale * iw + o.scale * io) / info,
                variance: 1.0 / info,
                source: ScaleSource::Fused,
            })
        }
        (Some(_), None) => estimate(w, ScaleSource::Wheel),
        (None, Some(_)) => estimate(o, ScaleSource::Flow),
        (None, None) => Err(NoScale::NoUsableSource),
    }
}

/// Selects this frame's scale by `method`.
pub fn select(
    method: SelectionMethod,
    input: &SelectionInput,
    p: &SelectParams,
) -> Result<ScaleEstimate, NoScale> {
    if !(input.baseline.is_finite() && input.baseline >= p.min_baseline) {
        return Err(NoScale::BaselineTooSmall);
    }
    if !(input.camera_confidence.is_finite() && input.camera_confidence > 0.0) {
        return Err(NoScale::CameraUnreliable);
    }
    let w = candidate(&input.wheel, input, p);
    let o = candidate(&input.flow, input, p);
    let chosen = match method {
        SelectionMethod::SlipThreshold => prefer_wheel_unless(input.slip.exceeded, w, o),
        SelectionMethod::Outlier => prefer_wheel_unless(input.wheel_outlier, w, o),
        SelectionMethod::SourceConfidence => {
            // Equal confidences pick the flow sensor.
            let flow_at_least = input.flow.confidence >= input.wheel.confidence;
            prefer_wheel_unless(flow_at_least && o.is_some(), w, o)
        }
        SelectionMethod::ScaleConfidence => match (w, o) {
            (Some(a), Some(b)) if b.confidence >= a.confidence => estimate(o, ScaleSource::Flow),
            _ => prefer_wheel_unless(false, w, o),
        },
        SelectionMethod::Fusion => {
            let gated = input.slip.exceeded || input.wheel_outlier;
            fuse(if gated { None } else { w }, o)
        }
        SelectionMethod::WheelOnly => estimate(w, ScaleSource::Wheel),
        SelectionMethod::FlowOnly => estimate(o, ScaleSource::Flow),
    }?;
    if positive_finite(chosen.scale) && positive_finite(chosen.variance) {
        Ok(chosen)
    } else {
        Err(NoScale::Degenerate)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tx(metres: f32, confidence: f32) -> Transaction {
        Transaction {
            metres,
            variance: Transaction::variance_for(metres, 0.02, 0.0005, confidence),
            confidence,
            coverage: 1.0,
        }
    }

    /// Wheels and flow with the same confidence; the wheels report 2 % more.
    fn tie(confidence: f32) -> SelectionInput {
        SelectionInput {
            baseline: 0.012,
            camera_confidence: 0.9,
            wheel: tx(0.0306, confidence),
            flow: tx(0.03, confidence),
            slip: SlipReport::NONE,
            wheel_outlier: false,
            robust: None,
        }
    }

    #[test]
    fn equal_confidences_pick_the_flow_sensor() {
        let p = SelectParams::default();
        for c in [0.3, 0.8, 1.0] {
            for method in [
                SelectionMethod::SourceConfidence,
                SelectionMethod::ScaleConfidence,
            ] {
                let e = select(method, &tie(c), &p).unwrap();
                assert_eq!(e.source, ScaleSource::Flow, "{method:?} at {c}");
                assert!((e.scale - 2.5).abs() < 1e-4, "{method:?}: {}", e.scale);
            }
        }
    }

    #[test]
    fn a_more_confident_wheel_still_wins() {
        let p = SelectParams::default();
        let mut input = tie(0.8);
        input.wheel.confidence = 0.9;
        for method in [
            SelectionMethod::SourceConfidence,
            SelectionMethod::ScaleConfidence,
        ] {
            assert_eq!(
                select(method, &input, &p).unwrap().source,
                ScaleSource::Wheel
            );
        }
    }
}
