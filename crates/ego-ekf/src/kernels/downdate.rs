//! `P <- P - W W^T` in place: the covariance downdate of the Kalman update
//! (`K S K^T = W W^T` with `W = P H^T L^-T`, see [`crate::update`]), on
//! the upper triangle or on both, written over [`DIM`] and the clone's
//! rows [`CLONE`] of the state table. Every entry is
//! `P[i, j] - W[i, 0] W[j, 0] - W[i, 1] W[j, 1] - ...` in that order, on
//! every target, so host and Cortex-M give the same bits.

use nalgebra::SMatrix;

#[cfg(not(target_arch = "arm"))]
use super::lanes::Lanes;
#[cfg(not(target_arch = "arm"))]
use super::mirror::mirror_leading;
use super::{entry_minus, row_of};
use crate::state::{CLONE, Covariance, DIM};

/// `P <- P - W W^T` on every entry, column by column: entry `(i, j)` is
/// `P[i, j] - W[i, 0] W[j, 0] - W[i, 1] W[j, 1] - ...` in that order, so
/// the result is exactly symmetric if `P` was, and bit for bit equal to
/// [`downdate_upper`] followed by [`mirror_upper_to_lower`](super::mirror_upper_to_lower) (which the
/// update uses: half the products; measured cheaper on the host too, with
/// the reset done on the triangle before the mirror).
pub fn downdate<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>) {
    for (j, col) in p.data.0.iter_mut().enumerate() {
        let wj = row_of(w, j);
        for (i, pij) in col.iter_mut().enumerate() {
            *pij = entry_minus(*pij, w, i, &wj);
        }
    }
}

/// `P <- P - W W^T` on the upper triangle of `P` (row <= column): every
/// entry is `P[i, j] - W[i, 0] W[j, 0] - W[i, 1] W[j, 1] - ...` in that
/// order, as in [`downdate`] (so that with [`mirror_upper_to_lower`](super::mirror_upper_to_lower) the
/// two agree bit for bit, and the host with the firmware). On hosts with
/// vector units each column's rows are taken in blocks of four (rounded up
/// past the diagonal: the few lower-triangle entries this also updates are
/// overwritten by the mirror), in a loop (not unrolled: see below);
/// on Cortex-M (`target_arch = "arm"`, scalar) four columns at a time, so
/// that their rows of `W` stay in registers and each row of `W` is loaded
/// once per four entries, and the lower triangle written too (the
/// symmetric downdate's code: one copy in flash).
pub fn downdate_upper<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>) {
    downdate_upper_with(p, w, clone_rows_zero(w));
}

/// [`downdate_upper`] with [`clone_rows_zero`] known: `skip_clone` must
/// equal `clone_rows_zero(w)`.
#[inline]
pub(crate) fn downdate_upper_with<const M: usize>(
    p: &mut Covariance,
    w: &SMatrix<f32, DIM, M>,
    skip_clone: bool,
) {
    #[cfg(not(target_arch = "arm"))]
    {
        // W's rows in blocks of four, block by block: `wb[k][r]` holds
        // rows `4k..4k + 4` of column `r`.
        const QUADS: usize = DIM / 4;
        let wb: [[Lanes<4>; M]; QUADS] =
            core::array::from_fn(|k| w.data.0.each_ref().map(|c| Lanes::load(c, 4 * k)));
        // Each column's blocks down to the one holding its diagonal: `j / 4
        // + 1` for column `j`, a loop, not unrolled. Unrolled per quad of
        // columns the wheel step took 570 fewer instructions, but the
        // function was 15.3 KB instead of 1.2 KB, and run side by side
        // with the loop on the other core the 3-D update was slower in 22
        // of 30 rounds (the 4-row wheel update: no difference; see
        // `benches/README.md`). With W zero on the clone's rows (a
        // decoupled clone), the clone's columns are left as they are: the
        // same bits as subtracting zeros.
        let end = if skip_clone { CLONE.start } else { DIM };
        let (quads, last) = p.data.0.as_chunks_mut::<4>();
        for (j, col) in quads.as_flattened_mut().iter_mut().enumerate().take(end) {
            downdate_column(col, &wb, row_of(w, j), j / 4 + 1);
        }
        // The last `DIM % 4` columns (those taking part): every block,
        // then their rows past the last whole block down to the diagonal.
        let first = 4 * QUADS;
        for (t, col) in last.iter_mut().enumerate().take(end.saturating_sub(first)) {
            let j = first + t;
            let wj = row_of(w, j);
            downdate_column(col, &wb, wj, QUADS);
            if let Some(rows) = col.get_mut(first..=j) {
                for (r, pij) in rows.iter_mut().enumerate() {
                    *pij = entry_minus(*pij, w, first + r, &wj);
                }
            }
        }
    }
    // Cortex-M: both triangles, the same code as the symmetric downdate
    // (the lower triangle is the mirror's anyway; one copy of the unrolled
    // blocks in flash instead of two).
    #[cfg(target_arch = "arm")]
    downdate_blocked(p, w, skip_clone);
}

