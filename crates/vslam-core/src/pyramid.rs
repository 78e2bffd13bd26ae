//! Image pyramids in caller-provided fixed buffers.
//!
//! Level 0 is the caller's image (borrowed, never copied). Each coarser level
//! is the previous one blurred by the 5-tap binomial kernel `[1 4 6 4 1] / 16`
//! in both directions and subsampled by two, with `(n + 1) / 2` pixels per
//! side and mirrored borders (`dcb|abcd|cba`), as OpenCV's `pyrDown` does.
//! Bouguet's pyramidal Lucas-Kanade ("Pyramidal Implementation of the Lucas
//! Kanade Feature Tracker", Intel, 2000, section 2.2) builds its pyramid the
//! same way with the 3-tap `[1 2 1] / 4` kernel; the 5-tap kernel suppresses
//! aliasing better at the same cost order.
//!
//! The coarser levels live packed (`stride == width`) one after another in a
//! [`PyramidStorage`], whose byte capacity is a const generic; size it with
//! [`storage_bytes`].

use core::fmt;

use crate::image::{ImageError, ImageView};

/// The most levels (including level 0) a [`Pyramid`] holds.
pub const MAX_LEVELS: usize = 8;

/// A coarser level is only built while both its sides keep at least this many pixels.
pub const MIN_LEVEL_SIDE: usize = 4;

/// The size of one side at `level` (level 0 is `side` itself).
pub const fn level_side(side: usize, level: usize) -> usize {
    let mut s = side;
    let mut l = 0;
    while l < level {
        s = s.div_ceil(2);
        l += 1;
    }
    s
}

/// Bytes a [`PyramidStorage`] needs for a `width x height` image and `levels`
/// levels (level 0 is borrowed, so a single level needs none).
pub const fn storage_bytes(width: usize, height: usize, levels: usize) -> usize {
    let mut total = 0usize;
    let mut l = 1;
    while l < levels {
        total = total.saturating_add(level_side(width, l).saturating_mul(level_side(height, l)));
        l += 1;
    }
    total
}

/// Why a pyramid could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PyramidError {
    /// Zero levels were requested.
    NoLevels,
    /// More levels were requested than the image size (or [`MAX_LEVELS`]) allows.
    TooManyLevels {
        /// Levels requested.
        requested: usize,
        /// The most this image allows, see [`Pyramid::max_levels`].
        max: usize,
    },
    /// The storage holds fewer bytes than the coarser levels need.
    StorageTooSmall {
        /// Bytes needed, see [`storage_bytes`].
        needed: usize,
        /// Bytes the storage holds.
        capacity: usize,
    },
    /// A level's image could not be formed (only on overflowing sizes).
    Image(ImageError),
}

impl fmt::Display for PyramidError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PyramidError::NoLevels => f.write_str("a pyramid needs at least one level"),
            PyramidError::TooManyLevels { requested, max } => write!(
                f,
                "{requested} pyramid levels requested, the image allows at most {max}"
            ),
            PyramidError::StorageTooSmall { needed, capacity } => write!(
                f,
                "pyramid storage holds {capacity} bytes, the levels need {needed}"
            ),
            PyramidError::Image(e) => write!(f, "pyramid level: {e}"),
        }
    }
}

impl core::error::Error for PyramidError {}

impl From<ImageError> for PyramidError {
    fn from(e: ImageError) -> Self {
        PyramidError::Image(e)
    }
}

/// Fixed storage for the coarser levels of a pyramid: `BYTES` bytes, no heap.
///
/// Reuse one per camera stream (or two, for the previous and the current
/// frame): building a pyramid overwrites it.
#[derive(Clone, Debug)]
pub struct PyramidStorage<const BYTES: usize> {
    bytes: [u8; BYTES],
}

impl<const BYTES: usize> PyramidStorage<BYTES> {
    /// Zeroed storage.
    pub const fn new() -> Self {
        PyramidStorage { bytes: [0; BYTES] }
    }

    /// The capacity in bytes.
    pub const fn capacity(&self) -> usize {
        BYTES
    }
}

impl<const BYTES: usize> Default for PyramidStorage<BYTES> {
    fn default() -> Self {
        Self::new()
    }
}

/// An image pyramid: level 0 is the source image, level `l` is `2^l` times smaller.
#[derive(Clone, Copy, Debug)]
pub struct Pyramid<'a> {
    /// Unused slots repeat level 0; `count` says how many are real.
    levels: [ImageView<'a>; MAX_LEVELS],
    count: usize,
}

