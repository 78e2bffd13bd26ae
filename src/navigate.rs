//! Closed-loop navigation of a differential-drive robot through waypoints,
//! on the [`Estimator`](crate::Estimator)'s answers only: its pose
//! ([`Estimate`]), the grip of the floor under the wheels and of the floor
//! the forward camera sees coming ([`Floor`], from the surface model), and
//! its verdict on each vertical jolt ([`JoltEvent`]).
//!
//! - Path following: pure pursuit of the segment from where the robot set
//!   off to the next waypoint ([`pursuit`]); a waypoint is reached when the
//!   estimate comes within `reach_radius` of it or passes it; the robot
//!   turns on the spot when the goal point lies far off its heading.
//! - Speed: the cruise speed scaled by the current grip over the reference
//!   grip, capped at `crossing_speed` (and the next floor's grip) within
//!   `anticipation_distance` of an anticipated floor change, slowed towards
//!   each waypoint.
//! - Jolts: [`Policy::FloorAware`] stops only at a jolt the estimator judges
//!   a suspected obstacle and drives on through those the floor explains
//!   (carpet, threshold strips); [`Policy::FixedThreshold`] is what a robot
//!   without the floor model does: it stops at every jolt whose peak exceeds
//!   one fixed level (its own [`JoltDetector`] with [`JoltContext::fixed`]),
//!   and drives at the cruise speed whatever the floor.
//! - At a stop: stand for `stop_s`, back off `backoff_distance` straight
//!   back, then go round: two detour waypoints `detour_offset` to the side
//!   (towards the side the next waypoint lies on, left when straight ahead),
//!   the second `detour_pass` beyond the stop point; a stop during a detour
//!   widens the next one.
//!
//! This is the loop the firmware runs at the wheel rate: fixed-size state, no
//! allocation, `libm` math.

pub mod pursuit;

use ego_ekf::events::{JoltConfig, JoltContext, JoltDetector, JoltEvent};
use ego_ekf::surface::{SurfaceKind, SurfaceModel};
use heapless::Vec;
use libm::{cosf, fabsf, hypotf, sinf};
use vslam_core::Timestamp;

use crate::estimate::Estimate;
pub use pursuit::Point;

/// Tuning of the navigator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavConfig {
    /// Forward speed on a floor of the reference grip, m/s.
    pub cruise_speed: f32,
    /// Lowest forward speed while driving, m/s.
    pub min_speed: f32,
    /// Largest commanded yaw rate, rad/s.
    pub max_yaw_rate: f32,
    /// Pure-pursuit lookahead, m.
    pub lookahead: f32,
    /// A waypoint is reached within this distance, m.
    pub reach_radius: f32,
    /// Slow down linearly to `min_speed` over this distance before a waypoint, m.
    pub approach_distance: f32,
    /// Turn on the spot while the goal point's bearing exceeds this, rad.
    pub spin_bearing: f32,
    /// The grip at which the robot drives at `cruise_speed`.
    pub reference_grip: f32,
    /// Slow down for a floor change anticipated within this distance, m.
    pub anticipation_distance: f32,
    /// Speed over an anticipated floor change, m/s.
    pub crossing_speed: f32,
    /// Standing time after a stop, s.
    pub stop_s: f32,
    /// Distance backed off after a stop, m.
    pub backoff_distance: f32,
    /// Backing speed, m/s.
    pub backoff_speed: f32,
    /// Lateral offset of a detour, m.
    pub detour_offset: f32,
    /// How far beyond the stop point a detour rejoins, m.
    pub detour_pass: f32,
    /// A jolt within this distance driven since the floor under the wheels
    /// changed, or this near an anticipated change, is the boundary's, m.
    pub boundary_distance: f32,
}

impl Default for NavConfig {
    /// A robot vacuum: 0.3 m/s cruise, 0.18 m/s over floor changes, 0.3 m
    /// back off, 0.8 m detours.
    fn default() -> Self {
        NavConfig {
            cruise_speed: 0.3,
            min_speed: 0.06,
            max_yaw_rate: 1.0,
            lookahead: 0.35,
            reach_radius: 0.03,
            approach_distance: 0.4,
            spin_bearing: 0.8,
            reference_grip: 0.95,
            anticipation_distance: 0.6,
            crossing_speed: 0.18,
            stop_s: 0.5,
            backoff_distance: 0.3,
            backoff_speed: 0.15,
            detour_offset: 0.8,
            detour_pass: 0.5,
            boundary_distance: 0.35,
        }
    }
}

