//! The maths of differential-drive dead reckoning over an IMU gap.
//!
//! The planar pose of the robot origin is integrated from the wheel rates
//! in the robot frame at the start of the gap (Siegwart, Nourbakhsh and
//! Scaramuzza, *Introduction to Autonomous Mobile Robots*, 2nd ed., 2011,
//! sec. 5.2.4, eqs. 5.6-5.9; midpoint heading): for a step of `dt` with
//! wheel rates `w_l`, `w_r`, radii `r_l`, `r_r` and track `L`,
//!
//! - speed `v = (r_l w_l + r_r w_r) / 2`, yaw rate `w = (r_r w_r - r_l w_l) / L`
//!   (the shared formulas of [`vslam_core::kinematics::diff_drive`]);
//! - `psi_m = psi + w dt / 2`, `x += v dt cos psi_m`, `y += v dt sin psi_m`,
//!   `psi += w dt`.
//!
//! Alongside, two things the filter needs to fold the result into its
//! covariance:
//!
//! - the covariance `S` of the dead-reckoning noise in `(x, y, psi)`, grown
//!   per step as in Siegwart et al. eq. 5.9 (`S <- A S A^T + N`): each wheel
//!   sample's forward noise `s_f` (the grip's, as the wheel update uses it)
//!   gives the speed variance `s_f^2 / 2` and the yaw-rate variance
//!   `2 s_f^2 / L^2` (uncorrelated, as rows 0 and 1 of the wheel
//!   measurement, [`crate::wheel::model`]), the non-holonomic constraint's
//!   noise `s_l` a sideways speed; each held over the step `dt`;
//! - the Jacobian `J` of `(x, y, psi)` with respect to the wheel radii and
//!   the track, so the filter's own uncertainty about them (estimated states)
//!   carries into the pose;
//! - the latest step's speed and yaw rate and their Jacobian, the robot's
//!   motion at the end (the filter's velocity after the gap).

use nalgebra::{Matrix2x3, Matrix3, RowVector3, Vector3};
use vslam_core::kinematics::{mid_axle, rim, turn};

/// What the filter knows of the wheels when a sample is integrated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelGeometry {
    /// Left wheel radius, m.
    pub radius_left: f32,
    /// Right wheel radius, m.
    pub radius_right: f32,
    /// Track (lateral distance between the contact points), m.
    pub track: f32,
    /// Forward wheel-speed noise of one sample, m/s.
    pub forward_std: f32,
    /// Sideways (non-holonomic) speed noise of one sample, m/s.
    pub lateral_std: f32,
}

impl WheelGeometry {
    /// Whether every value is finite and positive (the track and radii
    /// strictly; a zero noise is allowed).
    pub fn is_valid(&self) -> bool {
        let positive = [self.radius_left, self.radius_right, self.track];
        let noise = [self.forward_std, self.lateral_std];
        positive.iter().all(|v| v.is_finite() && *v > 0.0)
            && noise.iter().all(|v| v.is_finite() && *v >= 0.0)
    }

    /// Forward speed and yaw rate for wheel rates `left`, `right`, rad/s.
    pub fn motion(&self, left: f32, right: f32) -> (f32, f32) {
        let (vl, vr) = (rim(self.radius_left, left), rim(self.radius_right, right));
        (mid_axle(vl, vr), turn(vl, vr, self.track))
    }

    /// Variance of the yaw rate one sample measures, (rad/s)^2.
    pub fn yaw_rate_var(&self) -> f32 {
        2.0 * self.forward_std * self.forward_std / (self.track * self.track)
    }
}

