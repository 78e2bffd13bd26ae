//! True motion of the differential-drive robot, integrated at 1 kHz from the
//! script: rate-limited commands, slip per surface and per episode, body lift
//! over strips and cables. Everything the sensors see derives from this.

use super::script::{EpisodeKind, LIFT_HEIGHT, LIFT_WHEEL_FACTOR, Script};
use super::world::{Surface, World};

/// Integration step of the truth, nanoseconds (1 kHz).
pub const TRUTH_STEP_NS: u64 = 1_000_000;

/// The robot's true build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Robot {
    /// Nominal wheel radius (what the odometry is told), metres.
    pub nominal_radius: f64,
    /// True left wheel radius, metres.
    pub radius_left: f64,
    /// True right wheel radius, metres.
    pub radius_right: f64,
    /// Distance between the wheel contact points, metres.
    pub wheel_base: f64,
    /// Encoder counts per wheel revolution.
    pub ticks_per_revolution: f64,
    /// Largest forward acceleration, m/s^2.
    pub max_accel: f64,
    /// Largest yaw acceleration, rad/s^2.
    pub max_yaw_accel: f64,
}

impl Robot {
    /// The robot-vacuum preset's wheels ([`super::preset`]: 35 mm, 230 mm
    /// track, AS5047P encoders), the left one truly 2 % larger than nominal,
    /// the right 1 % smaller.
    pub fn vacuum() -> Self {
        let wheels = super::preset::preset().wheels;
        let radius = super::preset::decimal(wheels.mean_radius());
        Robot {
            nominal_radius: radius,
            radius_left: radius * 1.02,
            radius_right: radius * 0.99,
            wheel_base: super::preset::decimal(wheels.track),
            ticks_per_revolution: f64::from(wheels.counts_per_revolution),
            max_accel: 0.6,
            max_yaw_accel: 3.0,
        }
    }
}

/// Continuous slip of the wheels on a surface: wheel surface speed over ground speed, minus one.
pub fn surface_slip(s: Option<Surface>) -> f64 {
    match s {
        Some(Surface::Wood) => 0.005,
        Some(Surface::Carpet) => 0.06,
        Some(Surface::Tile) => 0.01,
        Some(Surface::Concrete) => 0.003,
        None => 0.0,
    }
}

/// The true state at one truth step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthStep {
    /// Time, nanoseconds from the start.
    pub t_ns: u64,
    /// Body origin in the world, metres.
    pub p: [f64; 3],
    /// Heading, radians.
    pub yaw: f64,
    /// Forward ground speed, m/s.
    pub v: f64,
    /// Yaw rate, rad/s.
    pub w: f64,
    /// World velocity, m/s.
    pub vel: [f64; 3],
    /// World acceleration (without gravity), m/s^2.
    pub acc: [f64; 3],
    /// Floor under the robot.
    pub surface: Option<Surface>,
    /// Cumulative left and right wheel angles, radians.
    pub wheel_angle: [f64; 2],
    /// Whether a slip episode is active.
    pub episode: Option<EpisodeKind>,
}

fn approach(current: f64, target: f64, max_step: f64) -> f64 {
    current + (target - current).clamp(-max_step, max_step)
}

/// The robot's true motion, one truth step at a time, from the origin
/// heading +x: what [`integrate`] runs over a script, and what a closed
/// loop runs with the commands of a controller.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    i: u64,
    x: f64,
    y: f64,
    yaw: f64,
    v: f64,
    w: f64,
    wheel: [f64; 2],
}

impl Motion {
    /// The time of the next step, seconds.
    pub fn t(&self) -> f64 {
        self.i as f64 * TRUTH_STEP_NS as f64 * 1e-9
    }

