extern crate std;

use super::*;
use crate::estimate::{Aids, PoseCovariance};
use ego_ekf::events::JoltKind;
use ego_ekf::state::{Quat, Vec3};
use ego_ekf::surface::SurfaceKind;

/// A perfect estimate of a unicycle at `(x, y, yaw)`.
fn estimate(t: u64, x: f32, y: f32, yaw: f32) -> Estimate {
    Estimate {
        t: Timestamp(t),
        p_wb: Vec3::new(x, y, 0.0),
        q_wb: Quat::from_euler_angles(0.0, 0.0, yaw),
        v_b: Vec3::zeros(),
        yaw_rate: 0.0,
        covariance: PoseCovariance::zeros(),
        aids: Aids::default(),
    }
}

fn jolt(t: u64, kind: JoltKind) -> JoltEvent {
    JoltEvent {
        onset: Timestamp(t),
        t: Timestamp(t),
        magnitude: 3.0,
        explained: 2.0,
        surface: None,
        kind,
    }
}

/// Drives a unicycle at 50 Hz for `seconds` with `nav`; `jolts` are
/// `(time s, kind)` handed over at that time. Gives the path.
fn drive(
    nav: &mut Navigator<8>,
    seconds: f32,
    floor: Option<Floor>,
    jolts: &[(f32, JoltKind)],
) -> std::vec::Vec<(f32, f32, f32)> {
    let (mut x, mut y, mut yaw) = (0.0f32, 0.0f32, 0.0f32);
    let dt = 0.02;
    let mut path = std::vec::Vec::new();
    for k in 0..(seconds / dt) as u64 {
        let t = k * 20_000_000;
        let ts = k as f32 * dt;
        for (tj, kind) in jolts {
            if (ts - tj).abs() < dt * 0.5 {
                nav.on_imu(Timestamp(t), 3.0, Some(&jolt(t, *kind)));
            }
        }
        let (cmd, _) = nav.command(&estimate(t, x, y, yaw), floor.as_ref());
        x += cmd.v * libm::cosf(yaw) * dt;
        y += cmd.v * libm::sinf(yaw) * dt;
        yaw += cmd.w * dt;
        path.push((x, y, cmd.v));
    }
    path
}

#[test]
fn it_reaches_every_waypoint_of_a_route() {
    let route = [[2.0, 0.0], [2.0, 1.0], [0.0, 1.0]];
    let mut nav = Navigator::<8>::new(NavConfig::default(), Policy::FloorAware, &route).unwrap();
    let path = drive(&mut nav, 40.0, None, &[]);
    assert!(nav.is_done(), "reached {}", nav.reached());
    let (x, y, _) = *path.last().unwrap();
    assert!((x - 0.0).abs() < 0.05 && (y - 1.0).abs() < 0.05, "{x} {y}");
    assert_eq!(nav.stops(), 0);
}

#[test]
fn the_floor_aware_robot_drives_through_what_the_floor_explains_and_stops_at_an_obstacle() {
    let route = [[4.0, 0.0]];
    let mut nav = Navigator::<8>::new(NavConfig::default(), Policy::FloorAware, &route).unwrap();
    let jolts = [
        (3.0, JoltKind::ThresholdStrip),
        (4.0, JoltKind::SurfaceNoise),
    ];
    let path = drive(&mut nav, 6.0, None, &jolts);
    assert_eq!(nav.stops(), 0);
    assert!(path[200].2 > 0.25, "still cruising at 4 s: {:?}", path[200]);

    let mut nav = Navigator::<8>::new(NavConfig::default(), Policy::FloorAware, &route).unwrap();
    let path = drive(&mut nav, 40.0, None, &[(3.0, JoltKind::SuspectedObstacle)]);
    assert_eq!(nav.stops(), 1);
    // Standing, then backing off.
    assert_eq!(path[160].2, 0.0);
    assert!(path.iter().any(|p| p.2 < 0.0), "never backed off");
    // Round it: off to the left, then on to the waypoint.
    let widest = path.iter().map(|p| p.1).fold(0.0f32, f32::max);
    assert!(widest > 0.7, "{widest}");
    assert!(nav.is_done(), "reached {}", nav.reached());
}

