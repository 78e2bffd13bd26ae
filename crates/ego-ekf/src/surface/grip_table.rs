//! (floor kind, wheel type) -> grip coefficient -> [`GripParams`].
//!
//! The grip coefficient `g` in (0, 1] says how closely the wheel's rolling
//! speed follows the ground speed (1 = no slip expected). It sets:
//!
//! - the forward wheel-velocity noise: `forward_std = base_forward_std / g`,
//!   times the learned multiplier of the floor ([`super::learning`]): less grip,
//!   more slip, more noise;
//! - the forward chi-square gate: `base_gate * (1 + gate_gain * (1 - g))`:
//!   less grip, wider gate, so slip shows up as noise rather than as a rejected
//!   wheel;
//! - the expected slip, the fraction of the wheels' rolling speed the ground
//!   does not take: `slip_gain * (1 - g)` as the prior, plus the floor's
//!   learned offset ([`super::slip`]); the wheel measurement's *mean*
//!   depends on the grip, not only its variance;
//! - whether the wheel update may learn the radii: only when every floor
//!   under the wheels grips at least `radius_min_grip`; on a low-grip floor
//!   the wheels' over-count is the floor's slip, and the radii are held;
//! - the vertical jolt the floor explains:
//!   `jolt_floor + jolt_sigmas * vibration(floor) * vibration(wheel)`, m/s^2;
//!   carpet and threshold strips explain larger jolts than wood.
//!
//! Defaults follow the usual ranking of indoor floors for rubber wheels
//! (smooth hard floors grip best, carpet least; omni rollers grip less and
//! rattle more than solid tyres); a robot refines the noise online.

use core::fmt;

use crate::grip::GripParams;

use super::classes::SurfaceKind;
use super::mix::SurfaceMix;

/// The robot's drive wheels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum WheelType {
    /// Solid, hard rubber tyre.
    HardRubber = 0,
    /// Soft rubber or treaded tyre.
    SoftTreaded = 1,
    /// Omni wheel or caster-like rollers.
    Omni = 2,
}

impl WheelType {
    /// How many wheel types there are.
    pub const COUNT: usize = 3;
    /// Every wheel type, in slot order.
    pub const ALL: [WheelType; WheelType::COUNT] = [
        WheelType::HardRubber,
        WheelType::SoftTreaded,
        WheelType::Omni,
    ];

    /// The table slot of this wheel type.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The wheel type in slot `i`, if any.
    pub fn from_index(i: usize) -> Option<WheelType> {
        WheelType::ALL.get(i).copied()
    }
}

/// Why a grip table was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GripTableError {
    /// A grip coefficient is outside (0, 1].
    Grip,
    /// A vibration level is not finite and non-negative.
    Vibration,
    /// A model constant (noise, gate, gains, jolt floor) is not finite and
    /// positive (gains: non-negative).
    Model,
}

impl fmt::Display for GripTableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            GripTableError::Grip => "grip coefficients must lie in (0, 1]",
            GripTableError::Vibration => "vibration levels must be finite and non-negative",
            GripTableError::Model => "grip model constants must be finite and positive",
        })
    }
}

impl core::error::Error for GripTableError {}

/// How a grip coefficient becomes noise, gate and jolt threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GripModel {
    /// Forward wheel-velocity noise at grip 1, m/s.
    pub base_forward_std: f32,
    /// Lateral/vertical constraint noise, m/s (independent of grip).
    pub lateral_std: f32,
    /// Forward chi-square gate (1 DOF) at grip 1.
    pub base_gate: f32,
    /// Relative gate widening per unit of lost grip.
    pub gate_gain: f32,
    /// Jolt every floor explains, m/s^2.
    pub jolt_floor: f32,
    /// How many vibration levels a jolt may reach before it is unexplained.
    pub jolt_sigmas: f32,
    /// Expected slip per unit of lost grip (the prior of
    /// [`super::slip`]), in `[0, 1]`.
    pub slip_gain: f32,
    /// Least grip of a floor on which the wheel radii learn, in `[0, 1]`.
    pub radius_min_grip: f32,
}

impl Default for GripModel {
    fn default() -> Self {
        GripModel {
            base_forward_std: 0.02,
            lateral_std: 0.01,
            base_gate: 6.63, // chi-square, 1 DOF, 99 %
            gate_gain: 2.0,
            jolt_floor: 0.8,
            jolt_sigmas: 3.0,
            slip_gain: 0.1,
            radius_min_grip: 0.8,
        }
    }
}

impl GripModel {
    fn is_valid(&self) -> bool {
        let pos = |v: f32| v.is_finite() && v > 0.0;
        let nonneg = |v: f32| v.is_finite() && v >= 0.0;
        pos(self.base_forward_std)
            && pos(self.lateral_std)
            && pos(self.base_gate)
            && nonneg(self.gate_gain)
            && pos(self.jolt_floor)
            && nonneg(self.jolt_sigmas)
            && (0.0..=1.0).contains(&self.slip_gain)
            && (0.0..=1.0).contains(&self.radius_min_grip)
    }
}

