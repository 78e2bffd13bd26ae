//! A synthetic robot under a planar ceiling, for the scale tests.
//!
//! Truth: a unicycle driving a staircase path (legs east and north with
//! turns in place), integrated at 1 kHz. Sensors made from the truth:
//! wheel odometry (100 Hz) with slip episodes on carpet strips where the
//! wheels report 40 % more than the true motion, IMU (250 Hz), a downward
//! flow sensor (100 Hz, counts with quantisation, noise and a dark patch with
//! invalid reports) and camera motions (10 Hz) computed exactly from the true
//! camera poses and the ceiling distance, plus small noise.
#![allow(dead_code)]

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use vslam_core::Timestamp;
use vslam_core::geometry::{Extrinsics, Rot3, Vec3};
use vslam_core::scale::CameraMotion;
use vslam_core::sensors::{FlowOptics, FlowSample, ImuSample, OdometryDelta};

/// SplitMix64 with Box-Muller normals: seeded, reproducible.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

#[derive(Clone, Copy, Debug)]
pub struct TruthState {
    pub t_ns: u64,
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
    pub v: f64,
    pub w: f64,
    pub a: f64,
}

/// What goes into the pipeline, in feed order.
#[derive(Clone, Copy, Debug)]
pub enum Event {
    Imu(ImuSample),
    Wheel(OdometryDelta),
    Flow(FlowSample),
    Camera(CameraMotion),
}

pub struct Scenario {
    pub truth: Vec<TruthState>,
    pub events: Vec<(u64, Event)>,
    pub camera: Extrinsics,
    pub flow_optics: FlowOptics,
    pub ceiling_distance: f64,
    pub path_length: f64,
    pub slip_samples: usize,
    pub wheel_samples: usize,
}

pub const WHEEL_SLIP_FACTOR: f64 = 1.4;
const SIM_NS: u64 = 1_000_000;

/// Commanded (v, w) at time t along the staircase: legs of `leg_east`,
/// `leg_north` metres with 90 degree turns in place; speed ramps over 0.5 s.
fn plan() -> Vec<(f64, f64, f64)> {
    // (duration s, v m/s, w rad/s), ramped inside each segment.
    let v = 0.3;
    let w = 0.8;
    let turn = std::f64::consts::FRAC_PI_2 / w;
    let east = 3.0 / v;
    let north = 1.0 / v;
    vec![
        (1.0, 0.0, 0.0),
        (east, v, 0.0),
        (turn, 0.0, w),
        (north, v, 0.0),
        (turn, 0.0, -w),
        (east, v, 0.0),
        (turn, 0.0, w),
        (north, v, 0.0),
        (turn, 0.0, -w),
        (east, v, 0.0),
        (1.0, 0.0, 0.0),
    ]
}

/// A trapezoid profile inside a segment of length `dur`: ramps of 0.4 s
/// (scaled so the area stays `dur * level` for the path length).
fn ramp(tau: f64, dur: f64, level: f64) -> (f64, f64) {
    let r = 0.4f64.min(dur / 2.0);
    // Peak chosen so that the integral equals level * dur.
    let peak = level * dur / (dur - r);
    if tau < r {
        (peak * tau / r, peak / r)
    } else if tau > dur - r {
        (peak * (dur - tau) / r, -peak / r)
    } else {
        (peak, 0.0)
    }
}

pub fn truth() -> Vec<TruthState> {
    let mut out = Vec::new();
    let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
    let mut t_ns = 1_000_000_000u64;
    for (dur, v, w) in plan() {
        let steps = (dur * 1000.0).round() as u64;
        for k in 0..steps {
            let tau = k as f64 / 1000.0;
            let (vk, ak) = ramp(tau, dur, v);
            let (wk, _) = ramp(tau, dur, w);
            out.push(TruthState {
                t_ns,
                x,
                y,
                yaw,
                v: vk,
                w: wk,
                a: ak,
            });
            let dt = 1e-3;
            let mid = yaw + 0.5 * wk * dt;
            x += vk * dt * mid.cos();
            y += vk * dt * mid.sin();
            yaw += wk * dt;
            t_ns += SIM_NS;
        }
    }
    out.push(TruthState {
        t_ns,
        x,
        y,
        yaw,
        v: 0.0,
        w: 0.0,
        a: 0.0,
    });
    out
}