impl<'a> Pyramid<'a> {
    /// The most levels (including level 0) a `width x height` image allows:
    /// coarser levels keep both sides at least [`MIN_LEVEL_SIDE`], and there
    /// are at most [`MAX_LEVELS`]. Always at least 1.
    pub const fn max_levels(width: usize, height: usize) -> usize {
        let mut n = 1;
        while n < MAX_LEVELS
            && level_side(width, n) >= MIN_LEVEL_SIDE
            && level_side(height, n) >= MIN_LEVEL_SIDE
        {
            n += 1;
        }
        n
    }

    /// Builds `levels` levels (including level 0, the `image` itself) into `storage`.
    pub fn build<const BYTES: usize>(
        image: &ImageView<'a>,
        levels: usize,
        storage: &'a mut PyramidStorage<BYTES>,
    ) -> Result<Self, PyramidError> {
        Self::build_in(image, levels, &mut storage.bytes)
    }

    /// Checks `levels` against the image and `capacity` bytes of storage;
    /// returns the bytes the coarser levels need.
    fn check_layout(
        image: &ImageView<'_>,
        levels: usize,
        capacity: usize,
    ) -> Result<usize, PyramidError> {
        if levels == 0 {
            return Err(PyramidError::NoLevels);
        }
        let max = Self::max_levels(image.width(), image.height());
        if levels > max {
            return Err(PyramidError::TooManyLevels {
                requested: levels,
                max,
            });
        }
        let needed = storage_bytes(image.width(), image.height(), levels);
        if capacity < needed {
            return Err(PyramidError::StorageTooSmall { needed, capacity });
        }
        Ok(needed)
    }

    /// [`Pyramid::build`] into a plain byte buffer (e.g. a static or a
    /// region of a larger frame buffer).
    pub fn build_in(
        image: &ImageView<'a>,
        levels: usize,
        storage: &'a mut [u8],
    ) -> Result<Self, PyramidError> {
        let needed = Self::check_layout(image, levels, storage.len())?;
        let mut all = [*image; MAX_LEVELS];
        let mut rest: &'a mut [u8] = storage;
        let mut prev = *image;
        for slot in all.iter_mut().take(levels).skip(1) {
            let (w, h) = (prev.width().div_ceil(2), prev.height().div_ceil(2));
            let len = w.checked_mul(h).ok_or(ImageError::TooLarge)?;
            let (cur, tail) =
                rest.split_at_mut_checked(len)
                    .ok_or(PyramidError::StorageTooSmall {
                        needed,
                        capacity: len,
                    })?;
            downsample_into(&prev, cur)?;
            let cur: &'a [u8] = cur;
            prev = ImageView::packed(cur, w, h)?;
            *slot = prev;
            rest = tail;
        }
        Ok(Pyramid {
            levels: all,
            count: levels,
        })
    }

    /// The pyramid of `image` whose coarser levels [`Pyramid::build_in`]
    /// already wrote into `storage` for this very image: views only, nothing
    /// recomputed (a tracker keeps the previous frame's pyramid this way).
    /// Checks sizes like `build_in`; whether `storage` really holds this
    /// image's levels is the caller's to know.
    pub fn from_storage(
        image: &ImageView<'a>,
        levels: usize,
        storage: &'a [u8],
    ) -> Result<Self, PyramidError> {
        let needed = Self::check_layout(image, levels, storage.len())?;
        let mut all = [*image; MAX_LEVELS];
        let mut rest = storage;
        let (mut w, mut h) = (image.width(), image.height());
        for slot in all.iter_mut().take(levels).skip(1) {
            (w, h) = (w.div_ceil(2), h.div_ceil(2));
            let len = w.checked_mul(h).ok_or(ImageError::TooLarge)?;
            let (cur, tail) = rest
                .split_at_checked(len)
                .ok_or(PyramidError::StorageTooSmall {
                    needed,
                    capacity: len,
                })?;
            *slot = ImageView::packed(cur, w, h)?;
            rest = tail;
        }
        Ok(Pyramid {
            levels: all,
            count: levels,
        })
    }

    /// How many levels, including level 0 (at least 1).
    pub fn levels(&self) -> usize {
        self.count
    }

    /// Level `level`, or `None` past the coarsest.
    pub fn level(&self, level: usize) -> Option<ImageView<'a>> {
        if level < self.count {
            self.levels.get(level).copied()
        } else {
            None
        }
    }

    /// Level 0, the source image.
    pub fn base(&self) -> ImageView<'a> {
        self.levels[0]
    }
}