#[test]
fn the_fixed_threshold_robot_stops_at_any_jolt_above_its_level() {
    let route = [[4.0, 0.0]];
    let policy = Policy::FixedThreshold { threshold: 2.0 };
    let mut nav = Navigator::<8>::new(NavConfig::default(), policy, &route).unwrap();
    // A calm floor, then one 3 m/s^2 bump the estimator calls a strip.
    let mut stops = 0;
    for k in 0..500u64 {
        let dev = if (200..205).contains(&k) { 3.0 } else { 0.1 };
        let t = Timestamp(k * 4_000_000);
        if nav
            .on_imu(t, dev, Some(&jolt(k * 4_000_000, JoltKind::ThresholdStrip)))
            .is_some()
        {
            stops += 1;
        }
    }
    assert_eq!(stops, 1);
    assert!(nav.is_stopped());
}

#[test]
fn grip_and_an_anticipated_floor_change_slow_the_floor_aware_robot() {
    let route = [[10.0, 0.0]];
    let carpet = Floor {
        grip: 0.7,
        ahead: None,
        kind: None,
        strip_jolt: 8.0,
    };
    let mut nav = Navigator::<8>::new(NavConfig::default(), Policy::FloorAware, &route).unwrap();
    let path = drive(&mut nav, 3.0, Some(carpet), &[]);
    let v = path.last().unwrap().2;
    assert!((v - 0.3 * 0.7 / 0.95).abs() < 1e-4, "{v}");
    let change = Floor {
        grip: 0.95,
        ahead: Some((0.3, 0.9)),
        kind: None,
        strip_jolt: 8.0,
    };
    let mut nav = Navigator::<8>::new(NavConfig::default(), Policy::FloorAware, &route).unwrap();
    let path = drive(&mut nav, 3.0, Some(change), &[]);
    assert_eq!(path.last().unwrap().2, 0.18);
    let policy = Policy::FixedThreshold { threshold: 2.0 };
    let mut nav = Navigator::<8>::new(NavConfig::default(), policy, &route).unwrap();
    let path = drive(&mut nav, 3.0, Some(carpet), &[]);
    assert_eq!(path.last().unwrap().2, 0.3, "no floor model: cruise speed");
}

#[test]
fn bad_routes_are_refused() {
    let c = NavConfig::default();
    assert_eq!(
        Navigator::<2>::new(c, Policy::FloorAware, &[]).err(),
        Some(NavError::RouteSize)
    );
    assert_eq!(
        Navigator::<2>::new(c, Policy::FloorAware, &[[0.0, 0.0]; 3]).err(),
        Some(NavError::RouteSize)
    );
    assert_eq!(
        Navigator::<2>::new(c, Policy::FloorAware, &[[f32::NAN, 0.0]]).err(),
        Some(NavError::Invalid)
    );
}

#[test]
fn a_suspected_obstacle_just_past_a_floor_change_is_the_boundary_strip() {
    let route = [[6.0, 0.0]];
    let mut nav = Navigator::<8>::new(NavConfig::default(), Policy::FloorAware, &route).unwrap();
    let floor = |kind| Floor {
        grip: 0.9,
        ahead: None,
        kind: Some(kind),
        strip_jolt: 8.0,
    };
    let mut x = 0.0f32;
    let mut stops = std::vec::Vec::new();
    for k in 0..800u64 {
        let t = k * 20_000_000;
        let kind = if x < 2.0 {
            SurfaceKind::Carpet
        } else {
            SurfaceKind::Tile
        };
        let (cmd, _) = nav.command(&estimate(t, x, 0.0, 0.0), Some(&floor(kind)));
        let before = x;
        x += cmd.v * 0.02;
        // Jolts 0.1 m past the change (the strip's) and 1.5 m past it.
        for at in [2.1f32, 3.5] {
            if before < at && x >= at {
                let j = jolt(t, JoltKind::SuspectedObstacle);
                if nav.on_imu(Timestamp(t), 5.0, Some(&j)).is_some() {
                    stops.push(at);
                }
            }
        }
    }
    assert_eq!(nav.explained(), 1);
    assert_eq!(stops, [3.5]);
}
