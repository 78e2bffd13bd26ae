//! The unobservable heading as a null space: rotating the whole world about
//! gravity by `e` changes nothing the IMU, the wheels or the zero-velocity
//! update measure. In the error state (body-frame attitude error, Solà
//! 2017, sec. 5.3) that is the direction `N`: `dtheta = R^T e_z`,
//! `dp = e_z x p`, `dv = e_z x v`, `dg = e_z x g`, the clone's pose the
//! same, zero on the biases and the robot states. Every measurement
//! Jacobian must have `H N = 0` at the estimate it is evaluated at, and the
//! transition must carry `N` along: `F N_k = N_{k+1}` (Hesch et al.,
//! "Consistency analysis and improvement of vision-aided inertial
//! navigation", IEEE T-RO 2014, sec. III). These tests evaluate both at a
//! state that is tilted, moving and turning, with nonzero biases; and the
//! observability constraint (`ego_ekf::observability`): the covariance's
//! heading direction moved to the corrected estimate after an update, and
//! the zero-velocity update projected to be blind to it.

use ego_ekf::GripParams;
use ego_ekf::config::ZuptConfig;
use ego_ekf::covariance::decouple_clone;
use ego_ekf::observability::{CloneCoupling, HEADING_HOLD_SLACK, project, reanchor};
use ego_ekf::propagate::{Transition, propagate_nominal};
use ego_ekf::state::{
    CP, CTH, Covariance, DIM, ErrorState, G, NominalState, P, Quat, STANDARD_GRAVITY, TH, V, Vec3,
};
use ego_ekf::wheel::model::{FORWARD, LATERAL, VERTICAL, wheel_rows};
use ego_ekf::zupt::model::zupt_measurement;
use vslam_core::Timestamp;
use vslam_core::sensors::WheelRates;

/// The yaw-about-gravity direction `N` at the estimate `x`.
fn yaw_direction(x: &NominalState) -> ErrorState {
    let ez = Vec3::z();
    let mut n = ErrorState::zeros();
    n.fixed_rows_mut::<3>(P).copy_from(&ez.cross(&x.p_wb));
    n.fixed_rows_mut::<3>(V).copy_from(&ez.cross(&x.v_wb));
    n.fixed_rows_mut::<3>(TH)
        .copy_from(&(x.q_wb.inverse() * ez));
    n.fixed_rows_mut::<3>(G).copy_from(&ez.cross(&x.gravity));
    n.fixed_rows_mut::<3>(CP)
        .copy_from(&ez.cross(&x.clone_p_wb));
    n.fixed_rows_mut::<3>(CTH)
        .copy_from(&(x.clone_q_wb.inverse() * ez));
    n
}

/// The world rotated about gravity by `angle`: what no sensor can tell
/// from `x`.
fn yawed(x: &NominalState, angle: f32) -> NominalState {
    let r = Quat::from_axis_angle(&Vec3::z_axis(), angle);
    NominalState {
        p_wb: r * x.p_wb,
        v_wb: r * x.v_wb,
        q_wb: r * x.q_wb,
        gravity: r * x.gravity,
        clone_p_wb: r * x.clone_p_wb,
        clone_q_wb: r * x.clone_q_wb,
        ..*x
    }
}

/// A tilted, moving, turning state with nonzero biases and a robot frame
/// off the body's.
fn state() -> NominalState {
    let q_wb = Quat::from_euler_angles(0.12, -0.08, 0.7);
    NominalState {
        p_wb: Vec3::new(1.3, -0.7, 0.05),
        v_wb: q_wb * Vec3::new(0.3, 0.02, -0.01),
        q_wb,
        accel_bias: Vec3::new(0.05, -0.03, 0.02),
        gyro_bias: Vec3::new(0.004, -0.002, 0.003),
        gravity: Vec3::new(0.02, -0.01, -STANDARD_GRAVITY),
        gyro_scale: 0.01,
        clone_p_wb: Vec3::new(1.1, -0.6, 0.04),
        clone_q_wb: Quat::from_euler_angles(0.11, -0.07, 0.65),
        p_bl: Vec3::new(0.01, 0.115, -0.06),
        p_br: Vec3::new(-0.01, -0.115, -0.06),
        q_rb: Quat::from_euler_angles(0.03, 0.05, -0.02),
        radius_left: 0.035,
        radius_right: 0.036,
    }
}

