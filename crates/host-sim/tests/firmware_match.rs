//! The firmware's loop on the host: `firmware/src/replay.rs` and
//! `firmware/src/sample.rs` compiled here by `#[path]`, run on the same
//! `firmware/data/sample.bin` the firmware embeds.
//!
//! - `host_loop_runs_the_sample_data` checks the host run itself;
//! - `firmware_output_matches_host` (ignored; `firmware/check` runs it with
//!   `FIRMWARE_OUTPUT=<QEMU output>`) compares every `result` line the
//!   firmware printed with the host's: counts exactly, floats within
//!   [`REL_TOL`] relative or [`ABS_TOL`] absolute.
//!
//! Why a tolerance at all: both sides run the same f32 operations in the
//! same order (Rust never contracts `a * b + c` into a fused multiply-add and
//! LLVM does not reassociate floats), and `sqrt` is correctly rounded on
//! both. What may differ is the last bit of transcendental functions
//! (`sinf`, `cosf`, `atan2f`, `expf`): the firmware uses the `libm` crate,
//! while on the host nalgebra's `std` feature (enabled by other host crates)
//! routes its own calls to the platform's libm. Those 1-ulp differences pass
//! through 3,000 filter steps that contract errors (the covariance update),
//! so the end state agrees to a few ulps times the condition of the problem:
//! `1e-4` relative is 800 ulps of f32, `1e-5` absolute covers quantities that
//! end near zero (biases, the attitude's roll and pitch components).
//! Measured: the release firmware and the host agree bit for bit (largest
//! difference 0); the tolerance is for builds that differ in those last bits
//! (another libm, `-C target-cpu`, fused multiply-add experiments).
#![allow(missing_docs)]

#[path = "../../../firmware/src/sample.rs"]
#[allow(dead_code)]
mod sample;

#[path = "../../../firmware/src/frames.rs"]
#[allow(dead_code)]
mod frames;

#[path = "../../../firmware/src/replay.rs"]
#[allow(dead_code)]
mod replay;

#[path = "../../../firmware/src/budget.rs"]
mod budget;

use replay::{FlowFramesRun, FrontEndRun, SegmentRun, Summary, Unmeasured, Value};
use traction::ego_ekf::surface::floor_model::RowFeatures;
use traction::frontend::FrontEndBuffers;
use traction::vslam_core::Stream;

static SAMPLE: &[u8] = include_bytes!("../../../firmware/data/sample.bin");
static FRAMES: &[u8] = include_bytes!("../../../firmware/data/frames160.bin");
static FLOW_FRAMES: &[u8] = include_bytes!("../../../firmware/data/flowframes35.bin");

/// The host's run of the parts of the firmware: the loop, the front end,
/// the floor segmenter and the raw flow-frame tracker.
struct Host {
    summary: Summary,
    frontend: FrontEndRun,
    segment: SegmentRun,
    flow_frames: FlowFramesRun,
}

impl Host {
    fn lines(&self) -> Vec<(String, Vec<Value>)> {
        let mut v = Vec::new();
        let mut push = |name: &str, values: &[Value]| v.push((name.to_string(), values.to_vec()));
        self.summary.for_each(&mut push);
        self.frontend.for_each(&mut push);
        self.segment.for_each(&mut push);
        self.flow_frames.for_each(&mut push);
        v
    }

    fn text(&self) -> String {
        let mut text = String::new();
        self.summary.write(&mut text).unwrap();
        self.frontend.write(&mut text).unwrap();
        self.segment.write(&mut text).unwrap();
        self.flow_frames.write(&mut text).unwrap();
        text
    }
}

/// Relative tolerance on floats.
const REL_TOL: f32 = 1e-4;
/// Absolute tolerance on floats near zero.
const ABS_TOL: f32 = 1e-5;

fn host_run() -> Host {
    // The estimator the firmware holds in a static, with no probe (the
    // probe only measures; the results are the same).
    let mut est: Box<traction::Estimator<'static>> = Box::new(traction::Estimator::unconfigured());
    let summary = replay::run(SAMPLE, &mut *est, &mut Unmeasured).expect("the sample data runs");
    let (header, _) = sample::open(SAMPLE).unwrap();
    let (fh, _) = frames::open(FRAMES).expect("frame data");
    // FrontEndConfig::new's defaults: 3 levels, 3x3 corner blocks.
    let [a, b, c, d] = FrontEndBuffers::sizes(fh.width, fh.height, 3, 3);
    let buffers = FrontEndBuffers {
        previous_frame: vec![0u8; a].leak(),
        previous_pyramid: vec![0u8; b].leak(),
        current_pyramid: vec![0u8; c].leak(),
        corner_scratch: vec![0f32; d].leak(),
    };
    let frontend = replay::run_frontend(FRAMES, &header, &mut *est, buffers, &mut Unmeasured)
        .expect("the frames run");
    let mut map = vec![0u8; fh.width / 2 * (fh.height / 2)];
    let mut tables = Box::new(RowFeatures::new());
    let segment = replay::run_segment(FRAMES, &mut map, &mut tables, &mut Unmeasured)
        .expect("the frames label");
    let flow_frames =
        replay::run_flow_frames(FLOW_FRAMES, &mut Unmeasured).expect("the raw flow frames track");
    Host {
        summary,
        frontend,
        segment,
        flow_frames,
    }
}

