//! Ground classes: which class ids of an external segmentation model are
//! floors, and which kind of floor each one is.
//!
//! A segmentation model labels every pixel with a class id (`u8`). The robot
//! only cares about the ids that are ground it can drive on; walls, furniture
//! and "unknown" are not ground and carry no surface information. The table
//! is a fixed 256-entry array (one per possible id), so a lookup never fails.

/// The kind of floor a ground class stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum SurfaceKind {
    /// Wooden floor, parquet, laminate: hard, smooth, high grip.
    Wood = 0,
    /// Carpet or rug: soft, lower grip, larger vertical vibration.
    Carpet = 1,
    /// Ceramic or stone tiles: hard, high grip, small jolts at grout lines.
    Tile = 2,
    /// Concrete or screed: hard, high grip, somewhat rough.
    Concrete = 3,
    /// A narrow threshold strip between rooms: a short, large jolt is normal.
    Threshold = 4,
}

impl SurfaceKind {
    /// How many kinds there are.
    pub const COUNT: usize = 5;

    /// Every kind, in slot order.
    pub const ALL: [SurfaceKind; SurfaceKind::COUNT] = [
        SurfaceKind::Wood,
        SurfaceKind::Carpet,
        SurfaceKind::Tile,
        SurfaceKind::Concrete,
        SurfaceKind::Threshold,
    ];

    /// The table slot of this kind.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The kind in slot `i`, if any.
    pub fn from_index(i: usize) -> Option<SurfaceKind> {
        SurfaceKind::ALL.get(i).copied()
    }

    /// A short snake_case name, stable for reports.
    pub const fn name(self) -> &'static str {
        match self {
            SurfaceKind::Wood => "wood",
            SurfaceKind::Carpet => "carpet",
            SurfaceKind::Tile => "tile",
            SurfaceKind::Concrete => "concrete",
            SurfaceKind::Threshold => "threshold",
        }
    }
}

impl core::fmt::Display for SurfaceKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// What one class id of the segmentation model means for the robot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ClassRole {
    /// The model could not tell (or the id is not configured): no information.
    #[default]
    Unknown,
    /// Something that is not a floor (wall, furniture, person, ...).
    NotGround,
    /// A floor of the given kind.
    Ground(SurfaceKind),
}

/// Class id -> role, for all 256 possible ids. Unconfigured ids are
/// [`ClassRole::Unknown`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClassConfig {
    roles: [ClassRole; 256],
}

impl Default for ClassConfig {
    fn default() -> Self {
        ClassConfig::new()
    }
}

impl ClassConfig {
    /// Every id unknown.
    pub const fn new() -> Self {
        ClassConfig {
            roles: [ClassRole::Unknown; 256],
        }
    }

    /// From a list of ground ids with their kinds and a list of ids that are
    /// not ground; every other id is unknown. A later entry for the same id wins.
    pub fn from_lists(ground: &[(u8, SurfaceKind)], not_ground: &[u8]) -> Self {
        let mut c = ClassConfig::new();
        for id in not_ground {
            c.set(*id, ClassRole::NotGround);
        }
        for (id, kind) in ground {
            c.set(*id, ClassRole::Ground(*kind));
        }
        c
    }

    /// Sets the role of one id.
    pub fn set(&mut self, id: u8, role: ClassRole) {
        if let Some(r) = self.roles.get_mut(usize::from(id)) {
            *r = role;
        }
    }

    /// Builder form of [`ClassConfig::set`] for a ground id.
    pub fn with_ground(mut self, id: u8, kind: SurfaceKind) -> Self {
        self.set(id, ClassRole::Ground(kind));
        self
    }

    /// Builder form of [`ClassConfig::set`] for a non-ground id.
    pub fn with_not_ground(mut self, id: u8) -> Self {
        self.set(id, ClassRole::NotGround);
        self
    }

    /// The role of an id.
    pub fn role(&self, id: u8) -> ClassRole {
        self.roles
            .get(usize::from(id))
            .copied()
            .unwrap_or(ClassRole::Unknown)
    }

    /// The surface kind of an id, if it is ground.
    pub fn ground_kind(&self, id: u8) -> Option<SurfaceKind> {
        match self.role(id) {
            ClassRole::Ground(k) => Some(k),
            _ => None,
        }
    }

    /// The ids that are ground surfaces, in increasing order.
    pub fn ground_ids(&self) -> impl Iterator<Item = (u8, SurfaceKind)> + '_ {
        (0u8..=255).filter_map(|id| self.ground_kind(id).map(|k| (id, k)))
    }
}
