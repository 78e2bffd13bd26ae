//! The kept corners: a list sorted strongest first whose members keep a
//! minimum distance, filled greedily in the order candidates arrive.

use super::Corner;

/// The squared distance, exact in integers, rounded once to `f32`.
fn dist_sq(a: &Corner, b: &Corner) -> f32 {
    let (dx, dy) = (a.x.abs_diff(b.x) as u64, a.y.abs_diff(b.y) as u64);
    dx.saturating_mul(dx).saturating_add(dy.saturating_mul(dy)) as f32
}

/// Whether `a` and `b` are closer than `sqrt(min_dist_sq)`; `rows` is a
/// whole number of rows beyond reach (`> sqrt(min_dist_sq)`), which settles
/// most pairs of a raster scan without the distance.
fn within_reach(a: &Corner, b: &Corner, rows: usize, min_dist_sq: f32) -> bool {
    a.y.abs_diff(b.y) < rows && dist_sq(a, b) < min_dist_sq
}

/// The fewest whole rows more than `sqrt(min_dist_sq)`: `floor(sqrt) + 1`
/// (a correctly rounded square root below `2²⁴` never falls below the
/// integer part); no shortcut for larger distances.
fn rows_beyond_reach(min_dist_sq: f32) -> usize {
    if min_dist_sq < 1.0e14 {
        libm::sqrtf(min_dist_sq) as usize + 1
    } else {
        usize::MAX
    }
}

/// Offers `c` to the sorted list `out[..kept]` and returns its new length.
///
/// A candidate closer than `sqrt(min_dist_sq)` to a kept corner at least as
/// strong is dropped; kept corners within reach that are weaker are evicted;
/// it is inserted after every corner at least as strong; when the list is
/// full the weakest falls off (or the candidate, if it is not stronger).
///
/// A candidate only ever removes corners weaker than itself, so whether
/// corners weaker than some level were offered never changes which corners
/// at or above that level are kept, nor their order: the detector can offer
/// candidates against a provisional threshold and cut the list at the final
/// one.
pub(super) fn offer(out: &mut [Corner], kept: usize, c: Corner, min_dist_sq: f32) -> usize {
    let cap = out.len();
    let Some(list) = out.get_mut(..kept) else {
        return kept;
    };
    // The list is sorted: the corners at least as strong come first.
    let at = list.partition_point(|k| k.response >= c.response);
    let (stronger, weaker) = list.split_at_mut(at);
    if weaker.is_empty() && kept == cap {
        return kept;
    }
    let rows = rows_beyond_reach(min_dist_sq);
    if stronger
        .iter()
        .any(|k| within_reach(k, &c, rows, min_dist_sq))
    {
        return kept;
    }
    // Evict the weaker corners within reach, keeping the order.
    let mut n = 0;
    for i in 0..weaker.len() {
        let Some(&k) = weaker.get(i) else { break };
        if !within_reach(&k, &c, rows, min_dist_sq) {
            if let Some(slot) = weaker.get_mut(n) {
                *slot = k;
            }
            n += 1;
        }
    }
    // Insert after every corner at least as strong.
    let new_len = (at + n + 1).min(cap);
    if let Some(tail) = out.get_mut(at..new_len) {
        tail.rotate_right(1);
        if let Some(first) = tail.first_mut() {
            *first = c;
        }
    }
    new_len
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec;
    use std::vec::Vec;

    use super::*;

    fn c(x: usize, y: usize, response: f32) -> Corner {
        Corner { x, y, response }
    }

    #[test]
    fn rows_beyond_reach_are_beyond_reach() {
        for d in [0.0f32, 0.5, 1.0, 1.5, 2.0, 9.99, 10.0, 10.01, 4095.5, 1.0e6] {
            let rows = rows_beyond_reach(d * d);
            assert!(rows as f32 > d, "{d}: {rows}");
            assert!(rows as f32 <= d + 1.0, "{d}: {rows}");
            let (a, b) = (c(0, 0, 1.0), c(0, rows, 1.0));
            assert!(dist_sq(&a, &b) >= d * d);
        }
        assert_eq!(rows_beyond_reach(f32::MAX), usize::MAX);
        assert_eq!(rows_beyond_reach(1.0e15), usize::MAX);
    }

    #[test]
    fn eviction_keeps_distance_and_order() {
        let mut out = [Corner::default(); 3];
        let mut n = 0;
        n = offer(&mut out, n, c(0, 0, 1.0), 25.0);
        n = offer(&mut out, n, c(20, 0, 2.0), 25.0);
        n = offer(&mut out, n, c(3, 0, 5.0), 25.0); // evicts (0,0)
        assert_eq!(&out[..n], &[c(3, 0, 5.0), c(20, 0, 2.0)]);
        n = offer(&mut out, n, c(22, 0, 1.0), 25.0); // blocked by (20,0)
        n = offer(&mut out, n, c(40, 0, 3.0), 25.0);
        n = offer(&mut out, n, c(60, 0, 0.5), 25.0); // full, too weak
        assert_eq!(&out[..n], &[c(3, 0, 5.0), c(40, 0, 3.0), c(20, 0, 2.0)]);
    }

    #[test]
    fn a_full_list_keeps_the_strongest_and_ties_stay_in_arrival_order() {
        let mut out = [Corner::default(); 2];
        let mut n = 0;
        for (i, r) in [1.0, 3.0, 2.0, 3.0, 0.5, 4.0].into_iter().enumerate() {
            n = offer(&mut out, n, c(100 * i, 0, r), 1.0);
        }
        assert_eq!(&out[..n], &[c(500, 0, 4.0), c(100, 0, 3.0)]);
        // An equal response does not push a kept corner off a full list.
        n = offer(&mut out, n, c(700, 0, 3.0), 1.0);
        assert_eq!(&out[..n], &[c(500, 0, 4.0), c(100, 0, 3.0)]);
    }

    #[test]
    fn weaker_offers_never_change_the_stronger_part_of_the_list() {
        // The property the detector's provisional threshold relies on.
        let mut seed = 11u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            seed >> 8
        };
        for _ in 0..200 {
            let candidates: Vec<Corner> = (0..60)
                .map(|_| {
                    c(
                        (next() % 40) as usize,
                        (next() % 40) as usize,
                        (next() % 50) as f32,
                    )
                })
                .collect();
            let level = (next() % 50) as f32;
            let cap = 1 + (next() % 12) as usize;
            let md2 = (next() % 100) as f32;
            let run = |all: bool| {
                let mut out = vec![Corner::default(); cap];
                let mut n = 0;
                for &k in candidates.iter().filter(|k| all || k.response >= level) {
                    n = offer(&mut out, n, k, md2);
                }
                out.truncate(n);
                out.retain(|k| k.response >= level);
                out
            };
            assert_eq!(run(true), run(false));
        }
    }
}
