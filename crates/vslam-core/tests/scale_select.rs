//! Unit tests of each scale selection method, including the switch to flow
//! during a slip episode and back to the wheels after it.

use vslam_core::scale::confidence::wheel_confidence;
use vslam_core::scale::robust::{RobustParams, RobustScale};
use vslam_core::scale::select::{
    ScaleSource, SelectParams, SelectionInput, SelectionMethod, candidate, fuse, select,
};
use vslam_core::scale::slip::{SlipEvidence, SlipParams, SlipReport, assess};
use vslam_core::scale::{NoScale, Transaction};

const D: f32 = 2.5;
const BASELINE: f32 = 0.012; // 3 cm at 2.5 m

fn tx(metres: f32, confidence: f32) -> Transaction {
    Transaction {
        metres,
        variance: Transaction::variance_for(metres, 0.02, 0.0005, confidence),
        confidence,
        coverage: 1.0,
    }
}

/// One frame where the robot truly moved `BASELINE * D`; the wheels report
/// `wheel_factor` times that, the flow the truth with confidence `flow_conf`.
fn frame(wheel_factor: f32, flow_conf: f32, running: Option<&RobustScale<9>>) -> SelectionInput {
    let truth = BASELINE * D;
    let wheel_path = truth * wheel_factor;
    let slip_params = SlipParams::default();
    let slip = assess(
        &SlipEvidence {
            dt: 0.1,
            wheel_path,
            flow_path: truth,
            flow_confidence: flow_conf,
            camera_baseline: BASELINE,
            scale: running.and_then(|r| r.estimate()).map(|e| e.scale),
            ..SlipEvidence::default()
        },
        &slip_params,
    );
    let wc = wheel_confidence(slip.amount, slip_params.threshold, 1.0, 0);
    let robust = running.and_then(|r| r.estimate());
    let wheel_outlier = robust.is_some_and(|e| e.z(wheel_path / BASELINE) > 4.0);
    SelectionInput {
        baseline: BASELINE,
        camera_confidence: 0.9,
        wheel: tx(wheel_path, wc),
        flow: tx(truth, flow_conf),
        slip,
        wheel_outlier,
        robust,
    }
}

fn sources_over_episode(method: SelectionMethod) -> Vec<ScaleSource> {
    let mut running: RobustScale<9> = RobustScale::new(RobustParams::default());
    let mut out = Vec::new();
    // 8 calm frames, 6 slipping (wheels +40 %), 8 calm again.
    let factors = [1.0f32; 8]
        .iter()
        .chain([1.4f32; 6].iter())
        .chain([1.0f32; 8].iter())
        .copied()
        .collect::<Vec<_>>();
    for f in factors {
        let input = frame(f, 0.8, Some(&running));
        let e = select(method, &input, &SelectParams::default()).unwrap();
        assert!((e.scale - D).abs() < 0.02 * D || e.source == ScaleSource::Wheel);
        running.push(e.scale);
        out.push(e.source);
    }
    out
}