/// Carpet strips: the wheels slip while the robot drives east across them.
pub fn on_carpet(s: &TruthState) -> bool {
    let xm = s.x.rem_euclid(3.0);
    (0.8..2.6).contains(&xm) && s.yaw.cos() > 0.9 && s.v > 0.05
}

/// A dark patch (off the carpet) where the flow sensor's reports are invalid.
pub fn on_dark_patch(s: &TruthState) -> bool {
    (6.1..6.7).contains(&s.x) && s.y > 1.5
}

fn body_pose(s: &TruthState) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(s.x, s.y, 0.0),
        UnitQuaternion::from_euler_angles(0.0, 0.0, s.yaw),
    )
}

fn delta_in_body(a: &TruthState, b: &TruthState, point: &Vector3<f64>) -> Vector3<f64> {
    // Displacement of a body point from a to b, in the body frame at a.
    let pa = body_pose(a) * nalgebra::Point3::from(*point);
    let pb = body_pose(b) * nalgebra::Point3::from(*point);
    body_pose(a).rotation.inverse() * (pb - pa)
}

pub fn scenario(seed: u64) -> Scenario {
    let mut rng = Rng::new(seed);
    let truth = truth();
    let mut events: Vec<(u64, Event)> = Vec::new();
    let ceiling_height = 2.6;

    // Camera: looking up, 0.1 m ahead of the axle, 0.1 m high, rotated 90 deg about z.
    let r_bc = UnitQuaternion::from_euler_angles(0.0, 0.0, std::f64::consts::FRAC_PI_2);
    let t_bc = Vector3::new(0.10, 0.0, 0.10);
    let camera = Extrinsics::new(
        Rot3::from_euler_angles(0.0, 0.0, std::f32::consts::FRAC_PI_2),
        Vec3::new(0.10, 0.0, 0.10),
    )
    .unwrap();
    let t_bc_pose = Isometry3::from_parts(Translation3::from(t_bc), r_bc);
    let d = ceiling_height - t_bc.z;

    // Flow sensor: 0.15 m ahead, 0.05 m left, 20 mm above the floor, its x along body y.
    let r_bf = Rot3::from_euler_angles(0.0, 0.0, std::f32::consts::FRAC_PI_2);
    let t_bf = Vector3::new(0.15, 0.05, 0.02);
    let flow_mount = Extrinsics::new(r_bf, Vec3::new(0.15, 0.05, 0.02)).unwrap();
    let cpr = 500.0;
    let height = 0.02;
    let flow_optics = FlowOptics::new(cpr as f32, height as f32, flow_mount).unwrap();
    let flow_scale_bias = 1.005;

    let mut path_length = 0.0;
    for w in truth.windows(2) {
        path_length += ((w[1].x - w[0].x).powi(2) + (w[1].y - w[0].y).powi(2)).sqrt();
    }

    // IMU, 250 Hz (every 4 ms), mounted at the body origin.
    for s in truth.iter().step_by(4) {
        let gyro = [
            (0.002 * rng.normal()) as f32,
            (0.002 * rng.normal()) as f32,
            (s.w + 0.003 * rng.normal()) as f32,
        ];
        let accel = [
            (s.a + 0.03 * rng.normal()) as f32,
            (s.v * s.w + 0.03 * rng.normal()) as f32,
            (9.81 + 0.03 * rng.normal()) as f32,
        ];
        events.push((
            s.t_ns,
            Event::Imu(ImuSample::new(Timestamp(s.t_ns), gyro, accel).unwrap()),
        ));
    }

    // Wheels, 100 Hz: body-origin displacement; on carpet the wheels report 40 % more.
    let mut slip_samples = 0;
    let mut wheel_samples = 0;
    let idx: Vec<usize> = (0..truth.len()).step_by(10).collect();
    for w in idx.windows(2) {
        let (a, b) = (&truth[w[0]], &truth[w[1]]);
        let mut d = delta_in_body(a, b, &Vector3::zeros());
        let mut dyaw = b.yaw - a.yaw;
        let noise = 1.0 + 0.003 * rng.normal();
        d *= noise;
        dyaw *= noise;
        if on_carpet(a) {
            d *= WHEEL_SLIP_FACTOR;
            slip_samples += 1;
        }
        wheel_samples += 1;
        let translation = Vec3::new(d.x as f32, d.y as f32, 0.0);
        events.push((
            b.t_ns,
            Event::Wheel(OdometryDelta {
                t0: Timestamp(a.t_ns),
                t1: Timestamp(b.t_ns),
                translation,
                dyaw: dyaw as f32,
                path_length: translation.norm(),
            }),
        ));
    }

    // Flow, 100 Hz, offset by 3 ms from the wheels: sensor motion in sensor axes.
    let idx: Vec<usize> = (3..truth.len()).step_by(10).collect();
    let r_fb = r_bf.inverse();
    let mut residual = [0.0f64; 2];
    for (n, w) in idx.windows(2).enumerate() {
        let (a, b) = (&truth[w[0]], &truth[w[1]]);
        let d_b = delta_in_body(a, b, &t_bf) * flow_scale_bias;
        let d_s = r_fb * Vec3::new(d_b.x as f32, d_b.y as f32, 0.0);
        let mut counts = [0i16; 2];
        for (i, c) in counts.iter_mut().enumerate() {
            let exact = f64::from(d_s[i]) / height * cpr + 0.5 * rng.normal() + residual[i];
            let q = exact.round();
            residual[i] = exact - q;
            *c = q as i16;
        }
        let dark = on_dark_patch(a);
        let squal = if dark {
            0x0C
        } else {
            60 + (rng.uniform() * 80.0) as u8
        };
        let shutter = if dark {
            0x1F40
        } else {
            0x0200 + (rng.uniform() * 256.0) as u16
        };
        let sample = FlowSample {
            t: Timestamp(b.t_ns),
            dx: counts[0],
            dy: counts[1],
            squal,
            shutter,
            motion: true,
            ..FlowSample::default()
        };
        // The first report anchors.
        if n == 0 {
            events.push((
                a.t_ns,
                Event::Flow(FlowSample {
                    t: Timestamp(a.t_ns),
                    ..FlowSample::default()
                }),
            ));
        }
        events.push((b.t_ns, Event::Flow(sample)));
    }

    // Camera, 10 Hz, fed 25 ms after the second frame (processing latency).
    let idx: Vec<usize> = (0..truth.len()).step_by(100).collect();
    for w in idx.windows(2) {
        let (a, b) = (&truth[w[0]], &truth[w[1]]);
        let c0 = body_pose(a) * t_bc_pose;
        let c1 = body_pose(b) * t_bc_pose;
        let rel = c0.inverse() * c1;
        let t = rel.translation.vector / d;
        let noise_t = Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 1.5e-4;
        let axis = Vector3::new(rng.normal(), rng.normal(), rng.normal());
        let noise_r = UnitQuaternion::from_scaled_axis(axis * 1.5e-4);
        let r = (rel.rotation * noise_r).to_rotation_matrix();
        let r32 = Rot3::from_matrix_unchecked(r.matrix().cast::<f32>());
        let t32 = (t + noise_t).cast::<f32>();
        let inliers = 80 + (rng.uniform() * 80.0) as u16;
        let ratio = (0.8 + rng.uniform() * 0.15) as f32;
        let residual = (0.3 + rng.uniform() * 0.5) as f32;
        let m = CameraMotion::new(
            Timestamp(a.t_ns),
            Timestamp(b.t_ns),
            r32,
            t32,
            inliers,
            ratio,
            residual,
        )
        .unwrap();
        events.push((b.t_ns + 25_000_000, Event::Camera(m)));
    }

    events.sort_by_key(|(t, e)| (*t, matches!(e, Event::Camera(_))));
    Scenario {
        truth,
        events,
        camera,
        flow_optics,
        ceiling_distance: d,
        path_length,
        slip_samples,
        wheel_samples,
    }
}