fn get<'a>(lines: &'a [(String, Vec<Value>)], name: &str) -> &'a [Value] {
    &lines
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no `{name}`"))
        .1
}

/// `result NAME V...` lines of a firmware output.
fn parse(text: &str) -> Vec<(String, Vec<String>)> {
    text.lines()
        .filter_map(|l| l.strip_prefix("result "))
        .map(|l| {
            let mut it = l.split_whitespace();
            let name = it.next().unwrap_or_default().to_string();
            (name, it.map(str::to_string).collect())
        })
        .collect()
}

/// Every difference between the firmware's lines and the host's, and the
/// largest relative difference of a float.
fn compare(firmware: &str, host: &Host) -> (Vec<String>, f32) {
    let fw = parse(firmware);
    let mut problems = Vec::new();
    let mut worst = 0.0f32;
    let host = host.lines();
    if fw.len() != host.len() {
        problems.push(format!(
            "{} result lines from the firmware, {} on the host",
            fw.len(),
            host.len()
        ));
    }
    for (name, values) in &host {
        let Some((_, got)) = fw.iter().find(|(n, _)| n == name) else {
            problems.push(format!("`{name}` missing from the firmware output"));
            continue;
        };
        if got.len() != values.len() {
            problems.push(format!(
                "`{name}`: {} values from the firmware, {} on the host",
                got.len(),
                values.len()
            ));
            continue;
        }
        for (i, (g, want)) in got.iter().zip(values).enumerate() {
            match want {
                Value::N(n) => {
                    if g.parse::<u32>().ok() != Some(*n) {
                        problems.push(format!("`{name}`[{i}]: firmware {g}, host {n}"));
                    }
                }
                Value::F(x) => match g.parse::<f32>() {
                    Ok(y) => {
                        let d = (y - x).abs();
                        if x.abs() > ABS_TOL {
                            worst = worst.max(d / x.abs());
                        }
                        if !(d <= ABS_TOL || d <= REL_TOL * x.abs()) {
                            problems.push(format!(
                                "`{name}`[{i}]: firmware {y:e}, host {x:e} (difference {d:e})"
                            ));
                        }
                    }
                    Err(_) => problems.push(format!("`{name}`[{i}]: `{g}` is not a number")),
                },
            }
        }
    }
    (problems, worst)
}

