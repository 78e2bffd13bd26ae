//! The kept corners: corners at least a minimum distance apart, the
//! strongest first, filled greedily in the order candidates arrive. The
//! rules are those of `offer` on a list sorted strongest first (the tests'
//! specification); the detector keeps the list in raster order instead
//! ([`RasterList`]), where the corners within reach of a new one are the
//! last few, and sorts it at the end.

use super::Corner;

/// The squared distance, exact in integers, rounded once to `f32`.
fn dist_sq(a: &Corner, b: &Corner) -> f32 {
    let (dx, dy) = (a.x.abs_diff(b.x) as u64, a.y.abs_diff(b.y) as u64);
    dx.saturating_mul(dx).saturating_add(dy.saturating_mul(dy)) as f32
}

/// Whether `a` and `b` are closer than `sqrt(min_dist_sq)`; `rows` is a
/// whole number of rows beyond reach (`> sqrt(min_dist_sq)`), which settles
/// most pairs of a raster scan without the distance.
#[cfg(test)]
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
#[cfg(test)]
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

/// The kept corners of a raster scan, in arrival order in `out[..len]`:
/// the corners within reach of a new one are the last few rows' worth at
/// the end, so the distance rules only look there. Same rules as [`offer`];
/// [`RasterList::finish`] sorts strongest first (ties in raster order).
pub(super) struct RasterList<'o> {
    out: &'o mut [Corner],
    len: usize,
    min_dist_sq: f32,
    rows: usize,
    /// Index of the weakest kept corner (the latest of equals), when known.
    weakest: Option<usize>,
}

impl<'o> RasterList<'o> {
    /// An empty list over `out`.
    pub(super) fn new(out: &'o mut [Corner], min_dist_sq: f32) -> Self {
        RasterList {
            out,
            len: 0,
            min_dist_sq,
            rows: rows_beyond_reach(min_dist_sq),
            weakest: None,
        }
    }

    /// Offers `c`, which comes after every corner offered before in raster
    /// order (row, then column).
    pub(super) fn offer(&mut self, c: Corner) {
        let cap = self.out.len();
        let Some(list) = self.out.get_mut(..self.len) else {
            return;
        };
        if self.len == cap {
            let weakest = match self.weakest {
                Some(i) => i,
                None => {
                    let i = weakest_index(list);
                    self.weakest = Some(i);
                    i
                }
            };
            if list.get(weakest).is_none_or(|w| w.response >= c.response) {
                return;
            }
        }
        // The corners of the last `rows` rows: the only ones within reach.
        let band = list
            .iter()
            .rposition(|k| c.y.abs_diff(k.y) >= self.rows)
            .map_or(0, |i| i + 1);
        let Some(recent) = list.get_mut(band..) else {
            return;
        };
        let near = |k: &Corner| dist_sq(k, &c) < self.min_dist_sq;
        if recent.iter().any(|k| k.response >= c.response && near(k)) {
            return;
        }
        // Evict the weaker corners within reach, keeping the order.
        let mut n = 0;
        for i in 0..recent.len() {
            let Some(&k) = recent.get(i) else { break };
            if !(k.response < c.response && near(&k)) {
                if let Some(slot) = recent.get_mut(n) {
                    *slot = k;
                }
                n += 1;
            }
        }
        let mut len = band + n;
        if len == cap {
            // Full: the weakest (the latest of equals) falls off.
            let Some(list) = self.out.get_mut(..len) else {
                return;
            };
            // Nothing was evicted: the list, and its weakest, are unchanged.
            let weakest = self.weakest.unwrap_or_else(|| weakest_index(list));
            if let Some(tail) = list.get_mut(weakest..) {
                tail.rotate_left(1);
            }
            len -= 1;
        }
        if let Some(slot) = self.out.get_mut(len) {
            *slot = c;
            self.len = len + 1;
        }
        self.weakest = None;
    }

    /// Sorts the kept corners strongest first, equals in raster order, and
    /// returns how many there are.
    pub(super) fn finish(self) -> usize {
        if let Some(list) = self.out.get_mut(..self.len) {
            list.sort_unstable_by(|a, b| {
                b.response
                    .partial_cmp(&a.response)
                    .unwrap_or(core::cmp::Ordering::Equal)
                    .then(a.y.cmp(&b.y))
                    .then(a.x.cmp(&b.x))
            });
        }
        self.len
    }
}

/// The index of the smallest response, the last of equals.
fn weakest_index(list: &[Corner]) -> usize {
    let mut at = 0;
    let mut weakest = f32::INFINITY;
    for (i, k) in list.iter().enumerate() {
        if k.response <= weakest {
            weakest = k.response;
            at = i;
        }
    }
    at
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
    fn the_raster_list_keeps_what_the_sorted_list_keeps() {
        let mut seed = 5u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            seed >> 8
        };
        for round in 0..2000 {
            let n = (next() % 120) as usize;
            let mut candidates: Vec<Corner> = (0..n)
                .map(|_| {
                    c(
                        (next() % 30) as usize,
                        (next() % 60) as usize,
                        (next() % 8) as f32,
                    )
                })
                .collect();
            candidates.sort_by_key(|k| (k.y, k.x));
            candidates.dedup_by_key(|k| (k.y, k.x));
            let cap = (next() % 25) as usize;
            let md2 = [0.0, 1.0, 2.0, 8.0, 25.0, 100.0, 1e20][round % 7];
            let mut sorted = vec![Corner::default(); cap];
            let mut kept = 0;
            let mut raster_out = vec![Corner::default(); cap];
            let mut raster = RasterList::new(&mut raster_out, md2);
            for &k in &candidates {
                kept = offer(&mut sorted, kept, k, md2);
                raster.offer(k);
            }
            let len = raster.finish();
            assert_eq!(&raster_out[..len], &sorted[..kept], "round {round}");
        }
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