    /// The true state now under the commanded `(v, w)`, the slip `episode`
    /// and the body `lift` of this time; then moves on one step. The
    /// accelerations are left at zero ([`differentiate_at`] fills them).
    pub fn step(
        &mut self,
        world: &World,
        robot: &Robot,
        (vc, wc): (f64, f64),
        episode: Option<EpisodeKind>,
        lift: f64,
    ) -> TruthStep {
        let dt = TRUTH_STEP_NS as f64 * 1e-9;
        let (x, y, yaw) = (self.x, self.y, self.yaw);
        self.v = approach(self.v, vc, robot.max_accel * dt);
        self.w = approach(self.w, wc, robot.max_yaw_accel * dt);
        let (v, w) = (self.v, self.w);
        let held = matches!(episode, Some(EpisodeKind::Stuck | EpisodeKind::Lifted));
        let (vg, wg) = match episode {
            Some(EpisodeKind::Stuck) => (0.0, 0.0),
            // Picked up and set down again: the body's ground speed fades
            // out while it rises and back in while it comes down.
            Some(EpisodeKind::Lifted) => {
                let on_floor = 1.0 - lift / LIFT_HEIGHT;
                (v * on_floor, w * on_floor)
            }
            _ => (v, w),
        };
        let surface = world.surface_at(x, y);
        let factor = (1.0 + surface_slip(surface))
            * match episode {
                Some(EpisodeKind::Spin(k)) => k,
                Some(EpisodeKind::Lifted) => LIFT_WHEEL_FACTOR,
                _ => 1.0,
            };
        let half = 0.5 * robot.wheel_base;
        // Stuck: the wheels still turn as commanded; otherwise they follow the ground.
        let (vl, vr) = if held {
            (v - w * half, v + w * half)
        } else {
            (vg - wg * half, vg + wg * half)
        };
        let z = 0.5
            * (world.wheel_lift(x, y, robot.radius_left)
                + world.wheel_lift(x, y, robot.radius_right))
            + lift;
        let out = TruthStep {
            t_ns: self.i * TRUTH_STEP_NS,
            p: [x, y, z],
            yaw,
            v: vg,
            w: wg,
            vel: [vg * yaw.cos(), vg * yaw.sin(), 0.0],
            acc: [0.0; 3],
            surface,
            wheel_angle: self.wheel,
            episode,
        };
        self.wheel[0] += vl * factor / robot.radius_left * dt;
        self.wheel[1] += vr * factor / robot.radius_right * dt;
        // Exact integration of a constant-twist step.
        if wg.abs() > 1e-9 {
            let r = vg / wg;
            self.x += r * ((yaw + wg * dt).sin() - yaw.sin());
            self.y -= r * ((yaw + wg * dt).cos() - yaw.cos());
        } else {
            self.x += vg * dt * yaw.cos();
            self.y += vg * dt * yaw.sin();
        }
        self.yaw += wg * dt;
        self.i += 1;
        out
    }
}

/// Integrates the script in `world` for `robot`, starting at the origin heading +x.
pub fn integrate(world: &World, script: &Script, robot: &Robot) -> Vec<TruthStep> {
    let dt = TRUTH_STEP_NS as f64 * 1e-9;
    let n = (script.duration / dt).round() as usize + 1;
    let mut out = Vec::with_capacity(n);
    let mut motion = Motion::default();
    for i in 0..n {
        let t = i as f64 * dt;
        out.push(motion.step(
            world,
            robot,
            script.command(t),
            script.episode(t),
            script.lift(t),
        ));
    }
    for i in 1..n.saturating_sub(1) {
        differentiate_at(&mut out, i);
    }
    out
}

/// Fills step `i`'s vertical velocity and accelerations by central
/// differences of its neighbours (nothing for the first and last step).
pub fn differentiate_at(steps: &mut [TruthStep], i: usize) {
    let dt = TRUTH_STEP_NS as f64 * 1e-9;
    let (Some(prev), Some(next)) = (
        i.checked_sub(1).and_then(|k| steps.get(k)),
        steps.get(i + 1),
    ) else {
        return;
    };
    let (prev, next) = (*prev, *next);
    let Some(s) = steps.get_mut(i) else { return };
    let vz = (next.p[2] - prev.p[2]) / (2.0 * dt);
    let az = (next.p[2] - 2.0 * s.p[2] + prev.p[2]) / (dt * dt);
    s.vel[2] = vz;
    s.acc = [
        (next.vel[0] - prev.vel[0]) / (2.0 * dt),
        (next.vel[1] - prev.vel[1]) / (2.0 * dt),
        az,
    ];
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::script::Segment;

    #[test]
    fn straight_drive_and_stuck_episode() {
        let world = World::office();
        let script = Script {
            segments: vec![Segment::Straight {
                length: 0.6,
                speed: 0.3,
            }],
            episodes: vec![super::super::script::Episode {
                start: 1.0,
                end: 1.5,
                kind: EpisodeKind::Stuck,
            }],
            duration: 3.0,
        };
        let robot = Robot::vacuum();
        let truth = integrate(&world, &script, &robot);
        let last = truth.last().unwrap();
        // Half a second stuck at 0.3 m/s: the body travels 0.15 m less than commanded.
        assert!((last.p[0] - 0.45).abs() < 0.01, "{}", last.p[0]);
        assert!(last.p[1].abs() < 1e-9);
        // The wheels turned for the whole commanded distance (plus wood slip).
        let wheel_dist = last.wheel_angle[0] * robot.radius_left;
        assert!((wheel_dist - 0.6 * 1.005).abs() < 0.01, "{wheel_dist}");
    }

    #[test]
    fn office_run_stays_indoors_and_crosses_every_surface() {
        let world = World::office();
        let truth = integrate(&world, &Script::office(), &Robot::vacuum());
        assert!(truth.iter().all(|s| s.surface.is_some()));
        for surf in [Surface::Wood, Surface::Carpet, Surface::Tile] {
            assert!(truth.iter().any(|s| s.surface == Some(surf)), "{surf:?}");
        }
        let max_az = truth.iter().map(|s| s.acc[2].abs()).fold(0.0, f64::max);
        assert!(max_az > 1.0 && max_az < 50.0, "{max_az}");
    }
}