#[test]
fn host_loop_runs_the_sample_data() {
    let host = host_run();
    let lines = host.lines();
    let text = host.text();
    print!("{text}");
    let s = &host.summary;
    // Every record read; the filter started and fused most of each stream.
    // One value per stream of the registry, in its order.
    let records = get(&lines, "records");
    assert_eq!(records.len(), Stream::COUNT);
    for (stream, n) in [
        (Stream::Imu, 3001),
        (Stream::Wheel, 601),
        (Stream::Flow, 1200),
        (Stream::Camera, 120),
    ] {
        assert_eq!(records[stream.index()], Value::N(n), "{stream}");
        assert_eq!(s.records[stream], n, "{stream}");
    }
    let total: u32 = s.records.iter().map(|(_, n)| n).sum();
    assert_eq!(
        total,
        3001 + 601 + 1200 + 120,
        "no other stream in the data"
    );
    // Every record through `traction::Estimator`: every IMU, wheel and
    // flow sample processed (returned by `poll`) and every record counted
    // once in its stream, the drive found again.
    assert_eq!(s.processed, 3001 + 601 + 1200);
    for (stream, n) in [
        (Stream::Imu, 3001),
        (Stream::Wheel, 601),
        (Stream::Flow, 1200),
        (Stream::Camera, 120),
    ] {
        let c = &s.counts[stream];
        // Gated samples are among the rejected ones.
        assert_eq!(c.fused() + c.rejected_total(), n, "{stream}");
        assert!(
            c.fused() > n * 8 / 10,
            "{stream}: {} of {n} fused",
            c.fused()
        );
    }
    let ep = s.estimate.expect("the estimator started").p_wb;
    assert!(ep.x > 2.5 && ep.x < 4.0, "estimator position {ep:?}");
    assert!(s.nav_commands > 500, "{} commands", s.nav_commands);
    assert!(s.ekf.is_initialised());
    let imu = s.ekf.imu_counts();
    assert!(imu.fused() > 2900, "IMU fused {}", imu.fused());
    assert!(s.ekf.wheel_counts().fused() > 550);
    assert!(s.ekf.flow_counts().fused() > 900);
    // The 12 s office drive: about 3.3 m ahead; the EKF and the camera
    // trajectory scaled by the pipeline agree.
    let p = s.ekf.position();
    assert!(p.x > 2.5 && p.x < 4.0, "EKF position {p:?}");
    let b = s.body_pose.translation.vector;
    assert!((b - p).norm() < 0.3, "camera {b:?} vs EKF {p:?}");
    // The scale is the camera's distance to the 2.5 m ceiling (camera at 0.1 m).
    let running = s.running.expect("a running scale");
    assert!((running.scale - 2.4).abs() < 0.1, "scale {running:?}");
    assert!(s.scaled_frames > 90);
    // The estimator's front end measured the motion between the 160x120
    // frames: about 12 mm (0.12 m/s for 0.1 s) over 2.4 m.
    let f = &host.frontend;
    assert_eq!((f.frames, f.pairs), (3, 2));
    let m = f.last.expect("a frame pair");
    assert!(m.inliers > 30, "{m:?}");
    let baseline = f.baseline.expect("a baseline");
    assert!(baseline > 0.002 && baseline < 0.05, "{baseline}");
    // The tallies also print with their reason names: the flow filter's
    // starts `fused N, gated G`, then the reasons it refused samples for.
    let mut counts = String::new();
    s.write_counts(&mut counts).unwrap();
    print!("{counts}");
    let flow = s.ekf.flow_counts();
    let line = format!(
        "counts ekf.flow_counts fused {}, gated {}",
        flow.fused(),
        flow.gated()
    );
    assert!(counts.lines().any(|l| l.starts_with(&line)), "{counts}");
    for (reason, n) in flow.by_reason() {
        if n > 0 && reason != traction::vslam_core::Reject::Gated {
            assert!(
                counts.contains(&format!("{reason} {n}")),
                "{reason}: {counts}"
            );
        }
    }
    // Every frame labelled, every cell of every map counted once.
    let seg = &host.segment;
    assert_eq!(seg.maps, 3);
    assert_eq!(seg.classes.iter().sum::<u32>(), 3 * 80 * 60);
    // Every cell's features and 2,000 draws, each with the reference's
    // scores bit for bit (compared with the firmware's line below: its
    // scores come from the Cortex-M kernel).
    assert_eq!(
        (seg.scores_checked, seg.score_mismatches),
        (3 * 80 * 60 + 2_000, 0)
    );
    // Every raw flow frame after the first makes a pair, most of them with
    // features (3 of the 10 on this floor are refused as textureless): the
    // floor moves backwards in the image, a few pixels per 10 ms report
    // (3.9 px on average here).
    let ff = &host.flow_frames;
    assert_eq!((ff.frames, ff.pairs), (11, 10));
    assert!(ff.textureless <= 3, "{ff:?}");
    assert!(ff.tracked >= 7 * 10, "{ff:?}");
    let mean_dx = ff.sum_dx / ff.tracked as f32;
    assert!(mean_dx < -1.0 && mean_dx > -6.0, "{ff:?}");
    // The printed form reads back exactly.
    let (problems, worst) = compare(&text, &host);
    assert!(problems.is_empty(), "{problems:#?}");
    assert_eq!(worst, 0.0);
}

