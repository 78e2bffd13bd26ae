//! Vertical jolts at 250 Hz: one bump is one event, the log and counters, and
//! the surface-adaptivity scenario (carpet and a threshold strip raise no
//! obstacle with surface-aware thresholds, a fixed wood threshold does, and a
//! cable on wood is still found).

mod surface_support;

use ego_ekf::events::{JoltConfig, JoltContext, JoltEvent, JoltKind, JoltMonitor};
use ego_ekf::surface::{SurfaceConfig, SurfaceKind, SurfaceModel, TrackerConfig, WheelType};
use proptest::test_runner::TestRng;
use surface_support::*;
use vslam_core::image::LabelView;
use vslam_core::{Reject, Timestamp};

const DT_NS: u64 = 4_000_000; // 250 Hz
const RATE: f64 = 250.0;

fn t_of(k: usize) -> Timestamp {
    Timestamp(k as u64 * DT_NS)
}

/// Floor vibration: an AR(1) process (`0.7` memory per 4 ms step) with
/// stationary standard deviation `sigma`, as vertical deviation `|x|`.
fn vibration(rng: &mut TestRng, sigma: f64, n: usize) -> Vec<f64> {
    let a: f64 = 0.7;
    let drive = sigma * (1.0 - a * a).sqrt();
    let mut x = 0.0;
    (0..n)
        .map(|_| {
            x = a * x + drive * normal(rng);
            x
        })
        .collect()
}

/// Adds a half-sine jolt of `peak` m/s^2 lasting `duration` s from `start` s.
fn add_jolt(signal: &mut [f64], start: f64, duration: f64, peak: f64) {
    let k0 = (start * RATE).round() as usize;
    let len = (duration * RATE).round() as usize;
    for i in 0..=len {
        if let Some(s) = signal.get_mut(k0 + i) {
            *s += peak * (std::f64::consts::PI * i as f64 / len as f64).sin();
        }
    }
}

fn run_fixed<const N: usize>(
    m: &mut JoltMonitor<N>,
    signal: &[f64],
    ctx: &JoltContext,
) -> Vec<JoltEvent> {
    signal
        .iter()
        .enumerate()
        .filter_map(|(k, v)| m.push(t_of(k), v.abs() as f32, ctx).unwrap())
        .collect()
}

fn wood_params() -> ego_ekf::GripParams {
    ego_ekf::surface::GripTable::default().params(SurfaceKind::Wood, WheelType::HardRubber, 1.0)
}

#[test]
fn one_bump_is_one_event() {
    let mut m = JoltMonitor::<8>::new(JoltConfig::default());
    let ctx = JoltContext::fixed(2.0);
    let mut s = vec![0.1; 500];
    // A bump with ringing: a second, smaller peak 30 ms later, a third 120 ms later.
    add_jolt(&mut s, 0.40, 0.02, 6.0);
    add_jolt(&mut s, 0.43, 0.02, 4.0);
    add_jolt(&mut s, 0.52, 0.02, 3.0);
    let ev = run_fixed(&mut m, &s, &ctx);
    assert_eq!(ev.len(), 1, "{ev:?}");
    let e = ev[0];
    assert_eq!(e.kind, JoltKind::SuspectedObstacle);
    // The peak is the signal's largest sample (as the detector sees it, f32;
    // the first of equal ones), at its time.
    let (k_max, v_max) = s.iter().enumerate().fold((0, 0.0f32), |b, (k, v)| {
        if *v as f32 > b.1 { (k, *v as f32) } else { b }
    });
    assert_eq!(e.magnitude, v_max, "{e:?}");
    assert_eq!(e.t, t_of(k_max));
    assert!(e.onset <= e.t);
    assert_eq!(e.explained, 2.0);
    // Two bumps half a second apart are two events.
    let mut m = JoltMonitor::<8>::new(JoltConfig::default());
    let mut s = vec![0.1; 500];
    add_jolt(&mut s, 0.40, 0.02, 6.0);
    add_jolt(&mut s, 0.90, 0.02, 5.0);
    assert_eq!(run_fixed(&mut m, &s, &ctx).len(), 2);
    assert_eq!(m.counters().get(JoltKind::SuspectedObstacle), 2);
}

