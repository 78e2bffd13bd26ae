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

    /// The office drive's first leg at 0.3 m/s: 2.7 m straight, a side step
    /// of two 20 degree arcs of 3 m radius, 6.2 m straight (over the first
    /// strip, the carpet and the second strip onto the tile).
    pub fn office_leg() -> [Segment; 4] {
        let d = std::f64::consts::PI / 9.0;
        [
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
        ]
    }

    /// The office drive (60 s): wood with a cable, a threshold strip, carpet,
    /// another strip, tile, a turn and back onto the carpet, with two episodes
    /// of wheels spinning faster than the ground and one stuck episode.
    pub fn office() -> Self {
        let [a, b, c, e] = Self::office_leg();
        Script {
            segments: vec![
                Segment::Wait { duration: 1.0 },
                a,
                b,
                c,
                e,
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

/// Turns in place of [`Script::spin`].
pub const SPIN_TURNS: u32 = 10;

/// Yaw rate of [`Script::spin`]'s turns, rad/s.
pub const SPIN_RATE: f64 = 1.0;

impl Script {
    /// Turning in place (66 s): 1 s standing, [`SPIN_TURNS`] full turns to
    /// the left at [`SPIN_RATE`], standing still for the rest; no episodes.
    /// A gyro scale-factor error turns into heading error here and nowhere
    /// is it larger per second.
    pub fn spin() -> Self {
        Script {
            segments: vec![
                Segment::Wait { duration: 1.0 },
                Segment::Spin {
                    angle: f64::from(SPIN_TURNS) * std::f64::consts::TAU,
                    rate: SPIN_RATE,
                },
                Segment::Wait { duration: 1.0 },
            ],
            episodes: Vec::new(),
            duration: 66.0,
        }
    }
}

/// Laps of [`Script::shuttle`]: each lap's slip episodes, by lap number
/// modulo 3 (office-like, slip-like, straight).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LapKind {
    /// Two short episodes of spinning wheels, as in the office drive.
    Office,
    /// Longer and stronger episodes, as in the slip drive.
    Slip,
    /// No episode: constant speed on even floors.
    Straight,
}

impl Script {
    /// One shuttle lap, from rest to rest at the start, facing +x: the office
    /// drive's first leg (2.7 m, a side step of two 20 degree arcs, 6.2 m
    /// over the strip, the carpet and the second strip onto the tile), a
    /// half turn on the spot, the same leg back, a half turn. Standing still
    /// 1 s at the start and 0.5 s around each turn, so every turn starts and
    /// ends at rest and the lap closes on itself. About 84 s.
    pub fn shuttle_lap() -> Vec<Segment> {
        let leg = Self::office_leg();
        let turn = [
            Segment::Wait { duration: 0.5 },
            Segment::Spin {
                angle: std::f64::consts::PI,
                rate: 0.8,
            },
            Segment::Wait { duration: 0.5 },
        ];
        let mut lap = vec![Segment::Wait { duration: 1.0 }];
        lap.extend(leg);
        lap.extend(turn);
        lap.extend(leg);
        lap.extend(turn);
        lap
    }

    /// The long drive: [`Script::shuttle_lap`] again and again for
    /// `duration` seconds, the laps taking turns as office, slip and
    /// straight laps ([`LapKind`]); the episodes of spinning wheels fall on
    /// the long straight over the carpet, out or back.
    pub fn shuttle(duration: f64) -> Self {
        let lap = Self::shuttle_lap();
        let lap_s: f64 = lap.iter().map(Segment::duration).sum();
        let laps = (duration / lap_s).ceil().max(1.0) as usize;
        let mut segments = Vec::with_capacity(laps * lap.len());
        let mut episodes = Vec::new();
        for k in 0..laps {
            let t0 = k as f64 * lap_s;
            segments.extend_from_slice(&lap);
            let spin = |start: f64, end: f64, factor: f64| Episode {
                start: t0 + start,
                end: t0 + end,
                kind: EpisodeKind::Spin(factor),
            };
            match Self::lap_kind(k) {
                LapKind::Office => {
                    episodes.push(spin(22.0, 23.5, 1.6));
                    episodes.push(spin(63.0, 64.0, 1.4));
                }
                LapKind::Slip => {
                    episodes.push(spin(21.0, 24.0, 1.8));
                    episodes.push(spin(61.0, 65.0, 1.6));
                }
                LapKind::Straight => {}
            }
        }
        Script {
            segments,
            episodes,
            duration,
        }
    }

    /// The kind of shuttle lap `k` (from 0).
    pub fn lap_kind(k: usize) -> LapKind {
        match k % 3 {
            0 => LapKind::Office,
            1 => LapKind::Slip,
            _ => LapKind::Straight,
        }
    }

    /// The segment commanded at `t` and its start time, if any.
    pub fn segment_at(&self, t: f64) -> Option<(usize, f64)> {
        let mut start = 0.0;
        for (i, s) in self.segments.iter().enumerate() {
            let d = s.duration();
            if t < start + d {
                return Some((i, start));
            }
            start += d;
        }
        None
    }

    /// Whether the robot is commanded to drive (a straight or an arc, not a
    /// turn on the spot or standing) all through `[t, t + d)`.
    pub fn driving_through(&self, t: f64, d: f64) -> bool {
        let driving = |t: f64| {
            self.segment_at(t).is_some_and(|(i, _)| {
                matches!(
                    self.segments.get(i),
                    Some(Segment::Straight { .. } | Segment::Arc { .. })
                )
            })
        };
        let steps = (d / 0.05).ceil().max(1.0) as usize;
        (0..=steps).all(|k| driving(t + d * k as f64 / steps as f64))
    }

    /// The script with a pause of `d` seconds inserted at `t` inside a
    /// segment that drives: the segment's command goes on for `d` seconds
    /// more (the stuck or lifted robot's wheels keep turning) and the rest
    /// of the path, the episodes after `t` and the end of the run move `d`
    /// later, so the robot still drives the whole path. `None` when `t` is
    /// not inside a straight or an arc.
    pub fn with_pause(&self, t: f64, d: f64) -> Option<Script> {
        let (i, start) = self.segment_at(t)?;
        let seg = *self.segments.get(i)?;
        let tau = t - start;
        let (before, during, after) = match seg {
            Segment::Straight { length, speed } => {
                let cut = |l: f64| Segment::Straight { length: l, speed };
                (cut(speed * tau), cut(speed * d), cut(length - speed * tau))
            }
            Segment::Arc {
                radius,
                angle,
                speed,
            } => {
                let rate = speed / radius * angle.signum();
                let cut = |a: f64| Segment::Arc {
                    radius,
                    angle: a,
                    speed,
                };
                (cut(rate * tau), cut(rate * d), cut(angle - rate * tau))
            }
            _ => return None,
        };
        let mut segments = self.segments.clone();
        segments.splice(i..=i, [before, during, after]);
        let episodes = self
            .episodes
            .iter()
            .map(|e| {
                if e.start >= t {
                    Episode {
                        start: e.start + d,
                        end: e.end + d,
                        ..*e
                    }
                } else {
                    *e
                }
            })
            .collect();
        Some(Script {
            segments,
            episodes,
            duration: self.duration + d,
        })
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
    fn a_shuttle_lap_closes_on_itself_and_the_laps_take_turns() {
        let lap = Script::shuttle_lap();
        let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
        for s in &lap {
            let (v, w) = s.command();
            let n = 10_000;
            let dt = s.duration() / n as f64;
            for _ in 0..n {
                x += v * yaw.cos() * dt;
                y += v * yaw.sin() * dt;
                yaw += w * dt;
            }
        }
        assert!(x.abs() < 1e-3 && y.abs() < 1e-3, "{x} {y}");
        assert!((yaw - std::f64::consts::TAU).abs() < 1e-9, "{yaw}");
        let s = Script::shuttle(300.0);
        let lap_s: f64 = lap.iter().map(Segment::duration).sum();
        assert!((83.0..86.0).contains(&lap_s), "{lap_s}");
        assert_eq!(s.segments.len(), 4 * lap.len());
        assert_eq!(s.duration, 300.0);
        assert_eq!(
            s.episodes.len(),
            6,
            "laps 0, 1, 3 (office, slip, office) have two each, the straight lap 2 none"
        );
        assert_eq!(Script::lap_kind(2), LapKind::Straight);
        for e in &s.episodes {
            assert!(s.driving_through(e.start, e.end - e.start), "{e:?}");
        }
    }

    #[test]
    fn a_pause_keeps_the_path_and_moves_what_follows() {
        let s = Script::shuttle(200.0);
        assert!(s.driving_through(5.0, 2.0));
        assert!(!s.driving_through(39.5, 2.0), "the half turn");
        assert!(s.with_pause(39.5, 1.0).is_none());
        let p = s.with_pause(5.0, 2.0).unwrap();
        assert_eq!(p.command(5.5), s.command(5.5));
        assert_eq!(p.command(30.0), s.command(28.0));
        assert_eq!(p.episodes[0].start, s.episodes[0].start + 2.0);
        assert_eq!(p.duration, 202.0);
        let length = |s: &Script| -> f64 {
            s.segments
                .iter()
                .map(|g| g.command().0.abs() * g.duration())
                .sum()
        };
        assert!(
            (length(&p) - length(&s) - 0.6).abs() < 1e-9,
            "0.3 m/s for 2 s more"
        );
        let a = s.with_pause(11.0, 1.0).unwrap();
        assert_eq!(a.command(11.5), s.command(11.5), "inside the arc");
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
