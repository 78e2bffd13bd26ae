//! Monte Carlo consistency of the fused filter: IMU at 250 Hz, wheel rates
//! at 50 Hz, zero-velocity updates while still, the downward flow sensor at
//! 25 Hz and the camera's frame pairs at 10 Hz (relative rotation and
//! metric translation between the pose clone at the previous frame and the
//! pose now; `ego_ekf::camera`). Seeded runs on the simulated drive of
//! `tests/consistency.rs` (curves and stops), truth and start drawn from
//! the filter's priors (`support::monte_carlo::draw`).
//!
//! The camera's measurement noise is drawn from what the filter is told:
//! each rotation angle from `rotation_std` (camera frame), the direction
//! `t/d` from the isotropic `translation_rel_std`, `translation_std` share,
//! and the metric scale from the variance handed to `fuse_camera`, each
//! pair independently. The flow's noise is the simulator's (white, 5 mm/s,
//! and its counts' quantization), told to the filter as `base_std`, with a
//! negligible relative share (the simulated optics have no height error).
//! The wheels' lateral and vertical constraints and the zero-velocity
//! update keep the filter's default noise although the simulation is exact
//! there: that makes the velocity conservative (below).
//!
//! Checked: the run-averaged NEES of position, velocity, attitude (3
//! degrees of freedom each) and world yaw (1) has a time average inside
//! the two-sided 95 % chi-square bounds, and at least 80 % of the
//! checkpoints are inside too, except for the velocity, of which 80 % must
//! not be above the upper bound (it is conservative: with the lateral
//! constraint's noise at 0.2 mm/s instead of 1 mm/s its ANEES is 2.83, 54
//! of 60 inside; but then the yaw's is 1.50, 38 of 60, see below); the
//! camera pairs' mean NIS lies between 0.9 and 1 times its 6 degrees of
//! freedom; the covariance stays positive definite. `MC_RUNS=200` measures
//! with more seeds (the same checks, narrower bounds: they then fail on
//! the conservative side, see the figures at the test).
//!
//! Not consistent at 200 runs (what this test does not claim): yaw and
//! position, the directions nothing observes, are overconfident once the
//! filter is told noise closer to the simulation's exact constraints
//! (lateral 0.2 mm/s, zero-velocity 0.5 mm/s: yaw ANEES 1.12-1.46 and
//! position 3.33-3.77 over the 200 seeds from 1000, 2000, 4000 and 6000,
//! bounds [0.81, 1.21] and [2.67, 3.35]), and equally so without the camera
//! and the flow (from 4000: yaw 1.44, position 3.75): the yaw variance
//! falls below its prior (1e-4 rad^2 to 8.3e-5 in 60 s), and with a yaw
//! prior of 0.2 rad it falls to 0.13 rad in the first second, the robot
//! standing still (the wheel updates; `tests/yaw_unobservable.rs`), which
//! a filter in which absolute yaw is unobservable must never do; the EKF's
//! Jacobians evaluated at changing
//! estimates give it spurious yaw information (Huang, Mourikis &
//! Roumeliotis, "Observability-based rules for designing consistent EKF
//! SLAM estimators", IJRR 2010; Hesch et al., "Consistency analysis and
//! improvement of vision-aided inertial navigation", T-RO 2014).

mod support;

use ego_ekf::covariance::is_positive_definite;
use ego_ekf::state::{KG, P, Quat, TH, V, Vec3};
use ego_ekf::{CameraConfig, EgoEkf, FilterConfig, FlowConfig, GripParams};
use support::monte_carlo::{Anees, Summary, draw, nees1, yaw_error};
use support::{Rng, Truth, attitude_error, flow_optics, nees3};
use vslam_core::geometry::Rot3;
use vslam_core::scale::CameraMotion;