#[test]
fn a_sustained_level_is_one_event_until_calm_again() {
    let mut m = JoltMonitor::<8>::new(JoltConfig::default());
    let ctx = JoltContext::fixed(2.0);
    let mut s = vec![0.0; 250];
    s.extend(vec![5.0; 250]); // one second pressed up
    s.extend(vec![0.0; 100]);
    s.extend(vec![5.0; 20]);
    s.extend(vec![0.0; 100]);
    let ev = run_fixed(&mut m, &s, &ctx);
    assert_eq!(ev.len(), 2, "{ev:?}");
}

#[test]
fn bad_samples_are_refused_and_counted() {
    let mut m = JoltMonitor::<8>::new(JoltConfig::default());
    let ctx = JoltContext::fixed(2.0);
    assert_eq!(m.push(t_of(1), f32::NAN, &ctx), Err(Reject::NonFinite));
    assert_eq!(m.push(t_of(1), f32::INFINITY, &ctx), Err(Reject::NonFinite));
    assert_eq!(m.push(t_of(2), 0.1, &ctx), Ok(None));
    assert_eq!(m.push(t_of(2), 0.1, &ctx), Err(Reject::Duplicate));
    assert_eq!(m.push(t_of(1), 0.1, &ctx), Err(Reject::OutOfOrder));
    let c = m.detector().samples();
    assert_eq!(c.fused(), 1);
    assert_eq!(c.rejected(Reject::NonFinite), 2);
    assert_eq!(c.rejected_total(), 4);
    // A jolt cut by a gap in the stream is closed with what was seen.
    assert_eq!(m.push(t_of(3), 4.0, &ctx), Ok(None));
    assert!(m.detector().is_capturing());
    let e = m
        .push(t_of(3 + 100), 0.1, &ctx)
        .unwrap()
        .expect("closed by gap");
    assert_eq!(e.magnitude, 4.0);
    assert_eq!(m.detector().samples().rejected(Reject::Gap), 1);
}

#[test]
fn a_full_log_drops_the_oldest_and_counts_it() {
    let mut m = JoltMonitor::<4>::new(JoltConfig::default());
    let ctx = JoltContext::fixed(2.0);
    let mut s = vec![0.0; 250 * 4];
    for i in 0..6 {
        add_jolt(&mut s, 0.2 + 0.5 * i as f64, 0.02, 3.0 + i as f64);
    }
    let ev = run_fixed(&mut m, &s, &ctx);
    assert_eq!(ev.len(), 6);
    assert_eq!(m.counters().total(), 6);
    assert_eq!(m.dropped(), 2);
    let kept: Vec<f32> = m.events().map(|e| e.magnitude.round()).collect();
    assert_eq!(kept, vec![5.0, 6.0, 7.0, 8.0]);
    m.clear_log();
    assert_eq!(m.events().count(), 0);
    assert_eq!(m.counters().total(), 6);
}

#[test]
fn jolts_near_a_boundary_crossing_are_threshold_strips() {
    let cfg = JoltConfig::default();
    let ctx = JoltContext {
        jolt_threshold: 2.0,
        floor_jolt_threshold: 2.0,
        strip_threshold: 9.0,
        surface: Some(SurfaceKind::Wood),
        last_crossing: Some(Timestamp(10_000_000_000)),
        next_crossing: None,
        forward_speed: 0.2,
    };
    let at = |s: f64| Timestamp((s * 1e9) as u64);
    assert_eq!(cfg.classify(at(10.1), 1.5, &ctx), JoltKind::SurfaceNoise);
    assert_eq!(cfg.classify(at(10.1), 6.0, &ctx), JoltKind::ThresholdStrip);
    // Also shortly before an announced crossing.
    let before = JoltContext {
        last_crossing: None,
        next_crossing: Some(at(10.0)),
        ..ctx
    };
    assert_eq!(
        cfg.classify(at(9.8), 6.0, &before),
        JoltKind::ThresholdStrip
    );
    // Larger than a strip explains: an obstacle even at a boundary.
    assert_eq!(
        cfg.classify(at(10.1), 12.0, &ctx),
        JoltKind::SuspectedObstacle
    );
    // Too far in time (0.5 s) and distance (0.15 m at 0.2 m/s = 0.75 s).
    assert_eq!(cfg.classify(at(10.7), 6.0, &ctx), JoltKind::ThresholdStrip);
    assert_eq!(
        cfg.classify(at(10.8), 6.0, &ctx),
        JoltKind::SuspectedObstacle
    );
    // Without boundaries nothing is a strip.
    assert_eq!(
        cfg.classify(at(10.1), 6.0, &JoltContext::fixed(2.0)),
        JoltKind::SuspectedObstacle
    );
    // On the strip itself (the floor in view a strip, the floor beside it
    // explaining 2 m/s^2): at a boundary a jolt the strip explains is the
    // strip's, one larger an obstacle; away from any boundary the strip
    // explains nothing (a strip is narrow), and a jolt the floor beside it
    // explains is still the strip's.
    let on_strip = JoltContext {
        jolt_threshold: 8.0,
        surface: Some(SurfaceKind::Threshold),
        last_crossing: Some(at(19.9)),
        ..ctx
    };
    assert_eq!(
        cfg.classify(at(20.0), 6.0, &on_strip),
        JoltKind::ThresholdStrip
    );
    assert_eq!(
        cfg.classify(at(20.0), 9.5, &on_strip),
        JoltKind::SuspectedObstacle
    );
    let far = JoltContext {
        last_crossing: None,
        ..on_strip
    };
    assert_eq!(
        cfg.classify(at(20.0), 6.0, &far),
        JoltKind::SuspectedObstacle
    );
    assert_eq!(cfg.classify(at(20.0), 1.5, &far), JoltKind::ThresholdStrip);
}