/// How jolts are judged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Policy {
    /// The estimator's verdict: stop at a suspected obstacle only; speed by grip.
    FloorAware,
    /// Stop at every jolt above `threshold` m/s^2; cruise speed everywhere.
    FixedThreshold {
        /// Peak vertical deviation that stops the robot, m/s^2.
        threshold: f32,
    },
}

/// The floor as the surface model sees it at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Floor {
    /// Grip coefficient of the floor under the wheels, (0, 1].
    pub grip: f32,
    /// An anticipated floor change: distance the wheels still travel to it
    /// (m) and the grip of the floor beyond.
    pub ahead: Option<(f32, f32)>,
    /// The dominant floor under the wheels, if known.
    pub kind: Option<SurfaceKind>,
    /// The largest jolt a threshold strip explains, m/s^2.
    pub strip_jolt: f32,
}

impl Floor {
    /// The floor the surface model `surface` sees at `t`, the robot moving
    /// forward at `v` m/s: the grip under the wheels, and the floor change
    /// its last map anticipated, its distance carried on from the map's time
    /// at `v`.
    pub fn of(surface: &SurfaceModel, t: Timestamp, v: f32) -> Floor {
        let state = surface.state_at(t);
        let since_map = surface
            .tracker()
            .last_map_time()
            .and_then(|m| t.nanos_since(m))
            .map_or(0.0, vslam_core::time::nanos_to_seconds);
        let ahead = state.anticipation.map(|a| {
            let grip = surface.table().params(a.kind, surface.wheel(), 1.0).grip();
            ((a.distance - v.max(0.0) * since_map).max(0.0), grip)
        });
        Floor {
            grip: surface.grip_params(t).grip(),
            ahead,
            kind: state.dominant(),
            strip_jolt: surface
                .table()
                .params(SurfaceKind::Threshold, surface.wheel(), 1.0)
                .jolt_threshold(),
        }
    }
}

/// What the wheels are told.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Command {
    /// Forward speed, m/s.
    pub v: f32,
    /// Yaw rate, rad/s.
    pub w: f32,
}

/// What happened at a control step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavEvent {
    /// Route waypoint `i` (from 0) was reached.
    Reached(usize),
    /// The last route waypoint was reached.
    Done,
}

/// Why a route was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavError {
    /// More waypoints than the navigator holds, or none.
    RouteSize,
    /// A waypoint or a configuration value is not finite, or a speed,
    /// distance or time is not positive.
    Invalid,
}

impl core::fmt::Display for NavError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            NavError::RouteSize => "a route needs 1 to N waypoints",
            NavError::Invalid => {
                "waypoints and settings must be finite, speeds and distances positive"
            }
        })
    }
}

impl core::error::Error for NavError {}

/// A stop the navigator made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// When the jolt peaked.
    pub t: Timestamp,
    /// Its peak vertical deviation, m/s^2.
    pub magnitude: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Follow,
    /// Standing after a stop until `until`; `at` is where (set at the first control step).
    Standing {
        until: Timestamp,
        at: Option<(Point, f32)>,
    },
    /// Backing off from the stop point `at` (heading `yaw`).
    Backing {
        at: Point,
        yaw: f32,
    },
    Done,
}

/// The navigator for routes of up to `N` waypoints; see the module docs.
#[derive(Clone, Debug)]
pub struct Navigator<const N: usize> {
    config: NavConfig,
    policy: Policy,
    fixed: JoltDetector,
    route: Vec<Point, N>,
    next: usize,
    detour: Vec<Point, 2>,
    widen: u8,
    from: Option<Point>,
    mode: Mode,
    stops: u32,
    explained: u32,
    /// Distance driven by the estimate, m, and the last position.
    odometer: f32,
    last: Option<Point>,
    /// The floor seen at the last control step, the odometer when it
    /// changed, and the floor's view then.
    kind: Option<SurfaceKind>,
    changed_at: Option<f32>,
    floor: Option<Floor>,
}