/// The planar motion integrated so far, in the robot frame at the start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeadReckoning {
    /// Forward displacement, m.
    pub x: f32,
    /// Leftward displacement, m.
    pub y: f32,
    /// Heading change, rad (counter-clockwise seen from above).
    pub psi: f32,
    /// Noise covariance of `(x, y, psi)`.
    pub noise: Matrix3<f32>,
    /// Jacobian of `(x, y, psi)` (rows) w.r.t. `(r_l, r_r, L)` (columns).
    pub jacobian: Matrix3<f32>,
    /// Time integrated, s.
    pub elapsed: f32,
    /// Forward speed of the latest step, m/s.
    pub speed: f32,
    /// Yaw rate of the latest step, rad/s.
    pub yaw_rate: f32,
    /// Jacobian of `(speed, yaw_rate)` w.r.t. `(r_l, r_r, L)`.
    pub rate_jacobian: Matrix2x3<f32>,
    /// Noise variances of the latest step's forward speed, sideways speed
    /// ((m/s)^2, also used for the vertical) and yaw rate ((rad/s)^2).
    pub rate_var: Vector3<f32>,
}

impl Default for DeadReckoning {
    fn default() -> Self {
        Self::ZERO
    }
}

impl DeadReckoning {
    /// No motion integrated (the default), as a constant.
    pub const ZERO: Self = DeadReckoning {
        x: 0.0,
        y: 0.0,
        psi: 0.0,
        noise: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        jacobian: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        elapsed: 0.0,
        speed: 0.0,
        yaw_rate: 0.0,
        rate_jacobian: Matrix2x3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        rate_var: Vector3::new(0.0, 0.0, 0.0),
    };
}

impl DeadReckoning {
    /// Integrates one step of `dt` seconds with wheel rates `left`, `right`
    /// (rad/s). Returns `false` and changes nothing if the result is not
    /// finite (the caller checks the inputs).
    pub fn step(&mut self, geometry: &WheelGeometry, left: f32, right: f32, dt: f32) -> bool {
        let mut next = *self;
        next.integrate(geometry, left, right, dt);
        let finite = [next.x, next.y, next.psi, next.elapsed, next.speed]
            .iter()
            .chain([next.yaw_rate].iter())
            .chain(next.noise.iter())
            .chain(next.jacobian.iter())
            .chain(next.rate_jacobian.iter())
            .chain(next.rate_var.iter())
            .all(|v| v.is_finite());
        if finite {
            *self = next;
        }
        finite
    }

