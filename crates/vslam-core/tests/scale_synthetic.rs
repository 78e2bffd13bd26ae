//! The synthetic sequence: a robot under a planar ceiling with wheel slip
//! episodes. The fused trajectory's final position error stays under 2 % of
//! the path length while wheel-only exceeds 10 %.

mod scale_sim;

use scale_sim::{Event, Scenario, scenario};
use vslam_core::adverse::SensorKind;
use vslam_core::scale::select::ScaleSource;
use vslam_core::scale::{NoScale, PipelineConfig, ScalePipeline, SelectionMethod};

struct Run {
    error: f64,
    relative: f64,
    frames: usize,
    no_scale_baseline: usize,
    flow_chosen_on_carpet: usize,
    carpet_frames: usize,
    slip_flagged_on_carpet: usize,
    slip_flagged_off_carpet: usize,
    mean_running_scale: f64,
    dark_frames: usize,
    wheel_chosen_in_dark: usize,
}

fn run(sc: &Scenario, method: SelectionMethod) -> Run {
    let config = PipelineConfig {
        method,
        camera: sc.camera,
        flow_optics: Some(sc.flow_optics),
        ..PipelineConfig::default()
    };
    let mut p: ScalePipeline<16> = ScalePipeline::new(config).unwrap();
    let mut out = Run {
        error: 0.0,
        relative: 0.0,
        frames: 0,
        no_scale_baseline: 0,
        flow_chosen_on_carpet: 0,
        carpet_frames: 0,
        slip_flagged_on_carpet: 0,
        slip_flagged_off_carpet: 0,
        mean_running_scale: 0.0,
        dark_frames: 0,
        wheel_chosen_in_dark: 0,
    };
    let mut scale_sum = 0.0;
    let mut scale_n = 0;
    for (_, e) in &sc.events {
        match e {
            Event::Imu(s) => {
                let _ = p.push_imu(s);
            }
            Event::Wheel(d) => p.push_wheel(d).unwrap(),
            Event::Flow(s) => {
                let _ = p.push_flow(s);
            }
            Event::Camera(m) => {
                let d = p.push_camera(m).unwrap();
                out.frames += 1;
                // Truth at the frame interval's middle: on carpet or not.
                let mid = (m.t0().0 + m.t1().0) / 2;
                let k = ((mid - sc.truth[0].t_ns) / 1_000_000) as usize;
                let on = sc.truth.get(k).is_some_and(scale_sim::on_carpet);
                if d.scale == Err(NoScale::BaselineTooSmall) {
                    out.no_scale_baseline += 1;
                }
                if sc.truth.get(k).is_some_and(scale_sim::on_dark_patch) {
                    out.dark_frames += 1;
                    if matches!(d.scale, Ok(s) if s.source == ScaleSource::Wheel) {
                        out.wheel_chosen_in_dark += 1;
                    }
                }
                if on {
                    out.carpet_frames += 1;
                    if d.slip.exceeded {
                        out.slip_flagged_on_carpet += 1;
                    }
                    if matches!(d.scale, Ok(s) if s.source == ScaleSource::Flow) {
                        out.flow_chosen_on_carpet += 1;
                    }
                } else if d.slip.exceeded {
                    out.slip_flagged_off_carpet += 1;
                }
                if let Some(r) = d.running {
                    scale_sum += f64::from(r.scale);
                    scale_n += 1;
                }
            }
        }
    }
    let last = sc.truth.last().unwrap();
    let b = p.body_pose().translation.vector;
    out.error = ((f64::from(b.x) - last.x).powi(2) + (f64::from(b.y) - last.y).powi(2)).sqrt();
    out.relative = out.error / sc.path_length;
    out.mean_running_scale = scale_sum / f64::from(scale_n.max(1));
    assert!(p.counts(SensorKind::Wheel).fused() as usize == sc.wheel_samples);
    out
}

#[test]
fn fused_stays_under_two_percent_while_wheel_only_exceeds_ten() {
    let sc = scenario(7);
    assert!(
        sc.slip_samples > 100,
        "the scenario must contain slip episodes"
    );
    let fused = run(&sc, SelectionMethod::Fusion);
    let wheel = run(&sc, SelectionMethod::WheelOnly);
    println!(
        "path {:.2} m, ceiling distance {:.2} m, {} frames ({} without scale: baseline too small)",
        sc.path_length, sc.ceiling_distance, fused.frames, fused.no_scale_baseline
    );
    println!(
        "fused:      final position error {:.3} m = {:.2} % of path (mean running scale {:.3} m)",
        fused.error,
        100.0 * fused.relative,
        fused.mean_running_scale
    );
    println!(
        "wheel-only: final position error {:.3} m = {:.2} % of path (mean running scale {:.3} m)",
        wheel.error,
        100.0 * wheel.relative,
        wheel.mean_running_scale
    );
    println!(
        "fused: slip flagged on {}/{} carpet frames, {} frames off carpet",
        fused.slip_flagged_on_carpet, fused.carpet_frames, fused.slip_flagged_off_carpet
    );
    println!(
        "fused: wheel chosen on {}/{} frames over the dark patch (flow invalid)",
        fused.wheel_chosen_in_dark, fused.dark_frames
    );
    assert!(fused.dark_frames > 5);
    assert!(fused.wheel_chosen_in_dark * 10 >= fused.dark_frames * 8);
    assert!(
        fused.no_scale_baseline > 0,
        "turns in place give frames without scale"
    );
    assert!(fused.relative < 0.02, "fused {:.4}", fused.relative);
    assert!(wheel.relative > 0.10, "wheel-only {:.4}", wheel.relative);
    assert!(fused.slip_flagged_on_carpet * 10 >= fused.carpet_frames * 8);
}

#[test]
fn every_method_beats_wheel_only_on_the_slip_sequence() {
    let sc = scenario(11);
    let wheel = run(&sc, SelectionMethod::WheelOnly).relative;
    for m in [
        SelectionMethod::SlipThreshold,
        SelectionMethod::Outlier,
        SelectionMethod::SourceConfidence,
        SelectionMethod::ScaleConfidence,
        SelectionMethod::Fusion,
        SelectionMethod::FlowOnly,
    ] {
        let r = run(&sc, m);
        println!(
            "{m:?}: {:.2} % (flow chosen on {}/{} carpet frames); wheel-only {:.2} %",
            100.0 * r.relative,
            r.flow_chosen_on_carpet,
            r.carpet_frames,
            100.0 * wheel
        );
        assert!(r.relative < 0.03, "{m:?}: {:.4}", r.relative);
        assert!(r.relative < wheel / 3.0);
    }
}