/// The surface-adaptivity scenario. The robot drives at 0.2 m/s over wood
/// towards carpet 0.5 m ahead (the wheels reach it at 2.5 s), crosses a
/// threshold strip there, and goes on over carpet to 10 s; maps come at 4 Hz.
struct Scenario {
    adaptive: Vec<JoltEvent>,
    fixed_wood: Vec<JoltEvent>,
}

fn carpet_scenario(seed: u8, cable_on_carpet: Option<(f64, f64)>) -> Scenario {
    let speed = 0.2;
    let n = (10.0 * RATE) as usize;
    let crossing = 2.5;
    let mut r = rng(seed);
    let wood = vibration(&mut r, 0.3, n);
    let carpet = vibration(&mut r, 1.0, n);
    let mut s: Vec<f64> = (0..n)
        .map(|k| {
            if (k as f64 / RATE) < crossing {
                wood[k]
            } else {
                carpet[k]
            }
        })
        .collect();
    // The threshold strip: a 30 ms jolt of 6.5 m/s^2 as the wheels cross it.
    add_jolt(&mut s, crossing - 0.02, 0.03, 6.5);
    if let Some((at, peak)) = cable_on_carpet {
        add_jolt(&mut s, at, 0.025, peak);
    }

    let mut cfg = SurfaceConfig::new(WheelType::HardRubber, classes());
    cfg.camera = camera();
    cfg.tracker = TrackerConfig::default();
    let mut model = SurfaceModel::new(cfg);
    let mut adaptive = JoltMonitor::<64>::new(JoltConfig::default());
    let mut fixed = JoltMonitor::<64>::new(JoltConfig::default());
    let wood_ctx = JoltContext::from_params(&wood_params(), Some(SurfaceKind::Wood));
    let (w, h) = (32, 48);
    let mut out = Scenario {
        adaptive: Vec::new(),
        fixed_wood: Vec::new(),
    };
    for (k, v) in s.iter().enumerate() {
        let t = t_of(k);
        if k % 63 == 0 {
            // ~4 Hz segmentation.
            let secs = k as f64 / RATE;
            let labels = boundary_map(w, h, 0.4, 0.5 - speed * secs, WOOD, CARPET);
            model
                .on_segmentation(t, &LabelView::new(&labels, w, h, w).unwrap(), speed as f32)
                .unwrap();
        }
        let ctx = model.jolt_context(t, speed as f32);
        if let Some(e) = adaptive.push(t, v.abs() as f32, &ctx).unwrap() {
            out.adaptive.push(e);
        }
        if let Some(e) = fixed.push(t, v.abs() as f32, &wood_ctx).unwrap() {
            out.fixed_wood.push(e);
        }
    }
    out
}

fn count(ev: &[JoltEvent], kind: JoltKind) -> usize {
    ev.iter().filter(|e| e.kind == kind).count()
}