impl<const N: usize> Navigator<N> {
    /// A navigator for `route` (visited in order).
    pub fn new(config: NavConfig, policy: Policy, route: &[Point]) -> Result<Self, NavError> {
        let pos = |v: f32| v.is_finite() && v > 0.0;
        let c = &config;
        if ![
            c.cruise_speed,
            c.min_speed,
            c.max_yaw_rate,
            c.lookahead,
            c.reach_radius,
            c.approach_distance,
            c.spin_bearing,
            c.reference_grip,
            c.anticipation_distance,
            c.crossing_speed,
            c.stop_s,
            c.backoff_distance,
            c.backoff_speed,
            c.detour_offset,
            c.detour_pass,
            c.boundary_distance,
        ]
        .iter()
        .all(|v| pos(*v))
            || !route.iter().flatten().all(|v| v.is_finite())
            || matches!(policy, Policy::FixedThreshold { threshold } if !pos(threshold))
        {
            return Err(NavError::Invalid);
        }
        if route.is_empty() {
            return Err(NavError::RouteSize);
        }
        let route = Vec::from_slice(route).map_err(|_| NavError::RouteSize)?;
        Ok(Navigator {
            config,
            policy,
            fixed: JoltDetector::new(JoltConfig::default()),
            route,
            next: 0,
            detour: Vec::new(),
            widen: 0,
            from: None,
            mode: Mode::Follow,
            stops: 0,
            explained: 0,
            odometer: 0.0,
            last: None,
            kind: None,
            changed_at: None,
            floor: None,
        })
    }

    /// Route waypoints reached so far.
    pub fn reached(&self) -> usize {
        self.next
    }

    /// Stops made so far.
    pub fn stops(&self) -> u32 {
        self.stops
    }

    /// Suspected obstacles the floor explained as a boundary's strip (no stop).
    pub fn explained(&self) -> u32 {
        self.explained
    }

    /// Whether the robot is at a floor boundary: within `boundary_distance`
    /// driven since the floor changed, or of an anticipated change.
    fn at_boundary(&self) -> bool {
        let d = self.config.boundary_distance;
        let since = self.changed_at.is_some_and(|c| self.odometer - c <= d);
        let ahead = self
            .floor
            .and_then(|f| f.ahead)
            .is_some_and(|(a, _)| a <= d);
        since || ahead
    }

    /// Whether the last waypoint has been reached.
    pub fn is_done(&self) -> bool {
        self.mode == Mode::Done
    }

    /// Whether the robot is standing or backing off after a stop.
    pub fn is_stopped(&self) -> bool {
        matches!(self.mode, Mode::Standing { .. } | Mode::Backing { .. })
    }

    /// The waypoint driven to now (a detour's first), if any.
    pub fn target(&self) -> Option<Point> {
        self.detour.first().or(self.route.get(self.next)).copied()
    }

    /// One IMU step: its time, the vertical deviation (m/s^2) and the
    /// estimator's verdict on a jolt that closed with it. Gives the stop
    /// when the policy stops the robot here (only while it follows the route).
    pub fn on_imu(
        &mut self,
        t: Timestamp,
        deviation: f32,
        jolt: Option<&JoltEvent>,
    ) -> Option<Stop> {
        let hit = match self.policy {
            Policy::FloorAware => {
                let j = jolt.filter(|j| j.kind.is_obstacle()).copied()?;
                // The estimator places a crossing in time, from the speed at
                // its last map; a robot held up before a boundary meets it
                // later. By the distance driven it is still the boundary's.
                let strip = self.floor.is_some_and(|f| j.magnitude <= f.strip_jolt);
                if strip && self.at_boundary() && self.mode == Mode::Follow {
                    self.explained = self.explained.saturating_add(1);
                    return None;
                }
                Some(j)
            }
            Policy::FixedThreshold { threshold } => self
                .fixed
                .push(t, deviation, &JoltContext::fixed(threshold))
                .ok()
                .flatten()
                .filter(|j| j.kind.is_obstacle()),
        }?;
        if self.mode != Mode::Follow {
            return None;
        }
        self.stops = self.stops.saturating_add(1);
        let until = t
            .checked_add_nanos((self.config.stop_s * 1e9) as u64)
            .unwrap_or(t);
        self.mode = Mode::Standing { until, at: None };
        Some(Stop {
            t: hit.t,
            magnitude: hit.magnitude,
        })
    }