    fn integrate(&mut self, g: &WheelGeometry, left: f32, right: f32, dt: f32) {
        let (v, w) = g.motion(left, right);
        let psi_m = self.psi + 0.5 * w * dt;
        let (s, c) = (libm::sinf(psi_m), libm::cosf(psi_m));
        let ds = v * dt;
        // Jacobians of v and w w.r.t. (r_l, r_r, L).
        let dv = RowVector3::new(0.5 * left, 0.5 * right, 0.0);
        let dw = RowVector3::new(-left / g.track, right / g.track, -w / g.track);
        let j_psi = self.jacobian.row(2).into_owned();
        let j_psi_m = j_psi + dw * (0.5 * dt);
        let j_x = self.jacobian.row(0) + dv * (c * dt) - j_psi_m * (s * ds);
        let j_y = self.jacobian.row(1) + dv * (s * dt) + j_psi_m * (c * ds);
        self.jacobian.set_row(0, &j_x);
        self.jacobian.set_row(1, &j_y);
        self.jacobian.set_row(2, &(j_psi + dw * dt));
        // Noise: S <- A S A^T + N, A = d(x, y, psi)+ / d(x, y, psi).
        let a = Matrix3::new(1.0, 0.0, -s * ds, 0.0, 1.0, c * ds, 0.0, 0.0, 1.0);
        let var_v = 0.5 * g.forward_std * g.forward_std * dt * dt;
        let var_l = g.lateral_std * g.lateral_std * dt * dt;
        let var_w = g.yaw_rate_var() * dt * dt;
        let n = Matrix3::new(
            c * c * var_v + s * s * var_l,
            c * s * (var_v - var_l),
            0.0,
            c * s * (var_v - var_l),
            s * s * var_v + c * c * var_l,
            0.0,
            0.0,
            0.0,
            var_w,
        );
        self.noise = a * self.noise * a.transpose() + n;
        self.x += c * ds;
        self.y += s * ds;
        self.psi += w * dt;
        self.elapsed += dt;
        self.speed = v;
        self.yaw_rate = w;
        self.rate_jacobian.set_row(0, &dv);
        self.rate_jacobian.set_row(1, &dw);
        self.rate_var = Vector3::new(
            0.5 * g.forward_std * g.forward_std,
            g.lateral_std * g.lateral_std,
            g.yaw_rate_var(),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRACK: f32 = 0.23;
    const R: f32 = 0.035;

    fn geometry() -> WheelGeometry {
        WheelGeometry {
            radius_left: R,
            radius_right: R,
            track: TRACK,
            forward_std: 0.02,
            lateral_std: 0.01,
        }
    }

    /// Wheel rates for forward speed `v` and yaw rate `w`.
    fn rates(v: f32, w: f32) -> (f32, f32) {
        ((v - 0.5 * w * TRACK) / R, (v + 0.5 * w * TRACK) / R)
    }

    #[test]
    fn a_constant_turn_follows_the_circle() {
        let (v, w) = (0.3, 0.8);
        let (l, r) = rates(v, w);
        let mut d = DeadReckoning::default();
        for _ in 0..100 {
            assert!(d.step(&geometry(), l, r, 0.02));
        }
        // 2 s on a circle of radius v / w.
        let (t, rho) = (2.0f32, v / w);
        let psi = w * t;
        assert!((d.psi - psi).abs() < 1e-4, "{}", d.psi);
        assert!((d.x - rho * libm::sinf(psi)).abs() < 1e-3, "{}", d.x);
        assert!(
            (d.y - rho * (1.0 - libm::cosf(psi))).abs() < 1e-3,
            "{}",
            d.y
        );
        assert!((d.speed - v).abs() < 1e-5 && (d.yaw_rate - w).abs() < 1e-5);
        assert!((d.elapsed - t).abs() < 1e-5);
    }

    #[test]
    fn yaw_variance_grows_by_the_wheel_yaw_rate_variance() {
        let g = geometry();
        let (l, r) = rates(0.3, 0.5);
        let mut d = DeadReckoning::default();
        let (n, dt) = (50, 0.02f32);
        for _ in 0..n {
            assert!(d.step(&g, l, r, dt));
        }
        let expected = n as f32 * 2.0 * 0.02 * 0.02 / (TRACK * TRACK) * dt * dt;
        let got = d.noise[(2, 2)];
        assert!(
            (got - expected).abs() < 1e-3 * expected,
            "{got} vs {expected}"
        );
        // Much less than the generic 1 rad/s/sqrt(Hz) over the same second.
        assert!(got < 1e-3);
        // Symmetric positive definite.
        assert!((d.noise - d.noise.transpose()).amax() < 1e-12);
        assert!(d.noise.cholesky().is_some());
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let (l, r) = rates(0.25, 0.7);
        let run = |g: &WheelGeometry| {
            let mut d = DeadReckoning::default();
            for _ in 0..50 {
                d.step(g, l, r, 0.02);
            }
            d
        };
        let base = run(&geometry());
        let h = 1e-4f32;
        for col in 0..3 {
            let mut g = geometry();
            match col {
                0 => g.radius_left += h,
                1 => g.radius_right += h,
                _ => g.track += h,
            }
            let d = run(&g);
            let fd = [
                (d.x - base.x) / h,
                (d.y - base.y) / h,
                (d.psi - base.psi) / h,
            ];
            for (row, fd) in fd.iter().enumerate() {
                let j = base.jacobian[(row, col)];
                assert!(
                    (j - fd).abs() < 0.02 * fd.abs().max(0.5),
                    "J[{row},{col}] {j} vs {fd}"
                );
            }
        }
    }

    #[test]
    fn a_non_finite_step_changes_nothing() {
        let mut d = DeadReckoning::default();
        assert!(d.step(&geometry(), 8.0, 9.0, 0.02));
        let before = d;
        assert!(!d.step(&geometry(), f32::NAN, 9.0, 0.02));
        assert!(!d.step(&geometry(), f32::INFINITY, 9.0, 0.02));
        assert_eq!(d, before);
        let bad = WheelGeometry {
            track: 0.0,
            ..geometry()
        };
        assert!(!bad.is_valid());
        assert!(geometry().is_valid());
    }
}
