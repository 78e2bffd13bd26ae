//! The wheel distance the scale pipeline takes, in the filter's best
//! knowledge of the wheels.
//!
//! The odometry integrates the ticks with the nominal radii of the robot
//! description; the filter learns the radii on firm floors and, on
//! low-grip floors, the floor's expected slip `s` (the ground moves
//! `(1 - s)` times the wheels' rolling distance: seed 004 claim 5,
//! [`ego_ekf::grip::GripParams::slip`]). The wheel transaction `Tw` of the
//! scale pipeline (seed 000, `s = Tw / |T|`) is the camera's metric scale
//! when the wheels are the chosen source, so it takes the same
//! correction: each odometry step's displacement is multiplied by the
//! ratio of the learned to the nominal rolling distance of its wheel
//! rates, and by `1 - s`. Without that, a carpet's wheel over-count went
//! into the camera's translation that the filter fuses, and pulled the
//! learned slip and radii back towards the uncorrected wheels.

use ego_ekf::grip::MAX_SLIP;
use vslam_core::sensors::{OdometryDelta, WheelRates};

/// The smallest learned-to-nominal rolling-distance ratio taken (the
/// learned radii 20 % below the nominal ones); outside `[0.8, 1.2]` the
/// radii are not corrected.
const MIN_RADIUS_RATIO: f32 = 0.8;
/// The largest learned-to-nominal rolling-distance ratio taken.
const MAX_RADIUS_RATIO: f32 = 1.2;

/// `delta` of the wheel `rates` integrated with the `nominal` radii
/// `[left, right]` (m), corrected to the `learned` radii and the floor's
/// expected `slip`. The forward rolling distance decides the radius ratio;
/// when the wheels turn against each other (a turn in place) and the
/// forward rolling distance is below a tenth of either wheel's, the mean
/// radius ratio is used. A radius ratio outside `[0.8, 1.2]` or from
/// non-finite inputs leaves the radii uncorrected; a slip outside
/// `[0, MAX_SLIP]` (the filter's range, [`ego_ekf::grip::MAX_SLIP`]) or
/// non-finite leaves the slip out.
pub fn corrected_delta(
    delta: &OdometryDelta,
    rates: &WheelRates,
    nominal: [f32; 2],
    learned: [f32; 2],
    slip: f32,
) -> OdometryDelta {
    let [n_l, n_r] = nominal;
    let [l_l, l_r] = learned;
    let (w_l, w_r) = (rates.left(), rates.right());
    let nominal_roll = n_l * w_l + n_r * w_r;
    let scale = libm::fabsf(n_l * w_l).max(libm::fabsf(n_r * w_r));
    let radius_ratio = if libm::fabsf(nominal_roll) > 0.1 * scale {
        (l_l * w_l + l_r * w_r) / nominal_roll
    } else {
        (l_l + l_r) / (n_l + n_r)
    };
    let radius_ratio = if (MIN_RADIUS_RATIO..=MAX_RADIUS_RATIO).contains(&radius_ratio) {
        radius_ratio
    } else {
        1.0
    };
    let slip = if (0.0..=MAX_SLIP).contains(&slip) {
        slip
    } else {
        0.0
    };
    let ratio = radius_ratio * (1.0 - slip);
    if ratio == 1.0 {
        return *delta;
    }
    OdometryDelta {
        translation: delta.translation * ratio,
        dyaw: delta.dyaw * ratio,
        path_length: delta.path_length * ratio,
        ..*delta
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vslam_core::Timestamp;
    use vslam_core::geometry::Vec3;

    fn delta() -> OdometryDelta {
        OdometryDelta {
            t0: Timestamp(0),
            t1: Timestamp(20_000_000),
            translation: Vec3::new(0.006, 0.0, 0.0),
            dyaw: 0.001,
            path_length: 0.006,
        }
    }

    fn rates(l: f32, r: f32) -> WheelRates {
        WheelRates::new(Timestamp(20_000_000), l, r).unwrap()
    }

    #[test]
    fn nominal_radii_and_no_slip_change_nothing() {
        let d = delta();
        let c = corrected_delta(&d, &rates(8.0, 9.0), [0.035, 0.035], [0.035, 0.035], 0.0);
        assert_eq!(c, d);
    }

    #[test]
    fn slip_and_larger_learned_radii_scale_the_step() {
        let d = delta();
        // Both radii 2 % larger, 5 % slip: 1.02 * 0.95 = 0.969.
        let c = corrected_delta(&d, &rates(8.0, 8.0), [0.035, 0.035], [0.0357, 0.0357], 0.05);
        assert!((c.path_length / d.path_length - 0.969).abs() < 1e-5);
        assert!((c.translation.x / d.translation.x - 0.969).abs() < 1e-5);
        assert!((c.dyaw / d.dyaw - 0.969).abs() < 1e-5);
        assert_eq!((c.t0, c.t1), (d.t0, d.t1));
    }

    #[test]
    fn the_faster_wheel_weighs_more_and_a_turn_in_place_uses_the_mean() {
        let d = delta();
        // Only the left wheel's radius is 4 % off; the left wheel turns
        // three times as fast: (3 * 1.04 + 1) / 4 = 1.03.
        let c = corrected_delta(&d, &rates(9.0, 3.0), [0.035, 0.035], [0.0364, 0.035], 0.0);
        assert!((c.path_length / d.path_length - 1.03).abs() < 1e-5);
        // Wheels against each other: the mean ratio 1.02.
        let c = corrected_delta(&d, &rates(5.0, -5.0), [0.035, 0.035], [0.0364, 0.035], 0.0);
        assert!((c.path_length / d.path_length - 1.02).abs() < 1e-5);
    }

    #[test]
    fn implausible_radii_or_slips_are_left_out() {
        let d = delta();
        let r = rates(8.0, 8.0);
        // Radii 43 % off: not taken; the slip still is.
        assert_eq!(corrected_delta(&d, &r, [0.035; 2], [0.05; 2], 0.0), d);
        let c = corrected_delta(&d, &r, [0.035; 2], [0.05; 2], 0.1);
        assert!((c.path_length / d.path_length - 0.9).abs() < 1e-5);
        // A large slip the filter may learn is taken whole.
        let c = corrected_delta(&d, &r, [0.035; 2], [0.035; 2], 0.5);
        assert!((c.path_length / d.path_length - 0.5).abs() < 1e-5);
        // Outside the filter's range or not finite: left out.
        assert_eq!(corrected_delta(&d, &r, [0.035; 2], [0.035; 2], 0.6), d);
        assert_eq!(corrected_delta(&d, &r, [0.035; 2], [0.035; 2], -0.1), d);
        assert_eq!(corrected_delta(&d, &r, [0.035; 2], [0.035; 2], f32::NAN), d);
        assert_eq!(corrected_delta(&d, &r, [0.035; 2], [f32::NAN; 2], 0.0), d);
        assert_eq!(corrected_delta(&d, &r, [0.0; 2], [0.035; 2], 0.0), d);
    }
}
