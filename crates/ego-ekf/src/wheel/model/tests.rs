//! Unit tests of the parent module.
use super::*;
use crate::state::Quat;
use vslam_core::Timestamp;

use crate::test_rng::Rng;

impl WheelRows {
    /// The row-by-row form with nalgebra's operators (before the
    /// lanes): the reference for the bits.
    fn p_ht_nalgebra(&self, p: &Covariance) -> SMatrix<f32, DIM, 4> {
        let f = &self.mid;
        let [h_f, d, ..] = &self.h;
        let [.., rad_f0, rad_f1] = *h_f;
        let [
            _,
            _,
            _,
            _,
            _,
            _,
            dg0,
            dg1,
            dg2,
            _,
            _,
            _,
            dc0,
            dc1,
            dc2,
            dr0,
            dr1,
            dr2,
            rad_d0,
            rad_d1,
        ] = *d;
        let (d_bg, d_c, d_rb) = (
            Vec3::new(dg0, dg1, dg2),
            Vec3::new(dc0, dc1, dc2),
            Vec3::new(dr0, dr1, dr2),
        );
        let mut out = SMatrix::<f32, DIM, 4>::zeros();
        let [o0, o1, o2, o3] = &mut out.data.0;
        let outs = o0.iter_mut().zip(o1.iter_mut()).zip(o2.iter_mut());
        for (row, (((f0, f1), f2), f3)) in p.data.0.iter().zip(outs.zip(o3.iter_mut())) {
            // Row i of P is column i (symmetry), entries at the support.
            let [
                v0,
                v1,
                v2,
                t0,
                t1,
                t2,
                g0,
                g1,
                g2,
                l0,
                l1,
                l2,
                r0,
                r1,
                r2,
                b0,
                b1,
                b2,
                a0,
                a1,
            ] = support_of(row);
            let (t_bg, t_cl, t_cr, t_rb) = (
                Vec3::new(g0, g1, g2),
                Vec3::new(l0, l1, l2),
                Vec3::new(r0, r1, r2),
                Vec3::new(b0, b1, b2),
            );
            let u = f.r_wb_t * Vec3::new(v0, v1, v2)
                + f.v_b.cross(&Vec3::new(t0, t1, t2))
                + f.p_mid.cross(&t_bg)
                + f.half_w.cross(&(t_cl + t_cr))
                - f.u_mid.cross(&t_rb);
            let m = f.r_rb * u;
            *f0 = m.x + (rad_f0 * a0 + rad_f1 * a1);
            *f2 = m.y;
            *f3 = m.z;
            *f1 = d_bg.dot(&t_bg)
                + d_c.dot(&(t_cr - t_cl))
                + d_rb.dot(&t_rb)
                + (rad_d0 * a0 + rad_d1 * a1);
        }
        out
    }
}

/// The block-of-rows form gives the bits of the row-by-row form with
/// nalgebra's operators, on exactly symmetric covariances.
#[test]
fn p_ht_blocks_equal_the_nalgebra_rows_bit_for_bit() {
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    for _ in 0..200 {
        let a = SMatrix::<f32, DIM, DIM>::from_fn(|_, _| rng.next());
        let p = a * a.transpose() + Covariance::identity() * 0.1;
        let p = (p + p.transpose()) * 0.5;
        let q_wb = Quat::from_scaled_axis(rng.vec3(6.0));
        let x = NominalState {
            p_wb: rng.vec3(4.0),
            v_wb: rng.vec3(1.0),
            q_wb,
            accel_bias: Vec3::zeros(),
            gyro_bias: Vec3::zeros(),
            gravity: Vec3::new(0.0, 0.0, -9.81),
            gyro_scale: 0.0,
            clone_p_wb: Vec3::zeros(),
            clone_q_wb: q_wb,
            p_bl: Vec3::new(0.0, 0.115, -0.06) + rng.vec3(0.02),
            p_br: Vec3::new(0.0, -0.115, -0.06) + rng.vec3(0.02),
            q_rb: Quat::from_scaled_axis(rng.vec3(0.1)),
            radius_left: 0.035 + 0.002 * rng.next(),
            radius_right: 0.035 + 0.002 * rng.next(),
        };
        let rates = WheelRates::new(Timestamp(0), 20.0 * rng.next(), 20.0 * rng.next())
            .unwrap_or_else(|_| unreachable!());
        let mut rows = wheel_rows(&x, &rng.vec3(2.0), &rates, &GripParams::default());
        // The support's columns only (the scale factor's is added apart).
        rows.scale = [0.0; 4];
        let (fast, slow) = (rows.p_ht(&p), rows.p_ht_nalgebra(&p));
        for (f, s) in fast.iter().zip(slow.iter()) {
            assert_eq!(f.to_bits(), s.to_bits(), "{fast} vs {slow}");
        }
    }
}

/// Any infinite or NaN value anywhere in the rows is found, and large
/// finite values are not taken for infinite ones.
#[test]
fn rows_are_finite_unless_one_value_is_not() {
    let x = NominalState {
        p_wb: Vec3::zeros(),
        v_wb: Vec3::new(0.3, 0.0, 0.0),
        q_wb: Quat::identity(),
        accel_bias: Vec3::zeros(),
        gyro_bias: Vec3::zeros(),
        gravity: Vec3::new(0.0, 0.0, -9.81),
        gyro_scale: 0.0,
        clone_p_wb: Vec3::zeros(),
        clone_q_wb: Quat::identity(),
        p_bl: Vec3::new(0.0, 0.115, -0.06),
        p_br: Vec3::new(0.0, -0.115, -0.06),
        q_rb: Quat::identity(),
        radius_left: 0.035,
        radius_right: 0.035,
    };
    let rates = WheelRates::new(Timestamp(0), 8.0, 9.0).unwrap_or_else(|_| unreachable!());
    let rows = wheel_rows(
        &x,
        &Vec3::new(0.0, 0.0, 0.2),
        &rates,
        &GripParams::default(),
    );
    assert!(rows.is_finite());
    let mut big = rows;
    big.h = [[f32::MAX; SUPPORT_LEN]; 4];
    big.noise = [f32::MAX; 4];
    assert!(big.is_finite());
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for k in 0..4 {
            let mut r = rows;
            r.residual[k] = bad;
            assert!(!r.is_finite());
            let mut r = rows;
            r.noise[k] = bad;
            assert!(!r.is_finite());
            for c in 0..SUPPORT_LEN {
                let mut r = rows;
                r.h[k][c] = bad;
                assert!(!r.is_finite(), "h[{k}][{c}] = {bad}");
            }
        }
    }
}
