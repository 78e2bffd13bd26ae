use super::*;

fn state(half_track: f32) -> NominalState {
    let mut x = *crate::EgoEkf::new(crate::FilterConfig::default())
        .unwrap_or_else(|_| unreachable!())
        .state();
    x.p_bl = Vec3::new(0.0, half_track, 0.0);
    x.p_br = Vec3::new(0.0, -half_track, 0.0);
    x.radius_left = 0.1;
    x.radius_right = 0.1;
    x
}

fn rates(k: u64, left: f32, right: f32) -> WheelRates {
    WheelRates::new(Timestamp(k * 100_000_000), left, right).unwrap_or_else(|_| unreachable!())
}

/// Ten IMU steps of 10 ms at the yaw rate `w` (plus the gyro offset `c`),
/// then a wheel sample at `0.3 m/s` with the speed difference `d`.
fn step(skid: &mut TrackScale, x: &NominalState, k: u64, w: f32, c: f32, d: f32) {
    for _ in 0..10 {
        skid.observe_imu(x, &Vec3::new(0.0, 0.0, w + c), 0.01);
    }
    let r = rates(k, (0.3 - 0.5 * d) / 0.1, (0.3 + 0.5 * d) / 0.1);
    skid.observe(x, &r, r.t(), 1.0);
}

/// Left and right turns at up to 0.5 rad/s on wheels that say 1.5 times
/// that over the filter's track, a gyro offset of 5 mrad/s: the effective
/// track is 1.5 times the kinematic one, the offset is told apart.
#[test]
fn learns_a_wider_effective_track_and_the_gyro_offset() {
    let mut skid = TrackScale::new(SkidConfig::new(0.5, 1.0));
    let (b, x) = (0.5f32, state(0.25));
    for k in 0..400u64 {
        let w = 0.5 * libm::sinf(k as f32 * 0.1);
        step(&mut skid, &x, k, w, 0.005, 1.5 * b * w);
    }
    let e = skid.estimate(b);
    assert!((e.chi - 1.5).abs() < 0.01, "{e:?}");
    assert!((e.gyro_offset - 0.005).abs() < 1e-3, "{e:?}");
    assert!(
        e.chi_std < 0.05 && e.updates == 399 && e.downweighted == 0,
        "{e:?}"
    );
    // Applied: the same mean, the difference scaled to the filter's track.
    let a = skid.apply(&x, &rates(0, 2.0, 4.0));
    assert!((a.left() + a.right() - 6.0).abs() < 1e-4);
    assert!(((a.right() - a.left()) - 2.0 / 1.5).abs() < 0.02, "{a:?}");
}

/// Standing still teaches nothing, driving straight only the offset; a chi
/// beyond the bounds is clamped.
#[test]
fn straight_runs_keep_the_gain_and_bounds_hold() {
    let mut skid = TrackScale::new(SkidConfig::new(0.5, 1.0));
    let x = state(0.25);
    for k in 0..50u64 {
        step(&mut skid, &x, k, 0.0, 0.0, 0.0);
    }
    assert_eq!(skid.estimate(0.5).updates, 49);
    assert_eq!(skid.gain(), 1.0);
    assert!(skid.estimate(0.5).gyro_offset.abs() < 1e-6);
    for k in 50..53u64 {
        let r = rates(k, 0.0, 0.0);
        skid.observe(&x, &r, r.t(), 1.0);
    }
    assert_eq!(skid.estimate(0.5).updates, 49, "standing");
    // The wheels turn eight times as fast as the body (a spin on snow):
    // chi at its bound 4, the offset within its own.
    for k in 51..400u64 {
        let w = 0.3 * libm::sinf(k as f32 * 0.1);
        step(&mut skid, &x, k, w, 0.0, 8.0 * 0.5 * w);
    }
    let e = skid.estimate(0.5);
    assert!((e.chi - 4.0).abs() < 1e-3, "{e:?}");
    assert!(e.gyro_offset.abs() <= 0.05 + 1e-6, "{e:?}");
}

/// Degenerate geometry (no track, zero radii) and extreme rates neither
/// panic nor update; the rates it would fuse stay finite or unchanged.
#[test]
fn degenerate_inputs_are_refused_without_panic() {
    let mut skid = TrackScale::new(SkidConfig::new(0.5, 1.0));
    let mut x = state(0.0);
    for k in 0..20u64 {
        step(&mut skid, &x, k, 0.5, 0.0, 0.3);
    }
    assert_eq!(skid.estimate(0.5).updates, 0, "no track");
    x = state(0.25);
    x.radius_left = 0.0;
    skid.observe_imu(&x, &Vec3::new(0.0, 0.0, f32::NAN), 0.01);
    skid.observe_imu(&x, &Vec3::new(0.0, 0.0, 1.0), -1.0);
    let r = rates(30, f32::MAX, -f32::MAX);
    skid.observe(&x, &r, r.t(), 1.0);
    let a = skid.apply(&x, &r);
    assert!(a.left().is_finite() && a.right().is_finite());
    assert!(skid.gain().is_finite() && skid.gain() > 0.0);
}