/// Default grip per floor (rows, [`SurfaceKind`] order) and wheel (columns,
/// [`WheelType`] order).
pub const DEFAULT_GRIP: [[f32; WheelType::COUNT]; SurfaceKind::COUNT] = [
    [0.90, 0.95, 0.80], // wood
    [0.60, 0.70, 0.45], // carpet
    [0.88, 0.93, 0.78], // tile
    [0.92, 0.95, 0.82], // concrete
    [0.70, 0.78, 0.55], // threshold strip
];

/// Default vertical vibration level per floor, m/s^2 ([`SurfaceKind`] order).
pub const DEFAULT_VIBRATION: [f32; SurfaceKind::COUNT] = [0.4, 1.5, 0.5, 0.6, 3.0];

/// Default vibration factor per wheel type ([`WheelType`] order).
pub const DEFAULT_WHEEL_VIBRATION: [f32; WheelType::COUNT] = [1.0, 0.8, 1.3];

/// The grip table: grip per (floor, wheel), vibration per floor and wheel,
/// and the model that turns them into [`GripParams`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GripTable {
    grip: [[f32; WheelType::COUNT]; SurfaceKind::COUNT],
    vibration: [f32; SurfaceKind::COUNT],
    wheel_vibration: [f32; WheelType::COUNT],
    model: GripModel,
}

impl Default for GripTable {
    fn default() -> Self {
        GripTable {
            grip: DEFAULT_GRIP,
            vibration: DEFAULT_VIBRATION,
            wheel_vibration: DEFAULT_WHEEL_VIBRATION,
            model: GripModel::default(),
        }
    }
}

impl GripTable {
    /// Checks and builds a table.
    pub fn new(
        grip: [[f32; WheelType::COUNT]; SurfaceKind::COUNT],
        vibration: [f32; SurfaceKind::COUNT],
        wheel_vibration: [f32; WheelType::COUNT],
        model: GripModel,
    ) -> Result<Self, GripTableError> {
        if !grip.iter().flatten().all(|g| *g > 0.0 && *g <= 1.0) {
            return Err(GripTableError::Grip);
        }
        if !vibration
            .iter()
            .chain(wheel_vibration.iter())
            .all(|v| v.is_finite() && *v >= 0.0)
        {
            return Err(GripTableError::Vibration);
        }
        if !model.is_valid() {
            return Err(GripTableError::Model);
        }
        Ok(GripTable {
            grip,
            vibration,
            wheel_vibration,
            model,
        })
    }

    /// The same table with the model `model`. Errors:
    /// [`GripTableError::Model`] for invalid constants.
    pub fn with_model(self, model: GripModel) -> Result<Self, GripTableError> {
        if !model.is_valid() {
            return Err(GripTableError::Model);
        }
        Ok(GripTable { model, ..self })
    }

    /// The model constants.
    pub fn model(&self) -> &GripModel {
        &self.model
    }

    /// The grip coefficient of a floor for a wheel type.
    pub fn grip(&self, kind: SurfaceKind, wheel: WheelType) -> f32 {
        self.grip
            .get(kind.index())
            .and_then(|r| r.get(wheel.index()))
            .copied()
            .unwrap_or(0.5)
    }

    /// The vibration level of a floor under a wheel type, m/s^2.
    pub fn vibration(&self, kind: SurfaceKind, wheel: WheelType) -> f32 {
        let s = self.vibration.get(kind.index()).copied().unwrap_or(1.0);
        let w = self
            .wheel_vibration
            .get(wheel.index())
            .copied()
            .unwrap_or(1.0);
        s * w
    }

    /// Grip parameters of one floor; `noise_multiplier` scales the forward
    /// noise (the learned correction, 1 = table default; non-finite or
    /// non-positive values count as 1).
    pub fn params(&self, kind: SurfaceKind, wheel: WheelType, noise_multiplier: f32) -> GripParams {
        let m = &self.model;
        let g = self.grip(kind, wheel);
        let mult = if noise_multiplier.is_finite() && noise_multiplier > 0.0 {
            noise_multiplier
        } else {
            1.0
        };
        let forward_std = m.base_forward_std / g * mult;
        let gate = m.base_gate * (1.0 + m.gate_gain * (1.0 - g));
        let jolt = m.jolt_floor + m.jolt_sigmas * self.vibration(kind, wheel);
        GripParams::new(g, forward_std, m.lateral_std, gate, jolt)
            .map(|p| {
                p.with_slip(self.slip_prior(kind, wheel))
                    .with_learn_radius(!self.holds_radius(kind, wheel))
            })
            .unwrap_or_default()
    }

    /// The prior expected slip of a floor: `slip_gain * (1 - grip)`.
    pub fn slip_prior(&self, kind: SurfaceKind, wheel: WheelType) -> f32 {
        self.model.slip_gain * (1.0 - self.grip(kind, wheel))
    }

