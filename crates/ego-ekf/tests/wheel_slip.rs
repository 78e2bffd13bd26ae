//! The floor's expected slip in the wheel measurement (seed 004 claim 5):
//! the forward and differential rows expect `(1 - s)` of the wheels'
//! speeds, and on a low-grip floor the radii are Schmidt consider
//! parameters (value and own covariance block unchanged, every other state
//! updated exactly as by the full update).

mod random_update;

use ego_ekf::covariance::is_positive_definite;
use ego_ekf::grip::GripParams;
use ego_ekf::state::RAD;
use ego_ekf::wheel::model::wheel_rows;
use ego_ekf::wheel::update::update;
use random_update::{Rng, random_covariance, random_state};
use vslam_core::Timestamp;
use vslam_core::sensors::WheelRates;

#[test]
fn expected_slip_scales_the_wheel_speeds_in_the_residual() {
    let mut rng = Rng(7);
    let x = random_state(&mut rng);
    let gyro = rng.vec3(0.5);
    let rates = WheelRates::new(Timestamp(0), 8.0, 9.0).unwrap();
    let plain = wheel_rows(&x, &gyro, &rates, &GripParams::default());
    let slip = 0.06;
    let slipping = wheel_rows(&x, &gyro, &rates, &GripParams::default().with_slip(slip));
    let mid = 0.5 * (x.radius_left * 8.0 + x.radius_right * 9.0);
    let diff = x.radius_right * 9.0 - x.radius_left * 8.0;
    // residual = (1 - s) * wheels - prediction.
    let d0 = slipping.residual[0] - plain.residual[0];
    let d1 = slipping.residual[1] - plain.residual[1];
    assert!((d0 + slip * mid).abs() < 1e-5, "{d0} vs {}", -slip * mid);
    assert!((d1 + slip * diff).abs() < 1e-5, "{d1} vs {}", -slip * diff);
    // The constraint rows and the Jacobian do not change.
    assert_eq!(slipping.residual[2], plain.residual[2]);
    assert_eq!(slipping.residual[3], plain.residual[3]);
    assert_eq!(slipping.h, plain.h);
    // Zero slip leaves the rows' bits.
    let zero = wheel_rows(&x, &gyro, &rates, &GripParams::default().with_slip(0.0));
    assert_eq!(zero, plain);
    // Out-of-range slips are clamped.
    assert_eq!(GripParams::default().with_slip(f32::NAN).slip(), 0.0);
    assert_eq!(GripParams::default().with_slip(-1.0).slip(), 0.0);
    assert_eq!(GripParams::default().with_slip(3.0).slip(), 0.5);
}

#[test]
fn held_radii_keep_their_value_and_block_and_nothing_else_changes() {
    for seed in 0..50u64 {
        let mut rng = Rng(seed);
        let x0 = random_state(&mut rng);
        let p0 = random_covariance(&mut rng);
        let gyro = rng.vec3(0.5);
        let rates = WheelRates::new(Timestamp(0), 8.0 + rng.next(), 8.0 + rng.next()).unwrap();
        let learning = GripParams::default().with_slip(0.03);
        let holding = learning.with_learn_radius(false);
        let rows_l = wheel_rows(&x0, &gyro, &rates, &learning);
        let rows_h = wheel_rows(&x0, &gyro, &rates, &holding);
        assert!(!rows_l.holds_radius() && rows_h.holds_radius());
        let (mut xl, mut pl) = (x0, p0);
        let (mut xh, mut ph) = (x0, p0);
        let ul = update(&mut xl, &mut pl, &rows_l, f32::INFINITY).unwrap();
        let uh = update(&mut xh, &mut ph, &rows_h, f32::INFINITY).unwrap();
        assert_eq!(
            ul, uh,
            "same innovation and variance (the radii's uncertainty included)"
        );
        // Held: the radii and their own block as before.
        assert_eq!(xh.radius_left, x0.radius_left);
        assert_eq!(xh.radius_right, x0.radius_right);
        for a in RAD..RAD + 2 {
            for b in RAD..RAD + 2 {
                assert_eq!(ph[(a, b)], p0[(a, b)]);
            }
        }
        // Learning: the radii moved (the rows see them).
        assert!(xl.radius_left != x0.radius_left || xl.radius_right != x0.radius_right);
        // Everything else is the full update's, bit for bit.
        let (mut xs, mut xf) = (xh, xl);
        xs.radius_left = 0.0;
        xs.radius_right = 0.0;
        xf.radius_left = 0.0;
        xf.radius_right = 0.0;
        assert_eq!(xs, xf, "seed {seed}");
        for i in 0..ph.nrows() {
            for j in 0..ph.ncols() {
                let held = (RAD..RAD + 2).contains(&i) && (RAD..RAD + 2).contains(&j);
                if !held {
                    assert_eq!(ph[(i, j)], pl[(i, j)], "seed {seed} ({i}, {j})");
                }
            }
        }
        assert!(is_positive_definite(&ph), "seed {seed}");
    }
}