#[test]
fn carpet_and_a_threshold_strip_raise_no_obstacle_with_surface_aware_thresholds() {
    for seed in [11u8, 12, 13] {
        let s = carpet_scenario(seed, None);
        let obstacles = count(&s.adaptive, JoltKind::SuspectedObstacle);
        let strips: Vec<_> = s
            .adaptive
            .iter()
            .filter(|e| e.kind == JoltKind::ThresholdStrip)
            .collect();
        let fixed_obstacles = count(&s.fixed_wood, JoltKind::SuspectedObstacle);
        eprintln!(
            "seed {seed}: adaptive {} events ({} obstacle, {} strip, {} noise); fixed wood {} obstacles",
            s.adaptive.len(),
            obstacles,
            strips.len(),
            count(&s.adaptive, JoltKind::SurfaceNoise),
            fixed_obstacles
        );
        assert_eq!(obstacles, 0, "seed {seed}: {:?}", s.adaptive);
        // The strip is recognised as such, on the floor of the moment.
        assert_eq!(strips.len(), 1, "seed {seed}");
        let tp = strips[0].t.seconds_since(Timestamp(0)).unwrap();
        assert!((tp - 2.5).abs() < 0.05);
        assert!(strips[0].magnitude > 6.0);
        // Carpet jolts are logged as surface noise, on carpet.
        assert!(
            s.adaptive
                .iter()
                .filter(|e| e.kind == JoltKind::SurfaceNoise)
                .all(|e| e.surface.is_some())
        );
        // A fixed threshold tuned for wood cries obstacle on the same ride.
        assert!(fixed_obstacles >= 3, "seed {seed}: {fixed_obstacles}");
    }
}

/// The jolt events of `signal` judged against a surface model that sees
/// the 32x48 map `floor` at about 4 Hz while the robot drives at 0.2 m/s;
/// `each` sees every step's context. Returns the events and the model.
fn events_on_one_floor(
    signal: &[f64],
    floor: &[u8],
    mut each: impl FnMut(&JoltContext),
) -> (Vec<JoltEvent>, SurfaceModel) {
    let mut cfg = SurfaceConfig::new(WheelType::HardRubber, classes());
    cfg.camera = camera();
    let mut model = SurfaceModel::new(cfg);
    let mut m = JoltMonitor::<16>::new(JoltConfig::default());
    let mut events = Vec::new();
    for (k, v) in signal.iter().enumerate() {
        let t = t_of(k);
        if k % 63 == 0 {
            model
                .on_segmentation(t, &LabelView::new(floor, 32, 48, 32).unwrap(), 0.2)
                .unwrap();
        }
        let ctx = model.jolt_context(t, 0.2);
        each(&ctx);
        if let Some(e) = m.push(t, v.abs() as f32, &ctx).unwrap() {
            events.push(e);
        }
    }
    (events, model)
}

#[test]
fn a_cable_is_still_an_obstacle_on_wood_and_on_carpet() {
    // Wood only, with a cable (a sharp 7 m/s^2, 25 ms jolt) at 1.0 s.
    let n = (3.0 * RATE) as usize;
    let mut r = rng(21);
    let mut s = vibration(&mut r, 0.3, n);
    add_jolt(&mut s, 1.0, 0.025, 7.0);
    let floor = map(32, 48, |_, y| if y < 19 { WALL } else { WOOD });
    let (events, _) = events_on_one_floor(&s, &floor, |_| {});
    let obstacles: Vec<_> = events
        .iter()
        .filter(|e| e.kind == JoltKind::SuspectedObstacle)
        .collect();
    assert_eq!(obstacles.len(), 1, "{events:?}");
    let o = obstacles[0];
    assert_eq!(o.surface, Some(SurfaceKind::Wood));
    assert!((o.t.seconds_since(Timestamp(0)).unwrap() - 1.0125).abs() < 0.02);
    assert!(o.magnitude > 6.5);
    // On carpet, far from the boundary, a harder cable hit is found too.
    let s = carpet_scenario(14, Some((6.0, 9.0)));
    let obstacles: Vec<_> = s
        .adaptive
        .iter()
        .filter(|e| e.kind == JoltKind::SuspectedObstacle)
        .collect();
    assert_eq!(obstacles.len(), 1, "{:?}", s.adaptive);
    assert_eq!(obstacles[0].surface, Some(SurfaceKind::Carpet));
    assert!((obstacles[0].t.seconds_since(Timestamp(0)).unwrap() - 6.0125).abs() < 0.02);
}