    /// The wheel command for the estimate `est` and the floor (`None`
    /// without a surface model), and what happened.
    pub fn command(
        &mut self,
        est: &Estimate,
        floor: Option<&Floor>,
    ) -> (Command, Option<NavEvent>) {
        let p = [est.p_wb.x, est.p_wb.y];
        let yaw = est.yaw();
        let c = self.config;
        if let Some(q) = self.last.replace(p) {
            self.odometer += hypotf(p[0] - q[0], p[1] - q[1]);
        }
        let kind = floor.and_then(|f| f.kind);
        if let (Some(old), Some(new)) = (self.kind, kind)
            && old != new
        {
            self.changed_at = Some(self.odometer);
        }
        if kind.is_some() {
            self.kind = kind;
        }
        self.floor = floor.copied();
        match self.mode {
            Mode::Done => (Command::default(), None),
            Mode::Standing { until, at } => {
                let at = at.unwrap_or((p, yaw));
                self.mode = if est.t >= until {
                    Mode::Backing {
                        at: at.0,
                        yaw: at.1,
                    }
                } else {
                    Mode::Standing {
                        until,
                        at: Some(at),
                    }
                };
                (Command::default(), None)
            }
            Mode::Backing { at, yaw: y0 } => {
                if hypotf(p[0] - at[0], p[1] - at[1]) < c.backoff_distance {
                    return (
                        Command {
                            v: -c.backoff_speed,
                            w: 0.0,
                        },
                        None,
                    );
                }
                self.plan_detour(at, y0, p);
                self.mode = Mode::Follow;
                (Command::default(), None)
            }
            Mode::Follow => self.follow(p, yaw, floor),
        }
    }

    /// Detour round a stop at `at` (heading `yaw`), from `p`.
    fn plan_detour(&mut self, at: Point, yaw: f32, p: Point) {
        let c = self.config;
        let (hx, hy) = (cosf(yaw), sinf(yaw));
        // The side the next route waypoint lies on; left when straight ahead.
        let side = match self.route.get(self.next) {
            Some(g) if hx * (g[1] - at[1]) - hy * (g[0] - at[0]) < -0.05 => -1.0,
            _ => 1.0,
        };
        if self.detour.is_empty() {
            self.widen = 0;
        } else {
            self.widen = self.widen.saturating_add(1);
        }
        let off = c.detour_offset * (1.0 + f32::from(self.widen)) * side;
        let (nx, ny) = (-hy * off, hx * off);
        self.detour.clear();
        let _ = self.detour.push([p[0] + nx, p[1] + ny]);
        let _ = self.detour.push([
            at[0] + hx * c.detour_pass + nx,
            at[1] + hy * c.detour_pass + ny,
        ]);
        self.from = Some(p);
    }

    fn follow(&mut self, p: Point, yaw: f32, floor: Option<&Floor>) -> (Command, Option<NavEvent>) {
        let c = self.config;
        let Some(goal) = self.target() else {
            self.mode = Mode::Done;
            return (Command::default(), Some(NavEvent::Done));
        };
        let from = *self.from.get_or_insert(p);
        let tr = pursuit::track(from, goal, p, yaw, c.lookahead);
        if tr.to_goal < c.reach_radius || (tr.length > 1e-3 && tr.along >= tr.length) {
            self.from = Some(goal);
            let event = if self.detour.is_empty() {
                let i = self.next;
                self.next += 1;
                if self.next >= self.route.len() {
                    self.mode = Mode::Done;
                    return (Command::default(), Some(NavEvent::Done));
                }
                Some(NavEvent::Reached(i))
            } else {
                self.detour.remove(0);
                None
            };
            return (Command::default(), event);
        }
        if fabsf(tr.bearing) > c.spin_bearing {
            let w = (2.0 * tr.bearing).clamp(-c.max_yaw_rate, c.max_yaw_rate);
            return (Command { v: 0.0, w }, None);
        }
        let mut v = c.cruise_speed;
        if let (Policy::FloorAware, Some(f)) = (self.policy, floor) {
            let scale = |g: f32| (g / c.reference_grip).clamp(0.3, 1.0);
            v = v.min(c.cruise_speed * scale(f.grip));
            if let Some((d, g)) = f.ahead
                && d < c.anticipation_distance
            {
                v = v.min(c.crossing_speed).min(c.cruise_speed * scale(g));
            }
        }
        let approach =
            c.min_speed + (c.cruise_speed - c.min_speed) * tr.to_goal / c.approach_distance;
        v = v.min(approach).max(c.min_speed);
        let mut w = v * tr.curvature;
        if fabsf(w) > c.max_yaw_rate {
            v *= c.max_yaw_rate / fabsf(w);
            w = w.clamp(-c.max_yaw_rate, c.max_yaw_rate);
        }
        (Command { v, w }, None)
    }
}

#[cfg(test)]
mod tests;
