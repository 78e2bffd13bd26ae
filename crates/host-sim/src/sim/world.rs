//! The simulated world: rooms with floor surfaces, threshold strips between
//! rooms, cables lying on the floor, and a textured planar ceiling.
//!
//! Heights of strips and cables are smoothed by the wheel: a wheel of radius
//! `r` rolling over a step of height `h` touches it over a run of about
//! `2 sqrt(2 r h)`, so the body rises along a raised-cosine of that width.

/// Floor surfaces, with the segmentation class id each is labelled with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Surface {
    /// Hardwood or laminate.
    Wood,
    /// Carpet: continuous slip, vertical vibration.
    Carpet,
    /// Ceramic tile.
    Tile,
    /// Bare concrete.
    Concrete,
}

impl Surface {
    /// Segmentation class id (see `SEG_CLASSES`).
    pub fn class_id(self) -> u8 {
        match self {
            Surface::Wood => 2,
            Surface::Carpet => 3,
            Surface::Tile => 4,
            Surface::Concrete => 5,
        }
    }

    /// Name used in reports and `sensor.yaml`.
    pub fn name(self) -> &'static str {
        match self {
            Surface::Wood => "wood",
            Surface::Carpet => "carpet",
            Surface::Tile => "tile",
            Surface::Concrete => "concrete",
        }
    }
}

/// Class ids of the simulated segmentation model.
pub const SEG_CLASSES: [(u8, &str); 7] = [
    (0, "unknown"),
    (1, "wall"),
    (2, "wood"),
    (3, "carpet"),
    (4, "tile"),
    (5, "concrete"),
    (6, "threshold"),
];
/// The ground classes among [`SEG_CLASSES`].
pub const SEG_GROUND: [u8; 5] = [2, 3, 4, 5, 6];
/// Class id of a threshold strip.
pub const THRESHOLD_CLASS: u8 = 6;
/// Class id of walls and everything that is not floor.
pub const WALL_CLASS: u8 = 1;

/// An axis-aligned room with one floor surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Room {
    /// Lower corner `[x, y]`, metres.
    pub min: [f64; 2],
    /// Upper corner `[x, y]`, metres.
    pub max: [f64; 2],
    /// Its floor.
    pub surface: Surface,
}

/// A raised strip across the floor along a line `x = at` (threshold strips)
/// or a cable along `x = at` (cables are narrower and often higher).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strip {
    /// Position along x, metres.
    pub at: f64,
    /// Physical width, metres.
    pub width: f64,
    /// Height, metres.
    pub height: f64,
    /// `true` for a threshold strip between rooms, `false` for an obstacle (cable).
    pub threshold: bool,
    /// The stretch of y it lies along, metres ([`ACROSS`]: across the whole room).
    pub span: [f64; 2],
}

/// The span of a strip across the whole room.
pub const ACROSS: [f64; 2] = [f64::NEG_INFINITY, f64::INFINITY];

/// The whole world.
#[derive(Clone, Debug, PartialEq)]
pub struct World {
    /// Rooms; the first containing a point wins.
    pub rooms: Vec<Room>,
    /// Threshold strips and cables.
    pub strips: Vec<Strip>,
    /// Ceiling height above the floor, metres.
    pub ceiling_height: f64,
    /// Metres per texel of the ceiling texture.
    pub ceiling_texel: f64,
}

impl World {
    /// The surface under `(x, y)`, or `None` outside every room.
    pub fn surface_at(&self, x: f64, y: f64) -> Option<Surface> {
        self.rooms
            .iter()
            .find(|r| x >= r.min[0] && x < r.max[0] && y >= r.min[1] && y < r.max[1])
            .map(|r| r.surface)
    }

    /// The strip whose physical footprint contains `x`, if any.
    pub fn strip_at(&self, x: f64) -> Option<&Strip> {
        self.strips
            .iter()
            .find(|s| (x - s.at).abs() <= 0.5 * s.width)
    }

