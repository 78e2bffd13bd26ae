//! Writes the firmware's embedded sample data, `firmware/data/sample.bin`
//! (format: `firmware/src/sample.rs`), deterministically from a seed:
//!
//! ```text
//! cargo run --release -p host-sim --example firmware_data [-- OUT.bin]
//! ```
//!
//! The `short` scenario of `host-sim simulate` (12 s of the office drive,
//! seed [`SEED`]): IMU at 250 Hz, wheel counts at 50 Hz and flow reports read
//! through the real drivers from the register-level chip simulators, and the
//! camera motions that traction's own front end (`traction::frontend`)
//! measures on the rendered 320x240 ceiling frames at 10 Hz. Records are in
//! processing order: by time, and at equal times IMU, wheel, flow, camera.
//!
//! Also writes `firmware/data/frames160.bin` (format: `firmware/src/frames.rs`):
//! [`FRAME_COUNT`] consecutive ceiling frames from [`FIRST_FRAME`] on,
//! 2x2 box-averaged to 160x120 (intrinsics halved), for the firmware's
//! front-end measurement.
//!
//! And `firmware/data/flowframes35.bin` (the same format, 35x35): the flow
//! sensor's raw frames of the same run, [`FLOW_FRAMES`] consecutive grabs at
//! the flow report rate from [`FLOW_FIRST_S`] on, rendered by the chip
//! simulator's frame renderer (`host_sim::sim::flow_frames`) and read
//! through the real driver's frame-grab path, for the firmware's raw-frame
//! measurement.
#![allow(missing_docs)]

use std::path::PathBuf;

use host_sim::pngio::load_gray;
use host_sim::sim::flow_frames;
use host_sim::sim::motion::TruthStep;
use host_sim::sim::scenario::{Scenario, generate};
use traction::frontend::{FrontEnd, FrontEndBuffers, FrontEndConfig};
use traction::vslam_core::decompose::PinholeIntrinsics;
use traction::vslam_core::flow_frames::FOCAL_PX;
use traction::vslam_core::geometry::Extrinsics;
use traction::vslam_core::sensors::FLOW_FRAME_SIDE;

#[path = "../../../firmware/src/sample.rs"]
#[allow(dead_code)]
mod sample;

#[path = "../../../firmware/src/frames.rs"]
#[allow(dead_code)]
mod frames;

use sample::{Header, Record};

/// The seed of the simulated run.
const SEED: u64 = 7;
/// First camera frame (3 s into the drive) and frames for the front end.
const FIRST_FRAME: usize = 30;
const FRAME_COUNT: usize = 3;
/// First raw flow frame's time into the drive, s, and raw frames.
const FLOW_FIRST_S: f64 = 3.0;
const FLOW_FRAMES: usize = 11;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware/data/sample.bin")
        });
    let (bytes, frames, flow_frames) = sample_data()?;
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(&out, &bytes)?;
    println!("wrote {} ({} bytes)", out.display(), bytes.len());
    let out = out.with_file_name("frames160.bin");
    std::fs::write(&out, &frames)?;
    println!("wrote {} ({} bytes)", out.display(), frames.len());
    let out = out.with_file_name("flowframes35.bin");
    std::fs::write(&out, &flow_frames)?;
    println!("wrote {} ({} bytes)", out.display(), flow_frames.len());
    Ok(())
}

/// The flow sensor's raw frames over `truth` from [`FLOW_FIRST_S`] on, one
/// per flow report ([`flow_frames::grabs`]), in the format of
/// `firmware/src/frames.rs` (intrinsics: the raw frame's focal length and
/// centre, pixels).
fn raw_flow_frames(
    scenario: &Scenario,
    truth: &[TruthStep],
) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    let first = (FLOW_FIRST_S * 1e9) as u64;
    let start = truth
        .iter()
        .position(|s| s.t_ns >= first)
        .ok_or("the drive ends before the raw frames")?;
    let centre = (FLOW_FRAME_SIDE / 2) as f32;
    let header = frames::FramesHeader {
        width: FLOW_FRAME_SIDE,
        height: FLOW_FRAME_SIDE,
        intrinsics: [FOCAL_PX, FOCAL_PX, centre, centre],
        count: FLOW_FRAMES,
    };
    let mut bytes = Vec::new();
    frames::write_header(&header, &mut |b: &[u8]| bytes.extend_from_slice(b));
    let tail = truth.get(start..).unwrap_or(&[]);
    let mut written = 0;
    for grab in flow_frames::grabs(&scenario.world, &scenario.flow, tail, SEED)?.take(FLOW_FRAMES) {
        let grab = grab?;
        frames::write_frame(grab.t, &grab.pixels, &mut |b: &[u8]| {
            bytes.extend_from_slice(b)
        });
        written += 1;
    }
    if written != FLOW_FRAMES {
        return Err("the drive ends before the last raw frame".into());
    }
    Ok(bytes)
}

/// `img` (`w x h`) averaged over 2x2 blocks, rounded.
fn half(img: &[u8], w: usize, h: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(w / 2 * (h / 2));
    for y in 0..h / 2 {
        for x in 0..w / 2 {
            let p = |dx: usize, dy: usize| u32::from(img[(2 * y + dy) * w + 2 * x + dx]);
            out.push(((p(0, 0) + p(1, 0) + p(0, 1) + p(1, 1) + 2) / 4) as u8);
        }
    }
    out
}