#[test]
fn comparison_flags_a_changed_value_or_count() {
    let host = host_run();
    let text = host.text();
    let s = &host.summary;
    // A position off by 1 mm in 3 m (3e-4 relative) is beyond the tolerance.
    let x = s.ekf.position().x;
    let changed = text.replacen(
        &format!("result ekf.position {x:e}"),
        &format!("result ekf.position {:e}", x + 1e-3),
        1,
    );
    assert_ne!(changed, text);
    let (problems, _) = compare(&changed, &host);
    assert_eq!(problems.len(), 1, "{problems:#?}");
    // One ulp is within it.
    let nudged = text.replacen(
        &format!("result ekf.position {x:e}"),
        &format!("result ekf.position {:e}", f32::from_bits(x.to_bits() + 1)),
        1,
    );
    assert!(compare(&nudged, &host).0.is_empty());
    // A count differs: flagged.
    let fused = s.ekf.imu_counts().fused();
    let counts = text.replacen(
        &format!("result ekf.imu_counts {fused} "),
        &format!("result ekf.imu_counts {} ", fused + 1),
        1,
    );
    assert_ne!(counts, text);
    assert_eq!(compare(&counts, &host).0.len(), 1);
    // A missing line: flagged.
    let short: String = text
        .lines()
        .filter(|l| !l.starts_with("result scale.running"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(!compare(&short, &host).0.is_empty());
}

#[test]
fn sample_format_round_trips() {
    let (header, records) = sample::open(SAMPLE).unwrap();
    let records: Vec<_> = records.collect::<Result<_, _>>().unwrap();
    let mut bytes = Vec::new();
    let mut sink = |b: &[u8]| bytes.extend_from_slice(b);
    sample::write_header(&header, &mut sink);
    for r in &records {
        sample::write_record(r, &mut sink);
    }
    sample::write_end(&mut sink);
    assert_eq!(bytes, SAMPLE);
    // Truncated or foreign data is an error, never a panic.
    assert!(matches!(
        sample::open(&SAMPLE[..3]),
        Err(sample::FormatError::Truncated)
    ));
    assert!(matches!(
        sample::open(b"NOPE\x01\x00"),
        Err(sample::FormatError::NotSampleData)
    ));
    let (_, cut) = sample::open(&SAMPLE[..SAMPLE.len() / 2]).unwrap();
    assert_eq!(
        cut.last(),
        Some(Err(sample::FormatError::Truncated)),
        "a stream cut in the middle ends in an error"
    );
}

#[test]
#[ignore = "needs the firmware's QEMU output: run firmware/check"]
fn firmware_output_matches_host() {
    let path = std::env::var("FIRMWARE_OUTPUT")
        .expect("FIRMWARE_OUTPUT names the file with the firmware's QEMU output");
    let text = std::fs::read_to_string(&path).expect("the firmware output file");
    assert!(
        text.lines().any(|l| l.trim() == "firmware: done"),
        "the firmware did not finish"
    );
    let host = host_run();
    let (problems, worst) = compare(&text, &host);
    println!(
        "firmware vs host: {} result lines, largest relative float difference {worst:e} \
         (tolerance {REL_TOL:e} relative or {ABS_TOL:e} absolute)",
        parse(&text).len()
    );
    assert!(
        problems.is_empty(),
        "firmware and host differ:\n{}",
        problems.join("\n")
    );
}

/// The budget sums each task's step medians, multiplies by the rate, leaves
/// out tasks the image does not run and any task with a step never measured.
#[test]
fn budget_sums_medians_at_each_rate() {
    use replay::Step;
    // Medians 1000 + 10 * index for every step.
    let all = |s: Step| Some(1000 + 10 * s.index() as u32);
    let imu = budget::LOOP
        .iter()
        .find(|t| t.name == "imu_250hz")
        .and_then(|t| budget::cost(t, all))
        .expect("imu task measured");
    // Propagate (index 0) + ScaleImu (index 4) at 250 Hz.
    assert_eq!(imu.per_call, 1000 + 1040);
    assert_eq!(imu.per_second, 2040 * 250);
    assert!((imu.percent_of(budget::M4_HZ) - 2040.0 * 250.0 * 100.0 / 168e6).abs() < 1e-4);
    let total = budget::total(all);
    let by_hand: u64 = budget::LOOP
        .iter()
        .filter_map(|t| budget::cost(t, all))
        .map(|c| c.per_second)
        .sum();
    assert_eq!(total.per_second, by_hand);
    // The camera's front end (index 9) never completed: the camera task drops out.
    let no_frontend = |s: Step| (s != Step::FrontEnd).then(|| all(s)).flatten();
    assert!(
        budget::LOOP
            .iter()
            .any(|t| t.name.starts_with("camera") && budget::cost(t, no_frontend).is_none())
    );
    assert!(budget::total(no_frontend).per_second < total.per_second);
    assert!(total.percent_of(budget::M7_HZ) < total.percent_of(budget::M4_HZ));
    // An alternative takes its task's place: the flow sensor's raw frames
    // (FlowFrame, index 18) at 100 Hz instead of the counts' ScaleFlow +
    // FuseFlow (indices 6 and 2).
    let frames = &budget::ALTERNATIVES[0];
    assert_eq!(
        (frames.task.name, frames.replaces),
        ("flow_frames_100hz", "flow_100hz")
    );
    assert!(budget::LOOP.iter().any(|t| t.name == frames.replaces));
    let with = budget::total_with(frames, all).expect("measured");
    assert_eq!(
        with.per_second,
        total.per_second - (1060 + 1020) * 100 + 1180 * 100
    );
    // Not measured: no alternative total.
    let no_frames = |s: Step| (s != Step::FlowFrame).then(|| all(s)).flatten();
    assert!(budget::total_with(frames, no_frames).is_none());
}