#[test]
fn the_wheel_rows_do_not_see_the_heading() {
    let x = state();
    let gyro = Vec3::new(0.05, -0.02, 0.6);
    let rates = WheelRates::new(Timestamp::from_nanos(0), 7.0, 10.0).unwrap();
    let grip = GripParams::new(0.95, 0.005, 0.001, 10.83, 2.0).unwrap();
    let m = wheel_rows(&x, &gyro, &rates, &grip).measurement();
    let hn = m.h * yaw_direction(&x);
    // The measurement function itself is invariant: the residual of the
    // yawed world is the residual's.
    let moved = wheel_rows(&yawed(&x, 0.01), &gyro, &rates, &grip).measurement();
    let change = (moved.residual - m.residual) / 0.01;
    println!("wheel H N (forward, differential, lateral, vertical): {hn:.2e}");
    println!("wheel dh/dyaw by differences: {change:.2e}");
    for r in [FORWARD, LATERAL, VERTICAL] {
        assert!(hn[r].abs() < 1e-5, "row {r}: {hn:.2e}");
        assert!(change[r].abs() < 1e-3, "row {r}: {change:.2e}");
    }
}

#[test]
fn the_zero_velocity_update_sees_the_heading_only_through_the_estimates() {
    // `H N` of the velocity rows is `e_z x v_hat` and of the position rows
    // `e_z x (p_hat - p_clone)`: zero when the estimate says the robot
    // stands still where it stopped, whatever the truth.
    let mut x = state();
    let m = zupt_measurement(&x, &ZuptConfig::default());
    let hn = m.h * yaw_direction(&x);
    println!("ZUPT H N at a moving estimate: {hn:.2e}");
    let ez = Vec3::z();
    let expected_v = ez.cross(&x.v_wb);
    let expected_p = ez.cross(&(x.p_wb - x.clone_p_wb));
    for k in 0..3 {
        assert!((hn[k] - expected_v[k]).abs() < 1e-6, "{hn:.2e}");
        assert!((hn[3 + k] - expected_p[k]).abs() < 1e-6, "{hn:.2e}");
        assert!(hn[6 + k].abs() < 1e-5, "attitude rows: {hn:.2e}");
    }
    x.v_wb = Vec3::zeros();
    x.clone_p_wb = x.p_wb;
    let hn = m.h * yaw_direction(&x);
    let hn_still = zupt_measurement(&x, &ZuptConfig::default()).h * yaw_direction(&x);
    println!("ZUPT H N at a still estimate: {hn_still:.2e}");
    assert!(hn_still.amax() < 1e-5, "{hn_still:.2e}");
    assert!(hn.amax() < 1e-5, "{hn:.2e}");
}

#[test]
fn the_transition_carries_the_heading_direction_along() {
    let mut x = state();
    let dt = 0.004;
    let raw_gyro = Vec3::new(0.05, -0.02, 0.6);
    let raw_accel = Vec3::new(0.4, 1.1, 9.7);
    let gyro = x.corrected_gyro(&raw_gyro);
    let accel = raw_accel - x.accel_bias;
    let n0 = yaw_direction(&x);
    let r_wb = x.q_wb.to_rotation_matrix().into_inner();
    let f = Transition::new(&r_wb, &accel, &gyro, dt)
        .with_gyro_scale(&x.gyro_scale_jacobian(&gyro))
        .dense();
    let a_w = x.q_wb * accel + x.gravity;
    propagate_nominal(&mut x, &accel, &gyro, dt);
    let n1 = yaw_direction(&x);
    let d = f * n0 - n1;
    println!(
        "F N_k - N_k+1: p {:.2e}, v {:.2e}, theta {:.2e}, g {:.2e}, clone {:.2e}",
        d.fixed_rows::<3>(P).transpose(),
        d.fixed_rows::<3>(V).transpose(),
        d.fixed_rows::<3>(TH).transpose(),
        d.fixed_rows::<3>(G).transpose(),
        d.fixed_rows::<6>(CP).transpose(),
    );
    // The position's residual is the step's second-order term
    // `-e_z x a_w dt^2 / 2` (the transition's `F_ptheta` is first order).
    let second_order = -Vec3::z().cross(&a_w) * (0.5 * dt * dt);
    let dp = d.fixed_rows::<3>(P) - second_order;
    assert!(dp.amax() < 1e-6, "{dp:.2e}");
    let rest = d.fixed_rows::<{ DIM - V }>(V);
    assert!(rest.amax() < 1e-5, "{:.2e}", rest.transpose());
}