/// The first `blocks` blocks of four rows of a column of
/// [`downdate_upper`], given `W` in blocks (`wb`) and the column's row of
/// `W` (`wj`).
#[cfg(not(target_arch = "arm"))]
#[inline(always)]
fn downdate_column<const M: usize>(
    col: &mut [f32; DIM],
    wb: &[[Lanes<4>; M]; DIM / 4],
    wj: [f32; M],
    blocks: usize,
) {
    for (block, wk) in col.as_chunks_mut::<4>().0.iter_mut().zip(wb).take(blocks) {
        let mut v = Lanes(*block);
        for (w_r, a) in wk.iter().zip(wj) {
            v = v - *w_r * Lanes::from(a);
        }
        *block = v.0;
    }
}

/// `P <- P - W W^T` on both triangles, bit for bit [`downdate_upper`]
/// followed by [`mirror_upper_to_lower`](super::mirror_upper_to_lower): on hosts exactly that; on
/// Cortex-M the four-column pass also stores each entry above the diagonal
/// into its mirror image (contiguous in the column of its row), so no
/// separate mirror pass runs.
pub fn downdate_symmetric<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>) {
    downdate_symmetric_with(p, w, clone_rows_zero(w));
}

/// [`downdate_symmetric`] with [`clone_rows_zero`] known: `skip_clone`
/// must equal `clone_rows_zero(w)`.
#[inline]
pub(crate) fn downdate_symmetric_with<const M: usize>(
    p: &mut Covariance,
    w: &SMatrix<f32, DIM, M>,
    skip_clone: bool,
) {
    #[cfg(not(target_arch = "arm"))]
    {
        downdate_upper_with(p, w, skip_clone);
        // A decoupled clone's rows and columns were left as they were
        // (symmetric): only the states before it need the mirror.
        mirror_leading(p, if skip_clone { CLONE.start } else { DIM });
    }
    #[cfg(target_arch = "arm")]
    downdate_blocked(p, w, skip_clone);
}

/// [`downdate_block`] for the columns `J..J + 4` of every `J` in the list
/// with `FROM <= J` and `J + 4 <= TO` (constants: the other calls compile
/// to nothing), `M` being the caller's number of rows of `W`. The list
/// covers states up to [`MAX_DIM`]; a larger state extends it.
#[cfg(target_arch = "arm")]
macro_rules! downdate_blocks {
    ($cols:ident, $w:ident, $from:expr, $to:expr) => {
        downdate_blocks!(@ $cols, $w, $from, $to;
            0 4 8 12 16 20 24 28 32 36 40 44 48 52 56 60);
    };
    (@ $cols:ident, $w:ident, $from:expr, $to:expr; $($j:literal)*) => {
        $(
            if const { $from <= $j && $j + 4 <= $to } {
                downdate_block::<$j, M>($cols, $w);
            }
        )*
    };
}

/// The Cortex-M downdate, four columns `j..j + 4` at a time
/// ([`downdate_block`]) over the whole blocks of four, then the columns
/// left over (`DIM % 4`, or `CLONE.start % 4` with `skip`) over all the
/// rows taking part ([`downdate_tail`]). With `skip` (a decoupled clone),
/// only the states before the clone: the first `CLONE.start` rows and
/// columns (the clone is the last block of the state). Both triangles are
/// written: each entry above the diagonal also at its mirror image. Every
/// block's columns are constants, so its rows of `W` and its addresses
/// need no checks: with the column start a run-time value the wheel update
/// took 1,720 more instructions (`firmware/profile --annotate`: about 289
/// per block for its setup and diagonal rows, much of it checks and
/// address arithmetic). The price is flash: 7 to 16 KB per `M`.
#[cfg(target_arch = "arm")]
#[inline(never)]
fn downdate_blocked<const M: usize>(p: &mut Covariance, w: &SMatrix<f32, DIM, M>, skip: bool) {
    /// The columns of the whole blocks before the clone.
    const BEFORE_CLONE: usize = 4 * (CLONE.start / 4);
    /// The columns of all the whole blocks.
    const WHOLE: usize = 4 * (DIM / 4);
    // With W zero on the clone's rows (a decoupled clone: `skip`), the
    // clone's rows and columns are left as they are: the same bits as
    // subtracting zeros.
    let cols = &mut p.data.0;
    downdate_blocks!(cols, w, 0, BEFORE_CLONE);
    if skip {
        downdate_tail::<BEFORE_CLONE, { CLONE.start }, M>(cols, w);
    } else {
        downdate_blocks!(cols, w, BEFORE_CLONE, WHOLE);
        downdate_tail::<WHOLE, DIM, M>(cols, w);
    }
}

/// The largest state [`downdate_blocks`] unrolls for (as the supports'
/// bit masks in [`crate::update::Support`]).
const MAX_DIM: usize = 64;
const _: () = assert!(DIM <= MAX_DIM);