    /// Height of a wheel of radius `wheel_radius` resting at `(x, y)`, metres.
    pub fn wheel_lift(&self, x: f64, y: f64, wheel_radius: f64) -> f64 {
        self.strips
            .iter()
            .filter(|s| y >= s.span[0] && y <= s.span[1])
            .map(|s| {
                let run = 0.5 * s.width + (2.0 * wheel_radius * s.height).sqrt();
                let d = (x - s.at).abs();
                if d >= run {
                    0.0
                } else if d <= 0.5 * s.width {
                    s.height
                } else {
                    let u = (d - 0.5 * s.width) / (run - 0.5 * s.width);
                    s.height * 0.5 * (1.0 + (std::f64::consts::PI * u).cos())
                }
            })
            .fold(0.0, f64::max)
    }

    /// The office: wood, carpet and tile rooms in a row with threshold strips
    /// between them, and a cable lying on the wood across the first room's
    /// middle (1.2 m of it, from y = -0.6 m to 0.6 m: a robot can go round).
    pub fn office() -> Self {
        World {
            rooms: vec![
                Room {
                    min: [-1.0, -2.5],
                    max: [4.0, 2.5],
                    surface: Surface::Wood,
                },
                Room {
                    min: [4.0, -2.5],
                    max: [8.0, 2.5],
                    surface: Surface::Carpet,
                },
                Room {
                    min: [8.0, -2.5],
                    max: [12.5, 2.5],
                    surface: Surface::Tile,
                },
            ],
            strips: vec![
                Strip {
                    at: 4.0,
                    width: 0.04,
                    height: 0.006,
                    threshold: true,
                    span: ACROSS,
                },
                Strip {
                    at: 8.0,
                    width: 0.04,
                    height: 0.006,
                    threshold: true,
                    span: ACROSS,
                },
                Strip {
                    at: 2.0,
                    width: 0.008,
                    height: 0.012,
                    threshold: false,
                    span: [-0.6, 0.6],
                },
            ],
            ceiling_height: 2.5,
            ceiling_texel: 0.006,
        }
    }
}

impl World {
    /// One long room of wood and nothing on the floor: the even floor of the
    /// `straight` scenario, under the office's ceiling.
    pub fn straight() -> Self {
        World {
            rooms: vec![Room {
                min: [-1.0, -2.5],
                max: [12.5, 2.5],
                surface: Surface::Wood,
            }],
            strips: Vec::new(),
            ..World::office()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surfaces_and_lift() {
        let w = World::office();
        assert_eq!(w.surface_at(1.0, 0.0), Some(Surface::Wood));
        assert_eq!(w.surface_at(5.0, 0.0), Some(Surface::Carpet));
        assert_eq!(w.surface_at(9.0, 0.0), Some(Surface::Tile));
        assert_eq!(w.surface_at(20.0, 0.0), None);
        assert_eq!(w.wheel_lift(4.0, 0.0, 0.035), 0.006);
        assert_eq!(w.wheel_lift(3.0, 0.0, 0.035), 0.0);
        let half = w.wheel_lift(
            4.0 + 0.02 + 0.5 * (2.0f64 * 0.035 * 0.006).sqrt(),
            1.0,
            0.035,
        );
        assert!((half - 0.003).abs() < 1e-9, "{half}");
        assert!(w.strip_at(2.003).is_some_and(|s| !s.threshold));
        assert_eq!(w.wheel_lift(2.0, 0.0, 0.035), 0.012);
        assert_eq!(w.wheel_lift(2.0, 0.9, 0.035), 0.0, "round the cable's end");
    }

    #[test]
    fn the_straight_world_is_wood_with_nothing_on_it() {
        let w = World::straight();
        for x in [-0.5, 0.0, 2.0, 4.0, 8.0, 11.0, 12.4] {
            assert_eq!(w.surface_at(x, 0.0), Some(Surface::Wood), "{x}");
            assert_eq!(w.wheel_lift(x, 0.0, 0.035), 0.0, "{x}");
        }
        assert_eq!(w.ceiling_height, World::office().ceiling_height);
    }
}
