//! The scripted drive: path segments with commanded speeds, and the slip
//! episodes of the scenario (continuous slip per surface comes from the
//! world; episodes are timed).

/// One piece of the commanded path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Segment {
    /// Straight ahead for `length` metres at `speed` m/s.
    Straight {
        /// Metres.
        length: f64,
        /// m/s.
        speed: f64,
    },
    /// An arc of `radius` metres turning by `angle` radians (positive = left) at `speed` m/s.
    Arc {
        /// Metres.
        radius: f64,
        /// Radians, signed.
        angle: f64,
        /// m/s along the arc.
        speed: f64,
    },
    /// Turn in place by `angle` radians at `rate` rad/s.
    Spin {
        /// Radians, signed.
        angle: f64,
        /// rad/s, positive.
        rate: f64,
    },
    /// Stand still for `duration` seconds.
    Wait {
        /// Seconds.
        duration: f64,
    },
}

impl Segment {
    /// Duration, seconds.
    pub fn duration(&self) -> f64 {
        match *self {
            Segment::Straight { length, speed } => length / speed,
            Segment::Arc {
                radius,
                angle,
                speed,
            } => radius * angle.abs() / speed,
            Segment::Spin { angle, rate } => angle.abs() / rate,
            Segment::Wait { duration } => duration,
        }
    }

    /// Commanded forward speed and yaw rate.
    pub fn command(&self) -> (f64, f64) {
        match *self {
            Segment::Straight { speed, .. } => (speed, 0.0),
            Segment::Arc {
                radius,
                angle,
                speed,
            } => (speed, angle.signum() * speed / radius),
            Segment::Spin { angle, rate } => (0.0, angle.signum() * rate),
            Segment::Wait { .. } => (0.0, 0.0),
        }
    }
}

/// What the wheels do differently from the ground during an episode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EpisodeKind {
    /// Wheels spin faster than the ground moves, by this factor.
    Spin(f64),
    /// The robot is stuck: wheels turn as commanded, the body does not move.
    Stuck,
    /// The robot is lifted off the floor: the body stays put (raised by
    /// [`LIFT_HEIGHT`]), the unloaded wheels spin [`LIFT_WHEEL_FACTOR`]
    /// times faster than commanded, the flow sensor loses the floor.
    Lifted,
}

/// How high a lifted robot is raised, metres.
pub const LIFT_HEIGHT: f64 = 0.03;
/// Rise and set-down time of a lift, seconds.
pub const LIFT_RAMP: f64 = 0.3;
/// Unloaded wheels spin this much faster than commanded.
pub const LIFT_WHEEL_FACTOR: f64 = 1.3;

/// A timed slip episode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Episode {
    /// Start, seconds from the start of the run.
    pub start: f64,
    /// End, seconds.
    pub end: f64,
    /// What happens.
    pub kind: EpisodeKind,
}

/// A whole script.
#[derive(Clone, Debug, PartialEq)]
pub struct Script {
    /// The path.
    pub segments: Vec<Segment>,
    /// Slip episodes.
    pub episodes: Vec<Episode>,
    /// Total duration, seconds (the path is cut or padded with standing still).
    pub duration: f64,
}

impl Script {
    /// Commanded `(v, w)` at time `t` seconds.
    pub fn command(&self, t: f64) -> (f64, f64) {
        let mut start = 0.0;
        for s in &self.segments {
            let d = s.duration();
            if t < start + d {
                return s.command();
            }
            start += d;
        }
        (0.0, 0.0)
    }

    /// The slip episode active at `t`, if any.
    pub fn episode(&self, t: f64) -> Option<EpisodeKind> {
        self.episodes
            .iter()
            .find(|e| t >= e.start && t < e.end)
            .map(|e| e.kind)
    }

