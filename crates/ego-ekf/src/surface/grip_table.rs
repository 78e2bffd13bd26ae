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
        GripParams::new(g, forward_std, m.lateral_std, gate, jolt).unwrap_or_default()
    }

    /// Grip parameters of a blend of floors: every field is the
    /// fraction-weighted mean of the floors' fields. `multipliers` are the
    /// learned forward-noise multipliers per floor ([`SurfaceKind`] order).
    pub fn blended(
        &self,
        mix: &SurfaceMix,
        wheel: WheelType,
        multipliers: &[f32; SurfaceKind::COUNT],
    ) -> GripParams {
        let mut acc = [0.0f32; 5];
        for (kind, f) in mix.iter() {
            let mult = multipliers.get(kind.index()).copied().unwrap_or(1.0);
            let p = self.params(kind, wheel, mult);
            for (a, v) in acc.iter_mut().zip(fields(&p).iter()) {
                *a += f * v;
            }
        }
        from_fields(&acc).unwrap_or_else(|| self.params(mix.dominant(), wheel, 1.0))
    }
}

/// The fields of grip parameters as an array (grip, forward std, lateral std,
/// gate, jolt threshold).
fn fields(p: &GripParams) -> [f32; 5] {
    [
        p.grip(),
        p.forward_std(),
        p.lateral_std(),
        p.forward_gate(),
        p.jolt_threshold(),
    ]
}

/// Grip parameters from fields, grip clamped into (0, 1] against rounding.
fn from_fields(v: &[f32; 5]) -> Option<GripParams> {
    let [g, fs, ls, gate, jolt] = *v;
    GripParams::new(g.min(1.0), fs, ls, gate, jolt).ok()
}

/// `(1 - w) * a + w * b`, field by field, `w` clamped to `[0, 1]` (NaN -> 0).
/// A convex blend of valid parameters is valid.
pub fn lerp_params(a: &GripParams, b: &GripParams, w: f32) -> GripParams {
    let w = if w.is_nan() { 0.0 } else { w.clamp(0.0, 1.0) };
    let (fa, fb) = (fields(a), fields(b));
    let mut out = [0.0f32; 5];
    for ((o, x), y) in out.iter_mut().zip(fa.iter()).zip(fb.iter()) {
        *o = (1.0 - w) * x + w * y;
    }
    from_fields(&out).unwrap_or(*a)
}