type Data = (Vec<u8>, Vec<u8>, Vec<u8>);

fn sample_data() -> Result<Data, Box<dyn std::error::Error>> {
    let scenario = Scenario::by_name("short").ok_or("no `short` scenario")?;
    let dir = std::env::temp_dir().join(format!("traction-firmware-data-{}", std::process::id()));
    let (ds, truth) = generate(&scenario, SEED, &dir)?;
    let flow_frames = raw_flow_frames(&scenario, &truth)?;
    let (imu_meta, imu) = ds.imu.as_ref().ok_or("no IMU stream")?;
    let (wheel_meta, wheels) = ds.wheel.as_ref().ok_or("no wheel stream")?;
    let (flow_meta, flow) = ds.flow.as_ref().ok_or("no flow stream")?;
    let (cam_meta, frames) = ds.cam.as_ref().ok_or("no camera stream")?;

    // The camera motions, as the estimator's camera path measures them.
    let [fu, fv, cu, cv] = cam_meta.intrinsics.map(|v| v as f32);
    let (w, h) = (
        cam_meta.resolution[0] as usize,
        cam_meta.resolution[1] as usize,
    );
    let mount = Extrinsics::from_row_major(&cam_meta.t_bs)?;
    let config = FrontEndConfig::new(w, h, PinholeIntrinsics::new(fu, fv, cu, cv)?, mount);
    let [s0, s1, s2, s3] = FrontEndBuffers::sizes(w, h, config.levels, config.corners.block_size);
    let (mut b0, mut b1, mut b2, mut b3) =
        (vec![0u8; s0], vec![0u8; s1], vec![0u8; s2], vec![0f32; s3]);
    let mut frontend = FrontEnd::new(
        config,
        FrontEndBuffers {
            previous_frame: &mut b0,
            previous_pyramid: &mut b1,
            current_pyramid: &mut b2,
            corner_scratch: &mut b3,
        },
    )?;
    let mut motions = Vec::new();
    let mut small = Vec::new();
    let small_header = frames::FramesHeader {
        width: w / 2,
        height: h / 2,
        // Pixel centres: u' = (u + 0.5) / 2 - 0.5.
        intrinsics: [
            fu / 2.0,
            fv / 2.0,
            (cu + 0.5) / 2.0 - 0.5,
            (cv + 0.5) / 2.0 - 0.5,
        ],
        count: FRAME_COUNT,
    };
    frames::write_header(&small_header, &mut |b: &[u8]| small.extend_from_slice(b));
    for (i, frame) in frames.iter().enumerate() {
        let img = load_gray(&frame.path)?;
        if let Ok(Some(m)) = frontend.process(frame.t, &img.view()?) {
            motions.push(m);
        }
        if (FIRST_FRAME..FIRST_FRAME + FRAME_COUNT).contains(&i) {
            let pixels = half(&img.data, img.width, img.height);
            frames::write_frame(frame.t, &pixels, &mut |b: &[u8]| small.extend_from_slice(b));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);

    // Every stream in processing order.
    let mut records: Vec<(u64, u8, Record)> = Vec::new();
    records.extend(imu.iter().map(|s| (s.t.0, 0, Record::Imu(*s))));
    records.extend(wheels.iter().map(|s| (s.t.0, 1, Record::Wheel(*s))));
    records.extend(flow.iter().map(|s| (s.t.0, 2, Record::Flow(*s))));
    records.extend(motions.iter().map(|m| (m.t1().0, 3, Record::Camera(*m))));
    records.sort_by_key(|(t, k, _)| (*t, *k));

    let header = Header {
        imu_noise: [
            imu_meta.accelerometer_noise_density as f32,
            imu_meta.gyroscope_noise_density as f32,
            imu_meta.accelerometer_random_walk as f32,
            imu_meta.gyroscope_random_walk as f32,
        ],
        ticks_per_revolution: wheel_meta
            .ticks_per_revolution
            .ok_or("no encoder resolution")?
            .round() as u32,
        wheel_radius: [
            wheel_meta.wheel_radius_left as f32,
            wheel_meta.wheel_radius_right as f32,
        ],
        wheel_base: wheel_meta.wheel_base as f32,
        flow_counts_per_radian: flow_meta.counts_per_radian as f32,
        flow_height: flow_meta.height as f32,
        flow_t_bs: flow_meta.t_bs,
        camera_t_bs: cam_meta.t_bs,
        imu_t_bs: imu_meta.t_bs,
    };
    let mut bytes = Vec::new();
    let mut sink = |b: &[u8]| bytes.extend_from_slice(b);
    sample::write_header(&header, &mut sink);
    for (_, _, r) in &records {
        sample::write_record(r, &mut sink);
    }
    sample::write_end(&mut sink);
    eprintln!(
        "{} IMU, {} wheel, {} flow, {} camera motions ({} frames)",
        imu.len(),
        wheels.len(),
        flow.len(),
        motions.len(),
        frames.len()
    );
    Ok((bytes, small, flow_frames))
}