/// Mirrors index `i` into `0..n` (`dcb|abcd|cba`, OpenCV's `BORDER_REFLECT_101`).
fn reflect(i: isize, n: usize) -> usize {
    let last = n.saturating_sub(1) as isize;
    let r = if i < 0 {
        -i
    } else if i > last {
        2 * last - i
    } else {
        i
    };
    r.clamp(0, last) as usize
}

/// The `[1 4 6 4 1]` weighted sum of five samples.
#[inline(always)]
fn binomial5(a: u16, b: u16, c: u16, d: u16, e: u16) -> u16 {
    a + 4 * b + 6 * c + 4 * d + e
}

/// Output columns per block of [`downsample_into`] (a fixed stack buffer).
const BLOCK: usize = 64;
/// Source columns a block reads: two on each side of its `2 BLOCK` centres.
const SPAN: usize = 2 * BLOCK + 4;

/// Halves `src` into the packed `dst` (`ceil(w/2) x ceil(h/2)` bytes):
/// 5x5 binomial blur, then every second pixel. Returns the new size.
///
/// Separable and in 16-bit integers (the exact sums fit: at most
/// `256 * 255 + 128`): for each output row the five source rows are summed
/// vertically per column, a block of 64 output columns at a time,
/// then the column sums are split into even and odd columns and combined
/// horizontally. Mirrored columns outside the image read the mirrored column
/// sum (the vertical sum commutes with the horizontal mirror).
pub fn downsample_into(
    src: &ImageView<'_>,
    dst: &mut [u8],
) -> Result<(usize, usize), PyramidError> {
    let (w, h) = (src.width(), src.height());
    let (ow, oh) = (w.div_ceil(2), h.div_ceil(2));
    let needed = ow.checked_mul(oh).ok_or(ImageError::TooLarge)?;
    let capacity = dst.len();
    let dst = dst
        .get_mut(..needed)
        .ok_or(PyramidError::StorageTooSmall { needed, capacity })?;
    for (oy, out) in dst.chunks_exact_mut(ow).enumerate() {
        let cy = 2 * oy as isize;
        let rows = [-2isize, -1, 0, 1, 2].map(|k| src.row(reflect(cy + k, h)).unwrap_or(&[]));
        for (block, out) in out.chunks_mut(BLOCK).enumerate() {
            // Source column of sums[0]: two left of the first centre.
            let first = (2 * block * BLOCK) as isize - 2;
            let len = 2 * out.len() + 3;
            let mut sums = [0u16; SPAN];
            column_sums(&rows, w, first, sums.get_mut(..len).unwrap_or(&mut []));
            horizontal(&sums, out);
        }
    }
    Ok((ow, oh))
}

/// The horizontal `[1 4 6 4 1]` pass of one block: output `k` (of
/// `out.len()`, at most [`BLOCK`]) from the column sums `sums[2k..2k + 5]`,
/// rounded and divided by 256. On Arm cores
/// without vector units (Cortex-M) reading the sums at a stride of two takes
/// fewer instructions; elsewhere splitting them into even and odd columns
/// lets the compiler vectorise. Both give the same bytes.
fn horizontal(sums: &[u16; SPAN], out: &mut [u8]) {
    if cfg!(target_arch = "arm") {
        horizontal_strided(sums, out);
    } else {
        horizontal_split(sums, out);
    }
}

/// The horizontal pass with the sums split into even and odd columns first,
/// so that the taps are unit-stride (the compiler vectorises it).
fn horizontal_split(sums: &[u16; SPAN], out: &mut [u8]) {
    let (mut even, mut odd) = ([0u16; BLOCK + 2], [0u16; BLOCK + 2]);
    for ((e, o), pair) in even
        .iter_mut()
        .zip(odd.iter_mut())
        .zip(sums.chunks_exact(2))
    {
        if let [a, b] = *pair {
            (*e, *o) = (a, b);
        }
    }
    // Output k is centred on sums[2k + 2]: taps e[k] o[k] e[k+1] o[k+1] e[k+2].
    let taps = even
        .iter()
        .zip(&odd)
        .zip(even.iter().skip(1).zip(odd.iter().skip(1)))
        .zip(even.iter().skip(2));
    for (o, (((&e0, &o0), (&e1, &o1)), &e2)) in out.iter_mut().zip(taps) {
        *o = ((binomial5(e0, o0, e1, o1, e2) + 128) >> 8) as u8;
    }
}

