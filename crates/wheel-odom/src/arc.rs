//! Exact differential-drive integration over one step.
//!
//! With both wheels turning at constant rates over the step, the mid-axle
//! point moves on a circular arc (or a line): arc length `ds = (l + r) / 2`,
//! heading change `dpsi = (r - l) / b` for wheel travels `l`, `r` and wheel
//! base `b`. The chord from the start is, in the start body frame,
//!
//! `x = ds * sinc(dpsi/2) * cos(dpsi/2)`, `y = ds * sinc(dpsi/2) * sin(dpsi/2)`
//!
//! (`sinc(h) = sin(h) / h`), the closed form of the arc that tends to the
//! straight line as `dpsi -> 0` without dividing by it (Thrun, Burgard, Fox,
//! *Probabilistic Robotics*, velocity motion model; Siegwart & Nourbakhsh,
//! *Introduction to Autonomous Mobile Robots*, 5.2.4).

/// One step of body motion from the two wheels' travel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArcStep {
    /// Forward displacement, metres, start body frame.
    pub x: f32,
    /// Leftward displacement, metres, start body frame.
    pub y: f32,
    /// Heading change, radians, counter-clockwise.
    pub dyaw: f32,
    /// Signed arc length travelled by the mid-axle point, metres.
    pub arc_length: f32,
}

impl ArcStep {
    /// Path length of the mid-axle point, metres (`>=` the chord).
    pub fn path_length(&self) -> f32 {
        libm::fabsf(self.arc_length)
    }
}

/// `sin(h) / h`, exact to f32 also near zero.
pub fn sinc(h: f32) -> f32 {
    if libm::fabsf(h) < 1e-3 {
        let h2 = h * h;
        1.0 - h2 / 6.0 + h2 * h2 / 120.0
    } else {
        libm::sinf(h) / h
    }
}

/// Integrates a step from the left and right wheel travel (metres) and the
/// wheel base (metres, positive).
pub fn integrate_arc(left: f32, right: f32, wheel_base: f32) -> ArcStep {
    let ds = 0.5 * (left + right);
    let dyaw = (right - left) / wheel_base;
    let half = 0.5 * dyaw;
    let k = ds * sinc(half);
    ArcStep {
        x: k * libm::cosf(half),
        y: k * libm::sinf(half),
        dyaw,
        arc_length: ds,
    }
}