/// A segmenter that takes the floor for a threshold strip (as the reference
/// model does on floors unlike its training photographs): every map labels
/// the ground below the walls a strip for 6 s of driving. A strip is narrow,
/// so it explains jolts only at a floor boundary: a cable hit at 4.0 s, far
/// from the one crossing (the first map), is still a suspected obstacle.
#[test]
fn a_floor_taken_for_a_strip_does_not_explain_a_cable() {
    let n = (6.0 * RATE) as usize;
    let mut r = rng(41);
    let mut s = vibration(&mut r, 0.3, n);
    add_jolt(&mut s, 4.0, 0.025, 6.4);
    let strip_floor = map(32, 48, |_, y| if y < 19 { WALL } else { STRIP });
    let (events, model) = events_on_one_floor(&s, &strip_floor, |ctx| {
        assert_eq!(ctx.surface, Some(SurfaceKind::Threshold));
    });
    let cable: Vec<_> = events
        .iter()
        .filter(|e| (e.t.seconds_since(Timestamp(0)).unwrap() - 4.0125).abs() < 0.05)
        .collect();
    assert_eq!(cable.len(), 1, "{events:?}");
    assert_eq!(cable[0].kind, JoltKind::SuspectedObstacle, "{events:?}");
    // What the strip alone would explain: more than this jolt.
    assert!(model.jolt_context(t_of(n), 0.2).jolt_threshold > 6.4);
}

#[test]
fn a_threshold_strip_class_in_view_explains_its_jolt_and_only_there() {
    // Wood with a 4 cm strip 0.6 m ahead; at 0.2 m/s the wheels reach it at
    // 3.0 s. The strip jolts 6.5 m/s^2 there; a cable hits at 5.0 s on wood.
    let speed = 0.2;
    let n = (6.0 * RATE) as usize;
    let mut r = rng(31);
    let mut s = vibration(&mut r, 0.3, n);
    add_jolt(&mut s, 2.99, 0.03, 6.5);
    add_jolt(&mut s, 5.0, 0.025, 7.0);
    let mut cfg = SurfaceConfig::new(WheelType::HardRubber, classes());
    cfg.camera = camera();
    let mut model = SurfaceModel::new(cfg);
    let mut m = JoltMonitor::<16>::new(JoltConfig::default());
    let (w, h) = (32, 96);
    let mut announced_strip = false;
    let mut events = Vec::new();
    for (k, v) in s.iter().enumerate() {
        let t = t_of(k);
        if k % 63 == 0 {
            let secs = k as f64 / RATE;
            let labels = strip_map(w, h, 0.4, 0.6 - speed * secs, 0.04);
            let _ = model.on_segmentation(t, &LabelView::new(&labels, w, h, w).unwrap(), 0.2);
            let st = model.state_at(t);
            announced_strip |= st
                .anticipation
                .is_some_and(|a| a.kind == SurfaceKind::Threshold);
        }
        if let Some(e) = m
            .push(t, v.abs() as f32, &model.jolt_context(t, 0.2))
            .unwrap()
        {
            events.push(e);
        }
    }
    assert!(announced_strip, "the strip class was announced ahead");
    let at = |e: &JoltEvent| e.t.seconds_since(Timestamp(0)).unwrap();
    let strip: Vec<_> = events
        .iter()
        .filter(|e| (at(e) - 3.0).abs() < 0.1)
        .collect();
    assert_eq!(strip.len(), 1, "{events:?}");
    eprintln!("strip event: {:?}", strip[0]);
    assert!(!strip[0].kind.is_obstacle(), "{:?}", strip[0]);
    let cable: Vec<_> = events
        .iter()
        .filter(|e| (at(e) - 5.0).abs() < 0.1)
        .collect();
    assert_eq!(cable.len(), 1, "{events:?}");
    assert_eq!(cable[0].kind, JoltKind::SuspectedObstacle);
    assert_eq!(cable[0].surface, Some(SurfaceKind::Wood));
    assert_eq!(count(&events, JoltKind::SuspectedObstacle), 1, "{events:?}");
}