/// The horizontal pass reading the taps straight from the sums.
fn horizontal_strided(sums: &[u16; SPAN], out: &mut [u8]) {
    for (o, t) in out.iter_mut().zip(sums.windows(5).step_by(2)) {
        if let [a, b, c, d, e] = *t {
            *o = ((binomial5(a, b, c, d, e) + 128) >> 8) as u8;
        }
    }
}

/// Vertical `[1 4 6 4 1]` sums of the five `rows` (each `w` wide) for the
/// source columns `first..first + out.len()`, mirrored outside `0..w`.
fn column_sums(rows: &[&[u8]; 5], w: usize, first: isize, out: &mut [u16]) {
    let [r0, r1, r2, r3, r4] = *rows;
    let last = first + out.len() as isize; // exclusive
    let lo = first.clamp(0, w as isize) as usize;
    let hi = last.clamp(0, w as isize) as usize;
    let skip = (lo as isize - first) as usize;
    // The columns inside the image, straight from the rows.
    if let (Some(a), Some(b), Some(c), Some(d), Some(e), Some(o)) = (
        r0.get(lo..hi),
        r1.get(lo..hi),
        r2.get(lo..hi),
        r3.get(lo..hi),
        r4.get(lo..hi),
        out.get_mut(skip..skip + (hi - lo)),
    ) {
        let taps = a.iter().zip(b).zip(c).zip(d).zip(e);
        for (o, ((((&a, &b), &c), &d), &e)) in o.iter_mut().zip(taps) {
            *o = binomial5(a.into(), b.into(), c.into(), d.into(), e.into());
        }
    }
    // The few mirrored columns past either edge.
    let column = |x: usize| {
        let p = |r: &[u8]| u16::from(r.get(x).copied().unwrap_or(0));
        binomial5(p(r0), p(r1), p(r2), p(r3), p(r4))
    };
    let inside = hi - lo;
    let (before, rest) = out.split_at_mut(skip.min(out.len()));
    let after = rest.get_mut(inside..).unwrap_or(&mut []);
    for (j, o) in before.iter_mut().enumerate() {
        *o = column(reflect(first + j as isize, w));
    }
    for (j, o) in after.iter_mut().enumerate() {
        *o = column(reflect(first + (skip + inside + j) as isize, w));
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn from_storage_gives_the_levels_build_in_wrote() {
        let mut img = [0u8; 37 * 23];
        for (i, p) in img.iter_mut().enumerate() {
            *p = (i * 7 % 251) as u8;
        }
        let view = ImageView::packed(&img, 37, 23).unwrap();
        // Size and a position-weighted checksum of every level.
        fn digest(p: &Pyramid<'_>) -> [(usize, usize, u64); 3] {
            let mut out = [(0, 0, 0); 3];
            for (l, o) in out.iter_mut().enumerate() {
                let v = p.level(l).unwrap();
                let mut sum = 0u64;
                for y in 0..v.height() {
                    for (x, px) in v.row(y).unwrap().iter().enumerate() {
                        sum += (*px as u64) * ((y * v.width() + x) as u64 + 1);
                    }
                }
                *o = (v.width(), v.height(), sum);
            }
            out
        }
        let mut storage = [0u8; storage_bytes(37, 23, 3)];
        let built = digest(&Pyramid::build_in(&view, 3, &mut storage).unwrap());
        let again = digest(&Pyramid::from_storage(&view, 3, &storage).unwrap());
        assert_eq!(built, again);
        assert_eq!(built[2].0, 10);
        assert_eq!(
            Pyramid::from_storage(&view, 3, &storage[..10]).err(),
            Some(PyramidError::StorageTooSmall {
                needed: storage_bytes(37, 23, 3),
                capacity: 10
            })
        );
    }

    use super::*;

    /// The textbook definition, pixel by pixel, to check the fast path against.
    fn reference(src: &ImageView<'_>) -> ([u8; 64 * 64], usize, usize) {
        let (w, h) = (src.width(), src.height());
        let (ow, oh) = (w.div_ceil(2), h.div_ceil(2));
        let k = [1u32, 4, 6, 4, 1];
        let mut out = [0u8; 64 * 64];
        for oy in 0..oh {
            for ox in 0..ow {
                let mut s = 0;
                for (j, kj) in k.iter().enumerate() {
                    for (i, ki) in k.iter().enumerate() {
                        let y = reflect(2 * oy as isize + j as isize - 2, h);
                        let x = reflect(2 * ox as isize + i as isize - 2, w);
                        s += kj * ki * u32::from(src.get(x, y).unwrap());
                    }
                }
                out[oy * ow + ox] = ((s + 128) >> 8) as u8;
            }
        }
        (out, ow, oh)
    }

    #[test]
    fn downsample_matches_reference_for_odd_and_even_sizes() {
        let mut buf = [0u8; 40 * 40];
        let mut seed = 12345u32;
        for b in buf.iter_mut() {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            *b = (seed >> 16) as u8;
        }
        for (w, h, stride) in [
            (1, 1, 1),
            (2, 3, 2),
            (5, 5, 7),
            (6, 4, 6),
            (17, 12, 20),
            (32, 31, 33),
        ] {
            let img = ImageView::new(&buf, w, h, stride).unwrap();
            let (want, ow, oh) = reference(&img);
            let mut got = [0u8; 64 * 64];
            assert_eq!(downsample_into(&img, &mut got).unwrap(), (ow, oh));
            assert_eq!(&got[..ow * oh], &want[..ow * oh], "{w}x{h}");
        }
    }

    #[test]
    fn both_horizontal_passes_give_the_same_block() {
        // The vectorisable pass (hosts) and the strided one (Cortex-M) on
        // every block length, sums up to the largest a column can have.
        let mut seed = 4242u32;
        let mut sums = [0u16; super::SPAN];
        for s in sums.iter_mut() {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            *s = ((seed >> 16) % (16 * 255 + 1)) as u16;
        }
        for n in 1..=super::BLOCK {
            let (mut a, mut b) = ([0u8; super::BLOCK], [0u8; super::BLOCK]);
            super::horizontal_split(&sums, &mut a[..n]);
            super::horizontal_strided(&sums, &mut b[..n]);
            assert_eq!(a[..n], b[..n], "{n} outputs");
        }
    }

    #[test]
    fn downsample_matches_reference_across_column_blocks() {
        // Wider than two blocks of 64 output columns, odd and even widths.
        let mut buf = [0u8; 301 * 7];
        let mut seed = 987u32;
        for b in buf.iter_mut() {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            *b = (seed >> 16) as u8;
        }
        for (w, h, stride) in [(300, 7, 301), (259, 6, 260), (129, 5, 129), (128, 3, 130)] {
            let img = ImageView::new(&buf, w, h, stride).unwrap();
            let (want, ow, oh) = reference(&img);
            let mut got = [0u8; 64 * 64];
            assert_eq!(downsample_into(&img, &mut got).unwrap(), (ow, oh));
            assert_eq!(&got[..ow * oh], &want[..ow * oh], "{w}x{h}");
        }
    }

    #[test]
    fn build_checks_levels_and_storage() {
        let buf = [7u8; 35 * 35];
        let img = ImageView::packed(&buf, 35, 35).unwrap();
        assert_eq!(Pyramid::max_levels(35, 35), 4); // 35, 18, 9, 5
        assert_eq!(storage_bytes(35, 35, 3), 18 * 18 + 9 * 9);
        let mut st = PyramidStorage::<{ storage_bytes(35, 35, 3) }>::new();
        let p = Pyramid::build(&img, 3, &mut st).unwrap();
        assert_eq!(p.levels(), 3);
        assert_eq!(p.level(2).map(|l| (l.width(), l.height())), Some((9, 9)));
        assert!(p.level(3).is_none());
        // A uniform image stays uniform.
        assert!(p.level(2).unwrap().data().iter().all(|&v| v == 7));
        let mut small = PyramidStorage::<10>::new();
        assert_eq!(
            Pyramid::build(&img, 2, &mut small).err(),
            Some(PyramidError::StorageTooSmall {
                needed: 324,
                capacity: 10
            })
        );
        assert_eq!(
            Pyramid::build(&img, 5, &mut small).err(),
            Some(PyramidError::TooManyLevels {
                requested: 5,
                max: 4
            })
        );
        assert_eq!(
            Pyramid::build(&img, 0, &mut small).err(),
            Some(PyramidError::NoLevels)
        );
        let one = ImageView::packed(&buf, 1, 1).unwrap();
        assert_eq!(Pyramid::max_levels(1, 1), 1);
        assert_eq!(Pyramid::build(&one, 1, &mut small).unwrap().levels(), 1);
    }
}
