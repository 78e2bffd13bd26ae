//! Unit tests of the parent module: the structured congruence against the
//! entry-by-entry formula over all of `P` and against `F P F^T` in `f64`.
use super::*;

/// xorshift in [-0.5, 0.5).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    }
    fn vec3(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * scale
    }
}

/// A symmetric positive definite `P` with correlations everywhere.
fn covariance(rng: &mut Rng) -> Covariance {
    let a = Covariance::from_fn(|_, _| rng.next());
    a * a.transpose() * (1.0 / DIM as f32) + Covariance::identity() * 1e-3
}

/// A state with every block of `N` moved away from zero.
fn state(rng: &mut Rng) -> NominalState {
    NominalState {
        p_wb: rng.vec3(8.0),
        v_wb: rng.vec3(1.0),
        q_wb: Quat::from_scaled_axis(rng.vec3(2.0)),
        accel_bias: rng.vec3(0.1),
        gyro_bias: rng.vec3(0.01),
        gravity: Vec3::new(0.0, 0.0, -9.81) + rng.vec3(0.1),
        gyro_scale: 0.01,
        clone_p_wb: rng.vec3(8.0),
        clone_q_wb: Quat::from_scaled_axis(rng.vec3(2.0)),
        p_bl: Vec3::new(0.01, 0.115, -0.06),
        p_br: Vec3::new(-0.01, -0.115, -0.06),
        q_rb: Quat::from_scaled_axis(rng.vec3(0.1)),
        radius_left: 0.035,
        radius_right: 0.036,
    }
}

/// `P += d b^T + b d^T + s d d^T` on every entry, the full expression.
fn congruence_everywhere(p: &mut Covariance, d: &ErrorState, u: &Vec3, s: f32) {
    let b: ErrorState = p.fixed_columns::<3>(TH) * u;
    for j in 0..DIM {
        for i in 0..DIM {
            p[(i, j)] += (d[i] * b[j] + b[i] * d[j]) + s * (d[i] * d[j]);
        }
    }
}

#[test]
fn the_heading_rows_are_the_blocks_of_n() {
    // Every row in exactly one run; the runs of `ON` are `N`'s blocks.
    let mut seen = [0u8; DIM];
    for &(a, e) in ON.iter().chain(&OFF) {
        seen[a..e].iter_mut().for_each(|k| *k += 1);
    }
    assert_eq!(seen, [1; DIM]);
    let on = ON.iter().flat_map(|&(a, e)| a..e);
    let off = OFF.iter().flat_map(|&(a, e)| a..e);
    assert_eq!(on.clone().count(), 3 * ON_BLOCKS.len());
    assert!(ON_BLOCKS.iter().all(|&b| on.clone().any(|i| i == b)));
    let mut rng = Rng(0x5eed_1234);
    for _ in 0..20 {
        let n = heading_direction(&state(&mut rng));
        for i in off.clone() {
            assert_eq!(n[i], 0.0, "row {i}");
        }
        for i in on.clone() {
            // Only the vertical parts of the crossed vectors are zero.
            let vertical = [P + 2, V + 2, G + 2, CP + 2].contains(&i);
            assert_eq!(n[i] == 0.0, vertical, "row {i}");
        }
    }
}

#[test]
fn the_congruence_is_the_whole_expression_on_every_entry() {
    let mut rng = Rng(0x0bad_cafe);
    for case in 0..20 {
        let p0 = covariance(&mut rng);
        let (xa, xb) = (state(&mut rng), state(&mut rng));
        let mut d = heading_direction(&xa) - heading_direction(&xb);
        if case % 2 == 1 {
            d.rows_range_mut(CLONE).fill(0.0);
        }
        let u = attitude_weights(&heading_direction(&xb)).unwrap();
        let s = heading_variance(&p0, &u).unwrap();
        let (mut fast, mut full) = (p0, p0);
        rank_one_congruence(&mut fast, &d, &u, s);
        congruence_everywhere(&mut full, &d, &u, s);
        for j in 0..DIM {
            for i in 0..DIM {
                // Equal (a zero's sign aside) to the expression with its
                // zero terms, and symmetric bit for bit.
                assert_eq!(fast[(i, j)], full[(i, j)], "case {case} ({i}, {j})");
                assert_eq!(fast[(i, j)].to_bits(), fast[(j, i)].to_bits(), "({i}, {j})");
            }
        }
        // And `F P F^T`, `F = I + d u^T` on the attitude columns, in f64.
        let mut f = nalgebra::SMatrix::<f64, DIM, DIM>::identity();
        for i in 0..DIM {
            for k in 0..3 {
                f[(i, TH + k)] += f64::from(d[i]) * f64::from(u[k]);
            }
        }
        let want = f * p0.cast::<f64>() * f.transpose();
        let scale = want.amax();
        let err = (fast.cast::<f64>() - want).amax();
        assert!(err < 1e-5 * scale, "case {case}: {err:e} of {scale:e}");
    }
}
