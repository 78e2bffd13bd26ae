//! Pure pursuit on a straight segment (R. C. Coulter, "Implementation of the
//! Pure Pursuit Path Tracking Algorithm", CMU-RI-TR-92-01, 1992): the goal
//! point lies `lookahead` metres along the segment ahead of the robot's
//! projection onto it; the arc through the robot and the goal point has the
//! curvature `kappa = 2 y / L^2`, with `y` the goal point's lateral offset in
//! the robot's frame and `L` its distance.

use libm::{atan2f, cosf, hypotf, sinf};

/// A point on the floor, world frame, metres.
pub type Point = [f32; 2];

/// Where the robot stands relative to a segment `a -> b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracking {
    /// Distance along the segment from `a` of the robot's projection, m.
    pub along: f32,
    /// Length of the segment, m.
    pub length: f32,
    /// Distance from the robot to `b`, m.
    pub to_goal: f32,
    /// Curvature of the pursuit arc, 1/m (positive: turn left).
    pub curvature: f32,
    /// Bearing of the goal point in the robot's frame, rad (positive: left).
    pub bearing: f32,
}

/// Pure pursuit of segment `a -> b` from position `p` with heading `yaw`.
/// A degenerate segment (`a == b`) is pursued as the point `b`.
pub fn track(a: Point, b: Point, p: Point, yaw: f32, lookahead: f32) -> Tracking {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let length = hypotf(dx, dy);
    let (ux, uy) = if length > 1e-6 {
        (dx / length, dy / length)
    } else {
        (0.0, 0.0)
    };
    let along = (p[0] - a[0]) * ux + (p[1] - a[1]) * uy;
    let to_goal = hypotf(b[0] - p[0], b[1] - p[1]);
    // The goal point: lookahead ahead of the projection, but never past b.
    let s = (along.max(0.0) + lookahead).min(length);
    let g = [a[0] + ux * s, a[1] + uy * s];
    let g = if to_goal < lookahead { b } else { g };
    let (gx, gy) = (g[0] - p[0], g[1] - p[1]);
    let (c, sn) = (cosf(yaw), sinf(yaw));
    let x_r = c * gx + sn * gy;
    let y_r = -sn * gx + c * gy;
    let l2 = x_r * x_r + y_r * y_r;
    let curvature = if l2 > 1e-8 { 2.0 * y_r / l2 } else { 0.0 };
    Tracking {
        along,
        length,
        to_goal,
        curvature,
        bearing: atan2f(y_r, x_r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_the_line_heading_along_it_goes_straight() {
        let t = track([0.0, 0.0], [2.0, 0.0], [0.5, 0.0], 0.0, 0.4);
        assert!(t.curvature.abs() < 1e-6 && t.bearing.abs() < 1e-6, "{t:?}");
        assert!((t.along - 0.5).abs() < 1e-6 && (t.to_goal - 1.5).abs() < 1e-6);
    }

    #[test]
    fn right_of_the_line_it_turns_left_onto_it() {
        let t = track([0.0, 0.0], [2.0, 0.0], [0.5, -0.1], 0.0, 0.4);
        assert!(t.curvature > 0.5 && t.bearing > 0.0, "{t:?}");
        // kappa = 2 y / L^2 with the goal point (0.9, 0): y = 0.1, L^2 = 0.17.
        assert!((t.curvature - 0.2 / 0.17).abs() < 1e-4, "{t:?}");
    }

    #[test]
    fn a_goal_behind_has_a_bearing_beyond_a_right_angle() {
        let t = track([0.0, 0.0], [-1.0, 0.0], [0.0, 0.0], 0.0, 0.4);
        assert!(t.bearing.abs() > 3.0, "{t:?}");
    }
}