const RUNS: usize = 25;
const SECONDS: u64 = 60;
/// IMU steps per camera frame (10 Hz).
const FRAME_EVERY: u64 = 25;
/// Ceiling distance: the unit of the camera's `t/d`, m.
const D: f64 = 2.4;
/// Relative standard deviation of a pair's metric scale.
const SCALE_REL_STD: f64 = 0.01;

/// Runs: [`RUNS`], or `MC_RUNS` from the environment.
fn runs() -> usize {
    std::env::var("MC_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(RUNS)
}

/// A camera turned and offset from the IMU (so the mounting matters).
fn camera() -> CameraConfig {
    CameraConfig {
        q_ic: Quat::from_euler_angles(0.1, -0.05, 1.2),
        t_ic: Vec3::new(0.05, -0.02, 0.08),
        ..CameraConfig::default()
    }
}

fn config() -> FilterConfig {
    FilterConfig {
        grip: GripParams::new(0.95, 0.005, 0.001, 10.83, 2.0).unwrap(),
        floor: None,
        camera: Some(camera()),
        flow: Some(FlowConfig {
            base_std: 0.005,
            relative_std: 1.0e-6,
            ..FlowConfig::new(flow_optics())
        }),
        ..FilterConfig::default()
    }
}

/// The camera's motion from `a` to `b` (true IMU poses) through the
/// mounting, `T_C0C1 = T_IC^-1 T_I0I1 T_IC`, with noise drawn from what the
/// filter is told (see the module doc); and the pair's scale with its
/// variance.
fn camera_motion(
    a: &Truth,
    b: &Truth,
    c: &CameraConfig,
    rng: &mut Rng,
) -> (CameraMotion, f32, f32) {
    let q_rel = a.q_wb.inverse() * b.q_wb;
    let t_rel = a.q_wb.inverse() * (b.p_wb - a.p_wb);
    let q_c = c.q_ic.inverse() * q_rel * c.q_ic;
    let t_c = (c.q_ic.inverse() * (q_rel * c.t_ic + t_rel - c.t_ic)).cast::<f64>();
    let q_c = q_c * Quat::from_scaled_axis(rng.vec3(c.rotation_std as f64));
    let rel = c.translation_rel_std as f64 * t_c.norm();
    let floor = c.translation_std as f64;
    let dir_std = (rel * rel + floor * floor).sqrt() / D;
    let u = t_c / D + rng.vec3(dir_std).cast::<f64>();
    let var_s = (SCALE_REL_STD * D).powi(2);
    let s = D + var_s.sqrt() * rng.normal();
    let motion =
        CameraMotion::new(a.t, b.t, Rot3::from(q_c), u.cast::<f32>(), 200, 0.9, 0.3).unwrap();
    (motion, s as f32, var_s as f32)
}

/// What the Monte Carlo runs gave.
struct Outcome {
    /// Per block: position, velocity, attitude, yaw, gyro scale factor.
    summaries: Vec<Summary>,
    zupts: u32,
    flows: u32,
    pairs: u32,
    /// Mean NIS of the fused camera pairs (6 degrees of freedom).
    camera_nis: f64,
    /// Checkpoints `(run, step)` whose covariance was not positive definite.
    not_pd: Vec<(usize, u64)>,
}

impl Outcome {
    fn block(&self, name: &str) -> &Summary {
        self.summaries.iter().find(|s| s.name == name).unwrap()
    }
}

/// `runs` seeded runs of `c` from seed `seed0`, checkpoints every second.
fn monte_carlo(c: &FilterConfig, runs: usize, seed0: u64) -> Outcome {
    let cam = c.camera.unwrap_or_default();
    // The gyro scale factor's block last: left out (and its value with
    // it) when the filter does not estimate it.
    let blocks = [
        ("position", 3),
        ("velocity", 3),
        ("attitude", 3),
        ("yaw", 1),
        ("gyro scale", 1),
    ];
    let n_blocks = if c.imu.estimate_gyro_scale { 5 } else { 4 };
    let mut anees = Anees::new(&blocks[..n_blocks], SECONDS as usize, runs);
    let (mut zupts, mut flows, mut pairs, mut gated) = (0, 0, 0, 0);
    let (mut nis_sum, mut nis_n) = (0.0f64, 0u32);
    let mut not_pd = Vec::new();
    for run in 0..runs {
        let seed = seed0 + run as u64;
        let (mut sim, start) = draw(seed, c);
        sim.with_flow = c.flow.is_some();
        let mut cam_rng = Rng::new(seed ^ 0xCA3E);
        let mut f = EgoEkf::new(*c).unwrap();
        f.start(&start).unwrap();
        let mut previous = sim.truth();
        for k in 1..=(SECONDS * 250) {
            let tick = sim.tick();
            f.propagate(&tick.imu).unwrap();
            if let Some(w) = tick.wheel {
                let _ = f.fuse_wheel(&w);
            }
            if let Some(fl) = tick.flow {
                let _ = f.fuse_flow(&fl);
            }
            if c.camera.is_some() && k % FRAME_EVERY == 0 {
                let (m, s, var_s) = camera_motion(&previous, &tick.truth, &cam, &mut cam_rng);
                if f.fuse_camera(&m, Some((s, var_s))).is_ok()
                    && let Some(status) = f.camera_status()
                {
                    nis_sum += status.nis as f64;
                    nis_n += 1;
                }
                previous = tick.truth;
            }
            if k % 250 == 0 {
                let s = f.state();
                let tr = &tick.truth;
                let p = f.covariance();
                let e_th = attitude_error(&s.q_wb, &tr.q_wb);
                let (e_yaw, var_yaw) = yaw_error(&e_th, &s.q_wb, p);
                let e_k = sim.gyro_scale - s.gyro_scale as f64;
                anees.add(
                    (k / 250) as usize - 1,
                    &[
                        nees3(&(tr.p_wb - s.p_wb), p, P),
                        nees3(&(tr.v_wb - s.v_wb), p, V),
                        nees3(&e_th, p, TH),
                        nees1(e_yaw, var_yaw),
                        nees1(e_k, p[(KG, KG)] as f64),
                    ],
                );
                if !is_positive_definite(p) {
                    not_pd.push((run, k));
                }
            }
        }
        zupts += f.zupt_counts().fused();
        flows += f.flow_counts().fused();
        pairs += f.camera_counts().fused();
        gated += f.camera_counts().gated();
    }
    let camera_nis = nis_sum / f64::from(nis_n.max(1));
    println!(
        "{runs} runs x {SECONDS} s from seed {seed0}: zero-velocity updates {zupts}, flow \
         reports fused {flows}, camera pairs fused {pairs} (gated {gated}), their mean NIS \
         {camera_nis:.3} (6 dof); covariance not positive definite at {not_pd:?}"
    );
    Outcome {
        summaries: anees.summaries(),
        zupts,
        flows,
        pairs,
        camera_nis,
        not_pd,
    }
}

/// The checks every configuration passes: positive definite, the aids
/// fused, the camera's NIS (if any) and the ANEES of `strict` blocks
/// inside the bounds with 80 % of the checkpoints inside.
fn check(o: &Outcome, runs: usize, strict: &[&str], camera: bool) {
    assert!(
        o.not_pd.is_empty(),
        "covariance not positive definite at {:?}",
        o.not_pd
    );
    assert!(o.zupts > 100, "zero-velocity updates must run at the stops");
    assert!(o.flows as usize > runs * 1000, "the flow must be fused");
    if camera {
        // 600 frames a run; the still ones and the first after each stop
        // only take the clone.
        assert!(
            o.pairs as usize > runs * 300,
            "camera pairs fused: {}",
            o.pairs
        );
        assert!(
            (5.4..=6.0 + 1.96 * (12.0 / f64::from(o.pairs)).sqrt()).contains(&o.camera_nis),
            "camera NIS {:.3}",
            o.camera_nis
        );
    }
    for name in strict {
        let s = o.block(name);
        assert!(
            s.passes(0.8),
            "{name}: time-averaged ANEES {:.2} in [{:.2}, {:.2}]? inside {}/{}",
            s.mean,
            s.lo,
            s.hi,
            s.inside,
            s.checkpoints
        );
    }
}

// Measured (cargo test -p ego-ekf --release --test fused_consistency --
// --nocapture): 25 runs, bounds [2.12, 4.03] (3 dof) and [0.52, 1.63]
// (1 dof): position 3.13 (59/60 inside), velocity 2.47 (40/60), attitude
// 2.81 (58/60), yaw 1.23 (60/60); camera NIS 5.76 over 12043 pairs. With
// MC_RUNS=200, bounds [2.67, 3.35] and [0.81, 1.21]: position 2.91
// (57/60), velocity 2.29 (5/60), attitude 2.58 (18/60), yaw 0.90 (60/60);
// camera NIS 5.80 over 97301 pairs. Those are with the heading constraint
// off; with it on (the default since 2026-12-07), 25 runs: position 3.08
// (59/60), velocity 2.40 (37/60), attitude 2.68 (57/60), yaw 1.14 (60/60);
// camera NIS 5.76 over 11960 pairs.
#[test]
fn fused_filter_average_nees_lies_inside_chi_square_bounds() {
    let runs = runs();
    let o = monte_carlo(&config(), runs, 1000);
    check(&o, runs, &["position", "attitude", "yaw"], true);
    let v = o.block("velocity");
    assert!(
        v.mean >= v.lo && v.mean <= v.hi,
        "velocity: time-averaged ANEES {:.2} outside [{:.2}, {:.2}]",
        v.mean,
        v.lo,
        v.hi
    );
    assert!(
        v.above as f64 <= 0.2 * v.checkpoints as f64,
        "velocity: ANEES above the bound {}/{} times",
        v.above,
        v.checkpoints
    );
}

// The gyro's z scale factor estimated (ImuConfig::estimate_gyro_scale),
// the truth's drawn from its prior (2 %) with its random walk. Measured
// (25 runs): position 3.14 (58/60), velocity 2.38 (41/60), attitude 2.67
// (54/60), yaw 0.99 (60/60), gyro scale 0.80 (51/60, bounds [0.52, 1.63]);
// MC_RUNS=200: gyro scale 0.70, yaw 0.87 (conservative). With the heading
// constraint on (the default since 2026-12-07), 25 runs: position 3.17
// (58/60), velocity 2.40 (43/60), attitude 2.70 (57/60), yaw 1.08 (60/60),
// gyro scale 0.79 (51/60). Without the camera
// the same runs are overconfident (200 runs: gyro scale 1.65, yaw 1.58,
// position 3.74; two covariances not positive definite): the scale
// factor's prior makes the yaw uncertain by up to 2 % of the angle turned,
// and the filter without the camera's rotation is overconfident whenever
// its yaw is that uncertain, scale factor or not (module doc; with the
// state off and a yaw prior of 0.06 rad instead of 0.01: yaw ANEES 3.23,
// position 6.11).
#[test]
fn fused_filter_with_gyro_scale_is_consistent() {
    let runs = runs();
    let mut c = config();
    c.imu.estimate_gyro_scale = true;
    let o = monte_carlo(&c, runs, 1000);
    check(
        &o,
        runs,
        &["position", "attitude", "yaw", "gyro scale"],
        true,
    );
    let v = o.block("velocity");
    assert!(v.mean >= v.lo && v.mean <= v.hi && v.above as f64 <= 0.2 * v.checkpoints as f64);
}

/// The first seed: `MC_SEED` from the environment, else 1000.
fn seed0() -> u64 {
    std::env::var("MC_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000)
}

/// Prints each block's ANEES as the module doc quotes them.
fn print_summaries(o: &Outcome) {
    for s in &o.summaries {
        println!(
            "{}: ANEES {:.2} in [{:.2}, {:.2}], {}/{} inside",
            s.name, s.mean, s.lo, s.hi, s.inside, s.checkpoints
        );
    }
}

// The constraints' noise closer to the simulation's exact ones (lateral
// 0.2 mm/s, zero-velocity 0.5 mm/s), the heading constrained
// (`ImuConfig::constrain_heading`, `ego_ekf::observability`): the
// heading, which nothing observes, is where a filter that learns spurious
// yaw information shows it (module doc). Measured with `MC_RUNS=200
// MC_SEED=S cargo test -p ego-ekf --release --test fused_consistency --
// --ignored tight --nocapture`, S = 1000, 2000: yaw ANEES 0.84, 0.91
// (bounds [0.81, 1.21]), position 3.02, 3.20 ([2.67, 3.35]); unconstrained
// (the constraint off) yaw 1.12, 1.26 and position 3.33, 3.57 (module doc).
// Ignored for its run time at 200 runs.
#[test]
#[ignore = "a measurement: run with MC_RUNS=200 and MC_SEED (comment above)"]
fn tight_constraint_noise_keeps_the_constrained_heading_consistent() {
    let runs = runs();
    let mut c = config();
    c.grip = GripParams::new(0.95, 0.005, 0.0002, 10.83, 2.0).unwrap();
    c.zupt.velocity_std = 0.0005;
    c.imu.constrain_heading = true;
    let o = monte_carlo(&c, runs, seed0());
    print_summaries(&o);
    check(&o, runs, &["yaw"], true);
}

// The gyro's scale factor estimated without the camera (issue 24 part 2),
// the heading constrained or not (`MC_CONSTRAIN=1`). Measured with
// `MC_RUNS=200 [MC_CONSTRAIN=1] cargo test -p ego-ekf --release --test
// fused_consistency -- --ignored without_camera --nocapture`:
// unconstrained yaw ANEES 1.59, gyro scale 1.62, position 4.36 and the
// covariance not positive definite at 7 checkpoints of 6 runs (the
// assertion fails); constrained yaw 0.85, gyro scale 0.93, position 2.91, not positive
// definite at 39 checkpoints of 23 runs. The failing direction is the
// pose's yaw minus the clone's at a stop: the zero-velocity update holds
// the two within its attitude noise while their common heading variance,
// now kept, is about 5e-3 rad^2, a correlation within 1e-6 of one that
// the f32 Cholesky of the check cannot factor. Asserted: the scale
// factor and the yaw are not overconfident (constrained: passes;
// unconstrained: fails).
#[test]
#[ignore = "a measurement: run with MC_RUNS=200 (comment above)"]
fn gyro_scale_without_camera_is_consistent() {
    let runs = runs();
    let mut c = config();
    c.imu.estimate_gyro_scale = true;
    c.imu.constrain_heading = std::env::var("MC_CONSTRAIN").is_ok_and(|v| v == "1");
    c.camera = None;
    let o = monte_carlo(&c, runs, seed0());
    print_summaries(&o);
    let mut runs_not_pd: Vec<usize> = o.not_pd.iter().map(|(run, _)| *run).collect();
    runs_not_pd.dedup();
    println!(
        "constrained {}: covariance not positive definite at {} checkpoints of {} runs",
        c.imu.constrain_heading,
        o.not_pd.len(),
        runs_not_pd.len()
    );
    // Not overconfident: the time average inside the bounds and at most a
    // fifth of the checkpoints above the upper one (the constrained yaw is
    // conservative early on: below the lower bound at 17 of 60).
    for name in ["yaw", "gyro scale"] {
        let s = o.block(name);
        assert!(
            s.mean >= s.lo && s.mean <= s.hi && s.above as f64 <= 0.2 * s.checkpoints as f64,
            "{name}: ANEES {:.2} in [{:.2}, {:.2}], {} of {} above",
            s.mean,
            s.lo,
            s.hi,
            s.above,
            s.checkpoints
        );
    }
}