/// Columns `J..J + 4` of the Cortex-M downdate: the rows `0..J` above the
/// block (each entry also stored at its mirror image `(J.., i)`,
/// contiguous in the column of its row), then the diagonal
/// block's four rows whole (its lower entries are the same products as its
/// upper ones, so equal bit for bit).
#[cfg(target_arch = "arm")]
#[inline(always)]
fn downdate_block<const J: usize, const M: usize>(
    cols: &mut [[f32; DIM]; DIM],
    w: &SMatrix<f32, DIM, M>,
) {
    let Some((left, [c0, c1, c2, c3, ..])) = cols.split_at_mut_checked(J) else {
        return;
    };
    let a = [
        row_of(w, J),
        row_of(w, J + 1),
        row_of(w, J + 2),
        row_of(w, J + 3),
    ];
    let rows = c0.iter_mut().zip(c1.iter_mut()).zip(c2.iter_mut());
    let mut rows = rows.zip(c3.iter_mut()).enumerate();
    // Above the block, with the mirror (`left` first: the zip stops on it
    // without taking a row).
    for (mirror, (i, (((p0, p1), p2), p3))) in left.iter_mut().zip(rows.by_ref()) {
        let v = block_entries(w, i, &a, [*p0, *p1, *p2, *p3]);
        [*p0, *p1, *p2, *p3] = v;
        if let Some(dst) = mirror.get_mut(J..J + 4) {
            dst.copy_from_slice(&v);
        }
    }
    // The diagonal block.
    for (i, (((p0, p1), p2), p3)) in rows.take(4) {
        [*p0, *p1, *p2, *p3] = block_entries(w, i, &a, [*p0, *p1, *p2, *p3]);
    }
}

/// Columns `J..N` (fewer than four) of the Cortex-M downdate over the rows
/// `0..N`, each entry above the diagonal also stored at its mirror image.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn downdate_tail<const J: usize, const N: usize, const M: usize>(
    cols: &mut [[f32; DIM]; DIM],
    w: &SMatrix<f32, DIM, M>,
) {
    let Some((left, right)) = cols.get_mut(..N).and_then(|c| c.split_at_mut_checked(J)) else {
        return;
    };
    for (c, col) in right.iter_mut().enumerate() {
        let jc = J + c;
        let wj = row_of(w, jc);
        let mut entries = col.iter_mut().enumerate().take(N);
        for (mirror, (i, pij)) in left.iter_mut().zip(entries.by_ref()) {
            let v = entry_minus(*pij, w, i, &wj);
            *pij = v;
            if let Some(dst) = mirror.get_mut(jc) {
                *dst = v;
            }
        }
        for (i, pij) in entries {
            *pij = entry_minus(*pij, w, i, &wj);
        }
    }
}

/// Entries `(i, j..j + 4)` of `P - W W^T` from their values `v` and the
/// rows `a` of `W` of the four columns: `v - W[i, 0] a[..][0] - ...`, in
/// that order (as [`entry_minus`]).
#[cfg(target_arch = "arm")]
#[inline(always)]
fn block_entries<const M: usize>(
    w: &SMatrix<f32, DIM, M>,
    i: usize,
    a: &[[f32; M]; 4],
    mut v: [f32; 4],
) -> [f32; 4] {
    let [a0, a1, a2, a3] = a;
    for (r, wir) in row_of(w, i).iter().enumerate() {
        let at = |a: &[f32; M]| a.get(r).copied().unwrap_or(0.0);
        v = mul_sub4(v, [at(a0), at(a1), at(a2), at(a3)], *wir);
    }
    v
}

/// Whether `W` is exactly zero on the clone's rows: then `P - W W^T`
/// leaves the clone's rows and columns as they are (this is so while the
/// filter keeps the clone decoupled, see
/// [`crate::covariance::decouple_clone`]: its cross terms are zero and no
/// measurement Jacobian has clone columns).
#[inline]
pub(crate) fn clone_rows_zero<const M: usize>(w: &SMatrix<f32, DIM, M>) -> bool {
    // The bits of every entry but the sign, or-ed: zero exactly when every
    // entry is `+0.0` or `-0.0` (an integer test, cheaper than comparing
    // floats on Cortex-M).
    let bits = w.data.0.iter().fold(0u32, |acc, col| {
        let rows = col.get(CLONE).unwrap_or(&[]);
        rows.iter().fold(acc, |a, v| a | (v.to_bits() << 1))
    });
    bits == 0
}

/// `acc - v a`, lane by lane.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn mul_sub4(acc: [f32; 4], v: [f32; 4], a: f32) -> [f32; 4] {
    let ([s0, s1, s2, s3], [v0, v1, v2, v3]) = (acc, v);
    [s0 - v0 * a, s1 - v1 * a, s2 - v2 * a, s3 - v3 * a]
}