/// `N` moved by the error reset `G = I - [dtheta/2]x` of a correction
/// that turned the pose by `d_th` and the clone by `d_cth`.
fn reset_direction(n: &ErrorState, d_th: &Vec3, d_cth: &Vec3) -> ErrorState {
    let mut out = *n;
    for (block, d) in [(TH, d_th), (CTH, d_cth)] {
        let u = n.fixed_rows::<3>(block).into_owned();
        out.fixed_rows_mut::<3>(block)
            .copy_from(&(u - (d * 0.5).cross(&u)));
    }
    out
}

/// The unit eigenvector of the largest eigenvalue of `p`.
fn dominant(p: &Covariance) -> nalgebra::SVector<f64, DIM> {
    let e = nalgebra::SymmetricEigen::new(p.cast::<f64>());
    e.eigenvectors.column(e.eigenvalues.imax()).into_owned()
}

#[test]
fn reanchoring_carries_the_heading_direction_to_the_corrected_estimate() {
    // A covariance whose one large direction is the heading the update
    // was blind to (`G N` at the estimate before it), then an update's
    // correction of position, velocity, attitude (beyond the reset's
    // threshold), gravity and clone.
    let before = state();
    let mut after = before;
    after.p_wb += Vec3::new(0.01, -0.02, 0.003);
    after.v_wb += Vec3::new(0.004, -0.003, 0.001);
    let d_th = Vec3::new(0.002, -0.001, 0.003);
    after.q_wb = before.q_wb * Quat::from_scaled_axis(d_th);
    after.gravity += Vec3::new(1e-3, -2e-3, 1e-3);
    let d_cth = Vec3::new(-0.001, 0.0015, 0.0);
    after.clone_p_wb += Vec3::new(0.002, 0.001, 0.0);
    after.clone_q_wb = before.clone_q_wb * Quat::from_scaled_axis(d_cth);
    let m = reset_direction(&yaw_direction(&before), &d_th, &d_cth);
    let mut p = Covariance::identity() * 1e-6 + m * m.transpose() * 0.01;
    let unchanged = dominant(&p);
    reanchor(
        &mut p,
        &before,
        &after,
        CloneCoupling::Coupled,
        f32::INFINITY,
    );
    let n_a = yaw_direction(&after).cast::<f64>().normalize();
    let moved = dominant(&p);
    let off = 1.0 - moved.dot(&n_a).abs();
    let off_unchanged = 1.0 - unchanged.dot(&n_a).abs();
    println!("1 - |cos| to N(after): reanchored {off:.2e}, not {off_unchanged:.2e}");
    assert!(off < 1e-6, "{off:.2e}");
    assert!(off_unchanged > 1e-5, "{off_unchanged:.2e}");
    assert!((p - p.transpose()).amax() == 0.0);
}

/// An update's correction, as in the test above.
fn corrected(before: &NominalState) -> NominalState {
    let mut after = *before;
    after.p_wb += Vec3::new(0.01, -0.02, 0.003);
    after.v_wb += Vec3::new(0.004, -0.003, 0.001);
    after.q_wb = before.q_wb * Quat::from_scaled_axis(Vec3::new(0.002, -0.001, 0.003));
    after
}

#[test]
fn reanchoring_leaves_a_decoupled_clone_decoupled() {
    // While the clone waits for its next use its rows are zero outside its
    // own block, and the propagation skips them: the re-anchoring must not
    // couple it (its part of `N` is the pose's when it is copied), even
    // when the clone's estimate moved.
    let before = state();
    let mut after = corrected(&before);
    after.clone_p_wb += Vec3::new(0.002, 0.001, 0.0);
    let m = yaw_direction(&before);
    let mut p = Covariance::identity() * 1e-6 + m * m.transpose() * 0.01;
    decouple_clone(&mut p);
    let mut coupled = p;
    reanchor(
        &mut p,
        &before,
        &after,
        CloneCoupling::Decoupled,
        f32::INFINITY,
    );
    reanchor(
        &mut coupled,
        &before,
        &after,
        CloneCoupling::Coupled,
        f32::INFINITY,
    );
    let outside = |p: &Covariance| {
        (0..CP)
            .flat_map(|i| (CP..DIM).map(move |j| (i, j)))
            .map(|(i, j)| p[(i, j)].abs().max(p[(j, i)].abs()))
            .fold(0.0f32, f32::max)
    };
    println!(
        "clone rows outside its block: decoupled {:.2e}, as if coupled {:.2e}",
        outside(&p),
        outside(&coupled)
    );
    assert_eq!(outside(&p), 0.0);
    assert!(outside(&coupled) > 1e-6);
    // The rest moved as with the clone coupled.
    let rest = (p - coupled).fixed_view::<{ CP }, { CP }>(0, 0).amax();
    assert!(rest < 1e-9, "{rest:.2e}");
}

