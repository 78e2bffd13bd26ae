//! The upper triangle of the covariance copied onto the lower one, in 4x4
//! blocks transposed in registers, over [`DIM`] = `4 (DIM / 4) + DIM % 4`
//! (the last `DIM % 4` columns four rows at a time).

use crate::state::{Covariance, DIM};

/// Copies the upper triangle of `p` onto the lower one.
///
/// In 4x4 blocks: each block above the diagonal is loaded by its four
/// column pieces (contiguous), transposed in registers and stored as the
/// four column pieces of its mirror image; a diagonal block by the same
/// transpose, keeping its upper half; the last `DIM % 4` columns four rows
/// at a time. The strided entry-by-entry copy cost about
/// twice as many instructions (callgrind, `examples/ekf_steps`).
pub fn mirror_upper_to_lower(p: &mut Covariance) {
    mirror_leading(p, DIM);
}

/// [`mirror_upper_to_lower`] on the leading `n x n` block only (`n <= DIM`;
/// the rest is left as it is): the columns past the block's last whole
/// 4x4 block entry by entry, unless `n = DIM`.
pub(crate) fn mirror_leading(p: &mut Covariance, n: usize) {
    const QUADS: usize = DIM / 4;
    if n < DIM {
        let first = 4 * (n / 4);
        let cols = &mut p.data.0;
        for j in first..n {
            let Some((left, [col, ..])) = cols.split_at_mut_checked(j) else {
                continue;
            };
            // Entry (i, j) above the diagonal, in column j, to (j, i).
            for (dst, &v) in left.iter_mut().zip(col.iter()) {
                if let Some(d) = dst.get_mut(j) {
                    *d = v;
                }
            }
        }
    }
    let (quads, last) = p.data.0.as_chunks_mut::<4>();
    for bj in 0..quads.len().min(n / 4) {
        let Some((left, right)) = quads.split_at_mut_checked(bj) else {
            continue;
        };
        let Some(src) = right.first_mut() else {
            continue;
        };
        // Blocks (bi, bj) above the diagonal to (bj, bi).
        let [c0, c1, c2, c3] = src.each_ref().map(|c| c.as_chunks::<4>().0);
        for ((((dst, b0), b1), b2), b3) in left.iter_mut().zip(c0).zip(c1).zip(c2).zip(c3) {
            let t = transpose4([*b0, *b1, *b2, *b3]);
            for (d, piece) in dst.iter_mut().zip(t) {
                if let Some(x) = d.as_chunks_mut::<4>().0.get_mut(bj) {
                    *x = piece;
                }
            }
        }
        // The diagonal block: below its diagonal from above it.
        let a = src
            .each_ref()
            .map(|c| c.as_chunks::<4>().0.get(bj).copied());
        if let [Some(a0), Some(a1), Some(a2), Some(a3)] = a {
            let a = [a0, a1, a2, a3];
            let t = transpose4(a);
            for (r, (d, (mut own, mirrored))) in
                src.iter_mut().zip(a.into_iter().zip(t)).enumerate()
            {
                for (c, (o, m)) in own.iter_mut().zip(mirrored).enumerate() {
                    if c > r {
                        *o = m;
                    }
                }
                if let Some(x) = d.as_chunks_mut::<4>().0.get_mut(bj) {
                    *x = own;
                }
            }
        }
    }
    // The last columns' rows above the diagonal go to the last rows of the
    // columns on their left, four rows (one column quad) at a time.
    const REST: usize = DIM % 4;
    if let (Some(last), true) = (last.first_chunk_mut::<REST>(), n == DIM) {
        let mut blocks = last.each_ref().map(|c| c.as_chunks::<4>().0.iter());
        for dst in quads.iter_mut() {
            let b = blocks.each_mut().map(|it| it.next());
            for (m, d) in dst.iter_mut().enumerate() {
                if let Some(tail) = d.as_chunks_mut::<4>().1.first_chunk_mut::<REST>() {
                    for (x, b) in tail.iter_mut().zip(b) {
                        *x = b.and_then(|b| b.get(m)).copied().unwrap_or(0.0);
                    }
                }
            }
        }
        // The corner: below its diagonal from above it (entry `(r, t)`,
        // `r > t`, of the last columns from entry `(t, r)`).
        let first = 4 * QUADS;
        let corner: [[f32; REST]; REST] = core::array::from_fn(|t| {
            let col = last.get(t);
            core::array::from_fn(|r| col.and_then(|c| c.get(first + r)).copied().unwrap_or(0.0))
        });
        for (t, col) in last.iter_mut().enumerate() {
            for (r, upper) in corner.iter().enumerate().skip(t + 1) {
                if let (Some(d), Some(v)) = (col.get_mut(first + r), upper.get(t)) {
                    *d = *v;
                }
            }
        }
    }
}

/// The transpose of a 4x4 block given by its columns: on hosts with SSE in
/// eight shuffles ([`wide::f32x4::transpose`]; written out entry by entry,
/// the compiler moves every entry on its own: two scalar moves each).
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn transpose4(a: [[f32; 4]; 4]) -> [[f32; 4]; 4] {
    wide::f32x4::transpose(a.map(wide::f32x4::new)).map(|v| v.to_array())
}

/// The transpose of a 4x4 block given by its columns.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn transpose4(a: [[f32; 4]; 4]) -> [[f32; 4]; 4] {
    let [
        [a00, a10, a20, a30],
        [a01, a11, a21, a31],
        [a02, a12, a22, a32],
        [a03, a13, a23, a33],
    ] = a;
    [
        [a00, a01, a02, a03],
        [a10, a11, a12, a13],
        [a20, a21, a22, a23],
        [a30, a31, a32, a33],
    ]
}
