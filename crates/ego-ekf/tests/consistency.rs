//! Monte Carlo consistency: seeded runs on simulated data with known truth
//! (differential-drive robot driving curves with stops; IMU at 250 Hz, wheel
//! rates at 50 Hz, zero-velocity updates while still). The run-averaged NEES
//! of position, velocity and attitude must lie inside the two-sided 95 %
//! chi-square bounds for `3 N` degrees of freedom divided by `N`.
//!
//! With wheels and IMU only, position and yaw are unobservable: their
//! covariance grows, and the NEES must still be consistent. The truth's
//! robot geometry, biases (with their random walks) and the start error are
//! drawn from the filter's priors.

mod support;

use ego_ekf::covariance::is_positive_definite;
use ego_ekf::{EgoEkf, FilterConfig, GripParams};
use support::monte_carlo::draw;
use support::{attitude_error, chi2_quantile, nees3};

const RUNS: usize = 25;
const SECONDS: u64 = 60;

fn config() -> FilterConfig {
    // Encoder-level wheel noise (1000 counts/rev at 50 Hz is ~3 mm/s); the
    // lateral constraint is exact in the simulation, its noise small. (With
    // the measured rates in the radius Jacobian the radii are biased low
    // and this test fails: position ANEES 48, velocity 15.)
    //
    // The floor constraint is off: the simulated floor is exactly flat and
    // the start height has an error drawn from the prior, while the
    // constraint models a real floor's unevenness (5 mm, 1 cm/s) around the
    // start height. With it on, the position ANEES is 3.27 but 57/60 inside
    // and the velocity ANEES 2.32 (38/60): the vertical errors are far
    // below the variances the unevenness allows.
    FilterConfig {
        grip: GripParams::new(0.95, 0.005, 0.001, 10.83, 2.0).unwrap(),
        floor: None,
        ..FilterConfig::default()
    }
}

// Measured (25 runs x 60 s; cargo test -p ego-ekf --release --test
// consistency -- --nocapture): time-averaged ANEES position 3.17 (60/60
// checkpoints inside), velocity 2.62 (52/60), attitude 2.83 (53/60),
// bounds [2.12, 4.03].
#[test]
fn average_nees_lies_inside_chi_square_bounds() {
    let c = config();
    let checkpoints = SECONDS as usize;
    let mut nees = vec![[0.0f64; 3]; checkpoints];
    let mut zupts = 0;
    let mut gated = 0;
    for run in 0..RUNS {
        let (mut sim, start) = draw(1000 + run as u64, &c);
        let mut f = EgoEkf::new(c).unwrap();
        f.start(&start).unwrap();
        for k in 1..=(SECONDS * 250) {
            let tick = sim.tick();
            f.propagate(&tick.imu).unwrap();
            if let Some(w) = tick.wheel {
                f.fuse_wheel(&w).unwrap();
            }
            if k % 250 == 0 {
                let s = f.state();
                let tr = &tick.truth;
                let e_p = tr.p_wb - s.p_wb;
                let e_v = tr.v_wb - s.v_wb;
                let e_th = attitude_error(&s.q_wb, &tr.q_wb);
                let p = f.covariance();
                let slot = &mut nees[(k / 250) as usize - 1];
                slot[0] += nees3(&e_p, p, ego_ekf::state::P);
                slot[1] += nees3(&e_v, p, ego_ekf::state::V);
                slot[2] += nees3(&e_th, p, ego_ekf::state::TH);
                assert!(is_positive_definite(p), "run {run} t {k}");
            }
        }
        zupts += f.zupt_counts().fused();
        gated += f.wheel_counts().gated();
        assert_eq!(f.imu_counts().fused() as u64, SECONDS * 250);
    }
    let n = RUNS as f64;
    let lo = chi2_quantile(3.0 * n, -1.96) / n;
    let hi = chi2_quantile(3.0 * n, 1.96) / n;
    let names = ["position", "velocity", "attitude"];
    println!("ANEES bounds [{lo:.2}, {hi:.2}], zupts {zupts}, gated {gated}");
    for (b, name) in names.iter().enumerate() {
        let series: Vec<f64> = nees.iter().map(|s| s[b] / n).collect();
        let inside = series.iter().filter(|v| **v >= lo && **v <= hi).count();
        let mean = series.iter().sum::<f64>() / series.len() as f64;
        println!(
            "{name}: mean ANEES {mean:.2}, inside {inside}/{}; series {:?}",
            series.len(),
            series
                .iter()
                .map(|v| (v * 100.0).round() / 100.0)
                .collect::<Vec<_>>()
        );
    }
    assert!(zupts > 100, "zero-velocity updates must run at the stops");
    for (b, name) in names.iter().enumerate() {
        let series: Vec<f64> = nees.iter().map(|s| s[b] / n).collect();
        let inside = series.iter().filter(|v| **v >= lo && **v <= hi).count();
        let mean = series.iter().sum::<f64>() / series.len() as f64;
        assert!(
            mean >= lo && mean <= hi,
            "{name}: time-averaged ANEES {mean:.2} outside [{lo:.2}, {hi:.2}]"
        );
        assert!(
            inside as f64 >= 0.8 * series.len() as f64,
            "{name}: ANEES inside the bounds only {inside}/{} times",
            series.len()
        );
    }
}