/// The bound of the tests below, rad^2 (0.2 rad).
const MAX_HEADING_VAR: f32 = 0.04;

/// Re-anchors `p` from `before` to `after` with the heading bounded at
/// [`MAX_HEADING_VAR`], and gives the heading's variance after it (along
/// `N(after)`'s attitude part).
fn held_heading_variance(p: &mut Covariance, before: &NominalState, after: &NominalState) -> f32 {
    reanchor(p, before, after, CloneCoupling::Coupled, MAX_HEADING_VAR);
    let n_a = yaw_direction(after);
    let u = n_a.fixed_rows::<3>(TH) / n_a.fixed_rows::<3>(TH).norm_squared();
    (u.transpose() * p.fixed_view::<3, 3>(TH, TH) * u).x
}

#[test]
fn the_heading_variance_is_held_at_its_bound() {
    // A heading known to 0.5 rad (nothing measures it) comes back to the
    // bound, along `N` only: what the measurements see is unchanged.
    let before = state();
    let after = corrected(&before);
    let m = reset_direction(&yaw_direction(&before), &Vec3::zeros(), &Vec3::zeros());
    let other = ErrorState::from_fn(|i, _| if i == V || i == TH + 1 { 0.01 } else { 0.0 });
    let mut p =
        Covariance::identity() * 1e-6 + m * m.transpose() * 0.25 + other * other.transpose();
    let s = held_heading_variance(&mut p, &before, &after);
    println!("heading variance after: {s:.5} rad^2 (bound {MAX_HEADING_VAR})");
    assert!((s - MAX_HEADING_VAR).abs() < 1e-4 * MAX_HEADING_VAR, "{s}");
    // Orthogonal to the heading direction (a direction no measurement is
    // blind to), the variance is what it was.
    let w = other.normalize();
    let n_a = yaw_direction(&after);
    let w = w - n_a * (n_a.dot(&w) / n_a.norm_squared());
    let before_var =
        (w.transpose() * (Covariance::identity() * 1e-6 + other * other.transpose()) * w).x;
    let after_var = (w.transpose() * p * w).x;
    println!("a measured direction's variance: {before_var:.3e} -> {after_var:.3e}");
    assert!(
        (after_var - before_var).abs() < 0.01 * before_var,
        "{before_var} {after_var}"
    );
    assert!((p - p.transpose()).amax() == 0.0);
}

#[test]
fn a_heading_variance_within_the_slack_is_left_alone() {
    // 5 % above the bound (inside `HEADING_HOLD_SLACK`): not scaled back
    // yet; 15 % above: back at the bound.
    let before = state();
    let after = corrected(&before);
    let m = reset_direction(&yaw_direction(&before), &Vec3::zeros(), &Vec3::zeros());
    let held = |over: f32| {
        let mut p = Covariance::identity() * 1e-6 + m * m.transpose() * (MAX_HEADING_VAR * over);
        held_heading_variance(&mut p, &before, &after) / MAX_HEADING_VAR
    };
    let (within, beyond) = (held(1.05), held(1.15));
    println!("heading variance over the bound: 1.05 -> {within:.4}, 1.15 -> {beyond:.4}");
    assert!(within > 1.04 && within < HEADING_HOLD_SLACK, "{within}");
    assert!((beyond - 1.0).abs() < 1e-4, "{beyond}");
}

#[test]
fn the_projected_zero_velocity_update_is_blind_to_the_heading() {
    // At a moving estimate the update's rows see the heading
    // (`e_z x v_hat`); projected, they do not, and only the attitude
    // columns changed.
    let x = state();
    let plain = zupt_measurement(&x, &ZuptConfig::default());
    let mut m = plain;
    project(&mut m, &x);
    let n = yaw_direction(&x);
    let before = (plain.h * n).amax();
    let after = (m.h * n).amax();
    println!("ZUPT |H N|: {before:.2e}, projected {after:.2e}");
    assert!(before > 1e-2, "{before:.2e}");
    assert!(after < 1e-6, "{after:.2e}");
    let mut diff = m.h - plain.h;
    diff.fixed_columns_mut::<3>(TH).fill(0.0);
    assert_eq!(diff.amax(), 0.0);
}