#[test]
fn slip_threshold_switches_to_flow_during_slip_and_back() {
    let s = sources_over_episode(SelectionMethod::SlipThreshold);
    assert!(s[..8].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
    assert!(s[8..14].iter().all(|x| *x == ScaleSource::Flow), "{s:?}");
    assert!(s[14..].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
}

#[test]
fn outlier_method_switches_when_the_wheel_scale_is_an_outlier_and_back() {
    let s = sources_over_episode(SelectionMethod::Outlier);
    assert!(s[..8].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
    assert!(s[8..14].iter().all(|x| *x == ScaleSource::Flow), "{s:?}");
    assert!(s[14..].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
}

#[test]
fn outlier_method_uses_flow_for_erroneous_wheel_data() {
    let mut input = frame(1.0, 0.8, None);
    input.wheel_outlier = true;
    let e = select(SelectionMethod::Outlier, &input, &SelectParams::default()).unwrap();
    assert_eq!(e.source, ScaleSource::Flow);
    input.wheel_outlier = false;
    let e = select(SelectionMethod::Outlier, &input, &SelectParams::default()).unwrap();
    assert_eq!(e.source, ScaleSource::Wheel);
    // Unusable wheel data (no coverage) also falls back to the flow.
    input.wheel = Transaction::NONE;
    let e = select(SelectionMethod::Outlier, &input, &SelectParams::default()).unwrap();
    assert_eq!(e.source, ScaleSource::Flow);
}

#[test]
fn source_confidence_picks_the_more_confident_source_and_switches_back() {
    let s = sources_over_episode(SelectionMethod::SourceConfidence);
    assert!(s[..8].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
    assert!(s[8..14].iter().all(|x| *x == ScaleSource::Flow), "{s:?}");
    assert!(s[14..].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
    // A dim floor makes the wheels win even with a little slip.
    let input = frame(1.1, 0.2, None);
    let e = select(
        SelectionMethod::SourceConfidence,
        &input,
        &SelectParams::default(),
    )
    .unwrap();
    assert_eq!(e.source, ScaleSource::Wheel);
}

#[test]
fn scale_confidence_prefers_the_value_that_agrees_and_switches_back() {
    let s = sources_over_episode(SelectionMethod::ScaleConfidence);
    assert!(s[..8].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
    assert!(s[8..14].iter().all(|x| *x == ScaleSource::Flow), "{s:?}");
    assert!(s[14..].iter().all(|x| *x == ScaleSource::Wheel), "{s:?}");
    // The scale values' confidences include the agreement with the running scale.
    let mut running: RobustScale<9> = RobustScale::new(RobustParams::default());
    for _ in 0..9 {
        running.push(D);
    }
    let input = frame(1.4, 0.8, Some(&running));
    let p = SelectParams::default();
    let w = candidate(&input.wheel, &input, &p).unwrap();
    let o = candidate(&input.flow, &input, &p).unwrap();
    assert!((w.scale - 1.4 * D).abs() < 1e-4 && (o.scale - D).abs() < 1e-4);
    assert!(o.confidence > 4.0 * w.confidence, "{o:?} {w:?}");
}

#[test]
fn fusion_is_inverse_variance_and_gates_slip() {
    let p = SelectParams::default();
    // Calm: both contribute, the result lies between them, variance below each.
    let mut input = frame(1.0, 0.8, None);
    input.wheel.metres *= 1.01;
    let w = candidate(&input.wheel, &input, &p).unwrap();
    let o = candidate(&input.flow, &input, &p).unwrap();
    let e = select(SelectionMethod::Fusion, &input, &p).unwrap();
    assert_eq!(e.source, ScaleSource::Fused);
    let expect =
        (w.scale / w.variance + o.scale / o.variance) / (1.0 / w.variance + 1.0 / o.variance);
    assert!((e.scale - expect).abs() < 1e-5);
    assert!(e.variance < w.variance.min(o.variance));
    assert_eq!(fuse(Some(w), Some(o)).unwrap(), e);
    // Slip gates the wheels out.
    let s = sources_over_episode(SelectionMethod::Fusion);
    assert!(s[..8].iter().all(|x| *x == ScaleSource::Fused), "{s:?}");
    assert!(s[8..14].iter().all(|x| *x == ScaleSource::Flow), "{s:?}");
    assert!(s[14..].iter().all(|x| *x == ScaleSource::Fused), "{s:?}");
    // An outlier flag gates them out too.
    input.wheel_outlier = true;
    assert_eq!(
        select(SelectionMethod::Fusion, &input, &p).unwrap().source,
        ScaleSource::Flow
    );
}

#[test]
fn no_scale_reasons_are_typed() {
    let p = SelectParams::default();
    let mut input = frame(1.0, 0.8, None);
    input.baseline = 0.001;
    assert_eq!(
        select(SelectionMethod::Fusion, &input, &p),
        Err(NoScale::BaselineTooSmall)
    );
    input.baseline = f32::NAN;
    assert_eq!(
        select(SelectionMethod::Fusion, &input, &p),
        Err(NoScale::BaselineTooSmall)
    );
    let mut input = frame(1.0, 0.8, None);
    input.camera_confidence = 0.0;
    assert_eq!(
        select(SelectionMethod::Fusion, &input, &p),
        Err(NoScale::CameraUnreliable)
    );
    let mut input = frame(1.0, 0.8, None);
    input.wheel = Transaction::NONE;
    input.flow = Transaction::NONE;
    for m in [
        SelectionMethod::SlipThreshold,
        SelectionMethod::Outlier,
        SelectionMethod::SourceConfidence,
        SelectionMethod::ScaleConfidence,
        SelectionMethod::Fusion,
        SelectionMethod::WheelOnly,
        SelectionMethod::FlowOnly,
    ] {
        assert_eq!(select(m, &input, &p), Err(NoScale::NoUsableSource), "{m:?}");
    }
    // Slip with a blank floor: method 1 has nothing to switch to.
    let mut input = frame(1.4, 0.8, None);
    input.flow = Transaction::NONE;
    assert!(input.slip.exceeded);
    assert_eq!(
        select(SelectionMethod::SlipThreshold, &input, &p),
        Err(NoScale::NoUsableSource)
    );
    let _ = SlipReport::NONE;
}