    /// Height of the body lifted by a [`EpisodeKind::Lifted`] episode at `t`
    /// (a raised-cosine rise and set-down of [`LIFT_RAMP`]), metres.
    pub fn lift(&self, t: f64) -> f64 {
        self.episodes
            .iter()
            .find(|e| e.kind == EpisodeKind::Lifted && t >= e.start && t < e.end)
            .map(|e| {
                let edge = ((t - e.start).min(e.end - t) / LIFT_RAMP).min(1.0);
                LIFT_HEIGHT * 0.5 * (1.0 - (std::f64::consts::PI * edge).cos())
            })
            .unwrap_or(0.0)
    }

    /// The office drive (60 s): wood with a cable, a threshold strip, carpet,
    /// another strip, tile, a turn and back onto the carpet, with two episodes
    /// of wheels spinning faster than the ground and one stuck episode.
    pub fn office() -> Self {
        let d = std::f64::consts::PI / 9.0;
        Script {
            segments: vec![
                Segment::Wait { duration: 1.0 },
                Segment::Straight {
                    length: 2.7,
                    speed: 0.3,
                },
                Segment::Arc {
                    radius: 3.0,
                    angle: d,
                    speed: 0.3,
                },
                Segment::Arc {
                    radius: 3.0,
                    angle: -d,
                    speed: 0.3,
                },
                Segment::Straight {
                    length: 6.2,
                    speed: 0.3,
                },
                Segment::Spin {
                    angle: std::f64::consts::PI,
                    rate: 0.8,
                },
                Segment::Straight {
                    length: 6.0,
                    speed: 0.3,
                },
            ],
            episodes: vec![
                Episode {
                    start: 22.0,
                    end: 23.5,
                    kind: EpisodeKind::Spin(1.6),
                },
                Episode {
                    start: 33.0,
                    end: 34.0,
                    kind: EpisodeKind::Spin(1.4),
                },
                Episode {
                    start: 48.0,
                    end: 50.0,
                    kind: EpisodeKind::Stuck,
                },
            ],
            duration: 60.0,
        }
    }
}

impl Script {
    /// The straight drive (36 s): 1 s standing, 10 m straight ahead at a
    /// constant 0.3 m/s, 1 s standing; no episodes. The case where fusing the
    /// sensors must not make the estimate worse than the best of them.
    pub fn straight() -> Self {
        Script {
            segments: vec![
                Segment::Wait { duration: 1.0 },
                Segment::Straight {
                    length: 10.0,
                    speed: 0.3,
                },
                Segment::Wait { duration: 1.0 },
            ],
            episodes: Vec::new(),
            duration: 36.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_follow_segments() {
        let s = Script::office();
        assert_eq!(s.command(0.5), (0.0, 0.0));
        assert_eq!(s.command(2.0), (0.3, 0.0));
        let (v, w) = s.command(11.0);
        assert!(
            (v - 0.3).abs() < 1e-12 && (w - 0.1).abs() < 1e-12,
            "{v} {w}"
        );
        assert_eq!(s.episode(48.5), Some(EpisodeKind::Stuck));
        assert_eq!(s.episode(47.0), None);
        let total: f64 = s.segments.iter().map(Segment::duration).sum();
        assert!(total > 55.0 && total < 70.0, "{total}");
    }

    #[test]
    fn the_straight_drive_is_ten_metres_at_constant_speed() {
        let s = Script::straight();
        assert!(s.episodes.is_empty());
        let moving = s.segments.iter().map(Segment::duration).sum::<f64>();
        assert!(moving <= s.duration, "{moving} {}", s.duration);
        let length: f64 = s
            .segments
            .iter()
            .map(|g| g.command().0 * g.duration())
            .sum();
        assert!((length - 10.0).abs() < 1e-9, "{length}");
        for t in [2.0, 10.0, 20.0, 30.0] {
            assert_eq!(s.command(t), (0.3, 0.0), "{t}");
        }
        assert_eq!(s.command(35.5).0, 0.0);
    }
}
