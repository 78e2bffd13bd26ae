//! Differential-drive kinematics (Siegwart, Nourbakhsh and Scaramuzza,
//! *Introduction to Autonomous Mobile Robots*, 2nd ed., 2011, sec. 5.2.4;
//! Thrun, Burgard and Fox, *Probabilistic Robotics*, velocity motion model).
//!
//! Each wheel's rim moves by `radius * angle` ([`rim`]; rates give speeds).
//! From the left and right rim motion `l`, `r` and the track `b` (lateral
//! distance between the contact points):
//!
//! - the mid-axle point moves forward by `(l + r) / 2` ([`mid_axle`]);
//! - the wheels differ by `r - l` ([`differential`]), the heading changes by
//!   `(r - l) / b` ([`turn`]).
//!
//! Travels give displacements and angles, speeds give velocities and rates:
//! the formulas are linear. With both wheels turning at constant rates over a
//! step, the mid-axle point moves on a circular arc (or a line); the chord
//! from the start, in the start body frame, is
//!
//! `x = ds * sinc(dpsi/2) * cos(dpsi/2)`, `y = ds * sinc(dpsi/2) * sin(dpsi/2)`
//!
//! (`sinc(h) = sin(h) / h`), the closed form that tends to the straight line
//! as `dpsi -> 0` without dividing by it ([`integrate_arc`]).

/// Rim travel (m) of a wheel of `radius` (m) turned by `angle` (rad), or rim
/// speed (m/s) for a rate (rad/s).
#[inline(always)]
pub fn rim(radius: f32, angle: f32) -> f32 {
    radius * angle
}

/// Forward motion of the mid-axle point from both rims' motion.
#[inline(always)]
pub fn mid_axle(left: f32, right: f32) -> f32 {
    0.5 * (left + right)
}

/// The right rim's motion minus the left's (the track times the turn).
#[inline(always)]
pub fn differential(left: f32, right: f32) -> f32 {
    right - left
}

/// Heading change (rad, counter-clockwise) from both rims' travel and the
/// track `track` (m); a yaw rate for rim speeds.
#[inline(always)]
pub fn turn(left: f32, right: f32, track: f32) -> f32 {
    differential(left, right) / track
}

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

/// Integrates a step from the left and right rim travel (metres) and the
/// track (metres, positive): the exact arc.
pub fn integrate_arc(left: f32, right: f32, track: f32) -> ArcStep {
    let ds = mid_axle(left, right);
    let dyaw = turn(left, right, track);
    let half = 0.5 * dyaw;
    let k = ds * sinc(half);
    ArcStep {
        x: k * libm::cosf(half),
        y: k * libm::sinf(half),
        dyaw,
        arc_length: ds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_turn_and_arc() {
        assert_eq!(mid_axle(0.2, 0.4), 0.3f32);
        assert_eq!(differential(0.2, 0.5), 0.3f32);
        assert!((turn(-0.1, 0.1, 0.25) - 0.8).abs() < 1e-6);
        assert_eq!(rim(0.035, 2.0), 0.07f32);
        let s = integrate_arc(0.1, 0.1, 0.25);
        assert_eq!((s.x, s.y, s.dyaw), (0.1, 0.0, 0.0));
        // A quarter circle of radius 0.5 m: chord (0.5, 0.5).
        let q = core::f32::consts::FRAC_PI_2;
        let (l, r) = ((0.5 - 0.125) * q, (0.5 + 0.125) * q);
        let s = integrate_arc(l, r, 0.25);
        assert!((s.dyaw - q).abs() < 1e-6);
        assert!(
            (s.x - 0.5).abs() < 1e-6 && (s.y - 0.5).abs() < 1e-6,
            "{s:?}"
        );
        assert!((s.path_length() - 0.5 * q).abs() < 1e-6);
        assert!((sinc(1e-4) - 1.0).abs() < 1e-7 && (sinc(1.0) - libm::sinf(1.0)).abs() < 1e-7);
    }
}
