//! Unit tests of the parent module: the structured congruence against the
//! entry-by-entry formula over all of `P` and against `F P F^T` in `f64`.
use super::*;
use crate::gap::test_support::random_covariance;

use crate::test_rng::Rng;

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

/// The rows of the runs `runs`, and how often each row is in one.
fn rows(runs: &[(usize, usize)]) -> [u8; DIM] {
    let mut seen = [0u8; DIM];
    for &(a, e) in runs {
        seen[a..e].iter_mut().for_each(|k| *k += 1);
    }
    seen
}

#[test]
fn the_heading_rows_are_the_blocks_of_n() {
    // Every row in exactly one run, with the clone or without it.
    let count = |on: &[(usize, usize)], off: &[(usize, usize)]| {
        let (a, b) = (rows(on), rows(off));
        core::array::from_fn::<u8, DIM, _>(|i| a[i] + b[i])
    };
    assert_eq!(count(&ON, &OFF), [1; DIM]);
    assert_eq!(count(&ON_NO_CLONE, &OFF_NO_CLONE), [1; DIM]);
    let on = rows(&ON);
    let without_clone = rows(&ON_NO_CLONE);
    for i in 0..DIM {
        assert_eq!(
            without_clone[i] == 1,
            on[i] == 1 && !CLONE.contains(&i),
            "row {i}"
        );
    }
    // `N` is nonzero exactly on the runs, but for the vertical parts of
    // the crossed vectors.
    let mut rng = Rng(0x5eed_1234);
    for _ in 0..20 {
        let n = heading_direction(&state(&mut rng));
        for i in 0..DIM {
            let vertical = [P + 2, V + 2, G + 2, CP + 2].contains(&i);
            assert_eq!(n[i] != 0.0, on[i] == 1 && !vertical, "row {i}");
        }
    }
}

/// `p` after the re-anchoring of an update between two random states, by
/// [`rank_one_congruence`] and by [`congruence_everywhere`], with the
/// `d` and `u` used; `d` zero on the clone unless `clone_moves`.
fn both_forms(
    p: &Covariance,
    rng: &mut Rng,
    clone_moves: bool,
) -> (Covariance, Covariance, (ErrorState, Vec3)) {
    let (xa, xb) = (state(rng), state(rng));
    let mut d = heading_direction(&xa) - heading_direction(&xb);
    if !clone_moves {
        d.rows_range_mut(CLONE).fill(0.0);
    }
    let u = attitude_weights(&heading_direction(&xb)).unwrap();
    let s = heading_variance(p, &u).unwrap();
    let (mut fast, mut full) = (*p, *p);
    rank_one_congruence(&mut fast, &d, &u, s);
    congruence_everywhere(&mut full, &d, &u, s);
    (fast, full, (d, u))
}

#[test]
fn a_decoupled_clone_keeps_its_zero_rows() {
    let mut rng = Rng(0xdec0_0b1e);
    for case in 0..10 {
        let mut p = random_covariance(0xdec0 + case);
        // Decoupled: the clone's rows and columns zero outside its block.
        for i in CLONE {
            for j in 0..DIM {
                if !CLONE.contains(&j) {
                    p[(i, j)] = 0.0;
                    p[(j, i)] = 0.0;
                }
            }
        }
        let (fast, full, _) = both_forms(&p, &mut rng, false);
        for i in 0..DIM {
            for j in 0..DIM {
                assert_eq!(fast[(i, j)], full[(i, j)], "case {case} ({i}, {j})");
                if CLONE.contains(&i) != CLONE.contains(&j) {
                    assert_eq!(fast[(i, j)].to_bits(), 0, "case {case} ({i}, {j})");
                }
            }
        }
    }
}

#[test]
fn the_congruence_is_the_whole_expression_on_every_entry() {
    let mut rng = Rng(0x0bad_cafe);
    for case in 0..20 {
        let p0 = random_covariance(0x0bad + case);
        let (fast, full, (d, u)) = both_forms(&p0, &mut rng, case % 2 == 0);
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