    /// The prior expected slips of every floor ([`SurfaceKind`] order).
    pub fn slip_priors(&self, wheel: WheelType) -> [f32; SurfaceKind::COUNT] {
        SurfaceKind::ALL.map(|k| self.slip_prior(k, wheel))
    }

    /// Whether the wheel radii are held on a floor (its grip is below
    /// `radius_min_grip`): there its expected slip is learned instead.
    pub fn holds_radius(&self, kind: SurfaceKind, wheel: WheelType) -> bool {
        self.grip(kind, wheel) < self.model.radius_min_grip
    }

    /// The floors whose radii are held ([`SurfaceKind`] order).
    pub fn held_floors(&self, wheel: WheelType) -> [bool; SurfaceKind::COUNT] {
        SurfaceKind::ALL.map(|k| self.holds_radius(k, wheel))
    }

    /// Grip parameters of a blend of floors: every field is the
    /// fraction-weighted mean of the floors' fields (the expected slip
    /// with the priors). `multipliers` are the learned forward-noise
    /// multipliers per floor ([`SurfaceKind`] order).
    pub fn blended(
        &self,
        mix: &SurfaceMix,
        wheel: WheelType,
        multipliers: &[f32; SurfaceKind::COUNT],
    ) -> GripParams {
        self.blended_learned(mix, wheel, multipliers, &[0.0; SurfaceKind::COUNT])
    }

    /// [`GripTable::blended`] with the learned slip offsets `slip_offsets`
    /// added to the floors' priors ([`SurfaceKind`] order; non-finite
    /// offsets count as 0). The radii learn only when no held floor
    /// ([`GripTable::holds_radius`]) covers [`HOLD_MIN_FRACTION`] of the
    /// ground or more.
    pub fn blended_learned(
        &self,
        mix: &SurfaceMix,
        wheel: WheelType,
        multipliers: &[f32; SurfaceKind::COUNT],
        slip_offsets: &[f32; SurfaceKind::COUNT],
    ) -> GripParams {
        let mut acc = [0.0f32; FIELDS];
        let mut learn_radius = true;
        for (kind, f) in mix.iter() {
            let mult = multipliers.get(kind.index()).copied().unwrap_or(1.0);
            let offset = slip_offsets.get(kind.index()).copied().unwrap_or(0.0);
            let offset = if offset.is_finite() { offset } else { 0.0 };
            let p = self.params(kind, wheel, mult);
            let p = p.with_slip(p.slip() + offset);
            learn_radius &= p.learn_radius() || f < HOLD_MIN_FRACTION;
            for (a, v) in acc.iter_mut().zip(fields(&p).iter()) {
                *a += f * v;
            }
        }
        from_fields(&acc)
            .map(|p| p.with_learn_radius(learn_radius))
            .unwrap_or_else(|| self.params(mix.dominant(), wheel, 1.0))
    }
}

/// Smallest fraction of the ground a held floor must cover to hold the
/// radii (a sliver at the edge of the label map does not).
pub const HOLD_MIN_FRACTION: f32 = 0.05;

/// How many blended fields [`fields`] has.
const FIELDS: usize = 6;

/// The fields of grip parameters as an array (grip, forward std, lateral std,
/// gate, jolt threshold, expected slip).
fn fields(p: &GripParams) -> [f32; FIELDS] {
    [
        p.grip(),
        p.forward_std(),
        p.lateral_std(),
        p.forward_gate(),
        p.jolt_threshold(),
        p.slip(),
    ]
}

/// Grip parameters from fields, grip clamped into (0, 1] against rounding
/// (radii learning: set by the caller).
fn from_fields(v: &[f32; FIELDS]) -> Option<GripParams> {
    let [g, fs, ls, gate, jolt, slip] = *v;
    GripParams::new(g.min(1.0), fs, ls, gate, jolt)
        .ok()
        .map(|p| p.with_slip(slip))
}

/// `(1 - w) * a + w * b`, field by field, `w` clamped to `[0, 1]` (NaN -> 0).
/// A convex blend of valid parameters is valid. The radii learn when both
/// ends let them (or the end with the whole weight does).
pub fn lerp_params(a: &GripParams, b: &GripParams, w: f32) -> GripParams {
    let w = if w.is_nan() { 0.0 } else { w.clamp(0.0, 1.0) };
    let (fa, fb) = (fields(a), fields(b));
    let mut out = [0.0f32; FIELDS];
    for ((o, x), y) in out.iter_mut().zip(fa.iter()).zip(fb.iter()) {
        *o = (1.0 - w) * x + w * y;
    }
    let learn = (a.learn_radius() || w >= 1.0) && (b.learn_radius() || w <= 0.0);
    from_fields(&out)
        .map(|p| p.with_learn_radius(learn))
        .unwrap_or(*a)
}
