//! Edge-replicated copies of the images whose borders the tracker's windows
//! hang over, for the AVX2 kernels (x86-64 with `std`).
//!
//! At a coarse pyramid level a window may hang over the border, its pixels
//! outside the image repeating the nearest edge pixel (`window`). Read row
//! by row, such a window costs up to 2.4 times one inside the image (the
//! AVX2 sweep: 2,945 instructions against 1,209), because each of its
//! source rows is first copied with the edge pixels repeated
//! (`SourceRows::row`). OpenCV's pyramids carry a replicated border instead
//! (`buildOpticalFlowPyramid`); [`Borders`] does the same lazily on the host:
//! once windows have hung over an image's border [`COPY_AFTER`] times in one
//! tracking call, the image is copied once with a margin of repeated edge
//! pixels on every side ([`Borders::margin`]), and every later window over
//! its border reads its rows straight from the copy, as the AVX2 kernels
//! read a window inside the image. The copy holds at each position the byte
//! the row copy would hold there (`image[clamp(y)][clamp(x)]`), so the
//! results are the same bits.
//!
//! The copies live on the heap for one tracking call (the [`Borders`] of its
//! template): for the `lk` bench's 320x240 pictures and 21x21 window (a
//! 14-pixel margin), 27,824 bytes for level 1 and 9,504 for level 2, per
//! pyramid; making one takes about 15,000 instructions. On that bench a
//! tracking call runs 2.91 M instructions against 3.13 M with every such
//! row copied, and takes 233 µs against 261 µs (`examples/lk_profile 500`,
//! medians of six runs each, alternating). The portable kernels (Cortex-M,
//! no `std`) never use the copies.

extern crate std;
use std::vec::Vec;

use crate::image::ImageView;
use crate::pyramid::MAX_LEVELS;

/// The window over an image's border at which the image is copied: a copy
/// costs about what the row copies of eight such windows cost, and the
/// point of waiting is that a call tracking one or two points near a border
/// does not pay for it (on the `lk` bench, copying at the first window
/// instead takes the same time).
pub(super) const COPY_AFTER: u32 = 4;

/// Images one tracking call keeps copies of: the coarse levels of both
/// pyramids.
const MAX_IMAGES: usize = 2 * (MAX_LEVELS - 1);

/// What tells one image view from another within a tracking call: its
/// buffer (address and length) and its geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Key {
    address: usize,
    len: usize,
    width: usize,
    height: usize,
    stride: usize,
}

impl Key {
    fn of(image: &ImageView<'_>) -> Self {
        Key {
            address: image.data().as_ptr() as usize,
            len: image.data().len(),
            width: image.width(),
            height: image.height(),
            stride: image.stride(),
        }
    }
}

/// One image's windows over the border so far and, once made, its copy.
#[derive(Debug)]
struct Entry {
    key: Key,
    windows: u32,
    margin: usize,
    /// `width + 2 margin`.
    stride: usize,
    /// `(height + 2 margin)` rows of `stride` bytes; empty until made.
    data: Vec<u8>,
}

impl Entry {
    /// Copies `image` with `margin` repeated edge pixels on every side.
    fn make(&mut self, image: &ImageView<'_>, margin: usize) -> Option<()> {
        let made = self.fill(image, margin);
        if made.is_none() {
            (self.margin, self.stride) = (0, 0);
            self.data.clear();
        }
        made
    }

    /// Writes each byte once: the image rows with their margins, the
    /// margin rows above and below as copies of the first and the last.
    fn fill(&mut self, image: &ImageView<'_>, margin: usize) -> Option<()> {
        let (w, h) = (image.width(), image.height());
        let stride = w.checked_add(margin.checked_mul(2)?)?;
        let rows = h.checked_add(margin.checked_mul(2)?)?;
        let data = &mut self.data;
        data.clear();
        // Out of memory: no copy (the caller copies the rows one by one).
        data.try_reserve(stride.checked_mul(rows)?).ok()?;
        // Row 0 with its margins, then its copies above it (the same bytes,
        // so their order does not matter), the other rows, the last one's
        // copies below.
        for y in 0..h {
            let row = image.row(y)?;
            let (first, last) = (*row.first()?, *row.last()?);
            data.extend(core::iter::repeat_n(first, margin));
            data.extend_from_slice(row);
            data.extend(core::iter::repeat_n(last, margin));
            if y == 0 {
                for _ in 0..margin {
                    data.extend_from_within(..stride);
                }
            }
        }
        let last_row = data.len().checked_sub(stride)?;
        for _ in 0..margin {
            data.extend_from_within(last_row..last_row + stride);
        }
        (self.margin, self.stride) = (margin, stride);
        Some(())
    }
}

/// The copies of one tracking call, made on demand (see the module doc).
/// An image is known by its buffer's address and length and its geometry,
/// which is only sound while the buffers stay borrowed: a [`Borders`] must
/// not outlive the tracking call (the template it belongs to does not).
#[derive(Debug)]
pub(super) struct Borders {
    entries: Vec<Entry>,
    /// Windows over an image's border before it is copied ([`COPY_AFTER`];
    /// the tests switch it).
    pub(super) copy_after: u32,
    /// Windows served from a copy (for the tests).
    pub(super) served: usize,
}

impl Borders {
    /// No copies yet (nothing allocated).
    pub(super) const fn new() -> Self {
        Borders {
            entries: Vec::new(),
            copy_after: COPY_AFTER,
            served: 0,
        }
    }

    /// The margin that serves every window of side `n` whose centre is
    /// inside the image, read as rows of at most `patch_bytes` bytes (the
    /// template's patch, the window with its one-pixel frame, is the widest
    /// read): a window's rows end at most `patch_bytes - n / 2 - 1` pixels
    /// right of the image (a moving window's rows, which start a pixel
    /// farther right than the patch's); it reaches at most `n / 2 + 1`
    /// pixels left of and above the image and `n / 2 + 2` below it (the
    /// patch's frame and the bilinear neighbour row), never more than on the
    /// right (`patch_bytes >= n + 2`).
    pub(super) fn margin(n: usize, patch_bytes: usize) -> usize {
        let half = n / 2;
        (half + 2).max(patch_bytes.saturating_sub(half + 1))
    }

    /// Where the `rows` rows of `need` bytes from column `x0`, row `y0` of
    /// `image` are in its copy with at least `margin` repeated edge pixels:
    /// the bytes from row 0's first to the last row's last, and the stride
    /// (row `i` starts `i` strides on); once windows have hung over the
    /// image's border [`Borders::copy_after`] times (this call counts one),
    /// when the rows lie in the copy; else `None` (the caller copies the rows).
    pub(super) fn block(
        &mut self,
        image: &ImageView<'_>,
        margin: usize,
        (x0, y0): (isize, isize),
        rows: usize,
        need: usize,
    ) -> Option<(&[u8], usize)> {
        let key = Key::of(image);
        let at = match self.entries.iter().position(|e| e.key == key) {
            Some(at) => at,
            None if self.entries.len() < MAX_IMAGES => {
                self.entries.try_reserve(1).ok()?;
                self.entries.push(Entry {
                    key,
                    windows: 0,
                    margin: 0,
                    stride: 0,
                    data: Vec::new(),
                });
                self.entries.len() - 1
            }
            None => return None,
        };
        let entry = self.entries.get_mut(at)?;
        if entry.data.is_empty() || entry.margin < margin {
            entry.windows = entry.windows.saturating_add(1);
            if entry.windows < self.copy_after {
                return None;
            }
            entry.make(image, margin)?;
        }
        // The block: every row inside its padded row, every row inside the copy.
        let x = usize::try_from(x0.checked_add_unsigned(entry.margin)?).ok()?;
        let y = usize::try_from(y0.checked_add_unsigned(entry.margin)?).ok()?;
        if x.checked_add(need)? > entry.stride || rows == 0 {
            return None;
        }
        let start = y.checked_mul(entry.stride)?.checked_add(x)?;
        let end = (rows - 1)
            .checked_mul(entry.stride)?
            .checked_add(start)?
            .checked_add(need)?;
        let block = entry.data.get(start..end)?;
        self.served += 1;
        Some((block, entry.stride))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: usize = 13;
    const H: usize = 9;

    fn picture() -> [u8; W * H] {
        core::array::from_fn(|i| (i * 37 % 251) as u8)
    }

    /// The byte at `(x, y)` with the edge pixels repeated.
    fn clamped(image: &ImageView<'_>, x: isize, y: isize) -> u8 {
        let x = x.clamp(0, image.width() as isize - 1) as usize;
        let y = y.clamp(0, image.height() as isize - 1) as usize;
        image.get(x, y).unwrap()
    }

    /// Reads the `rows x need` block at `(x0, y0)` through `borders`.
    fn read(
        borders: &mut Borders,
        image: &ImageView<'_>,
        margin: usize,
        at: (isize, isize),
        rows: usize,
        need: usize,
    ) -> Option<Vec<Vec<u8>>> {
        let (bytes, stride) = borders.block(image, margin, at, rows, need)?;
        assert_eq!(bytes.len(), (rows - 1) * stride + need);
        Some(
            (0..rows)
                .map(|i| bytes[i * stride..][..need].to_vec())
                .collect(),
        )
    }

    #[test]
    fn a_block_holds_the_edge_replicated_bytes_wherever_it_fits() {
        let px = picture();
        let image = ImageView::packed(&px, W, H).unwrap();
        let mut borders = Borders::new();
        borders.copy_after = 1;
        let margin = 4;
        let (mut read_blocks, mut refused) = (0, 0);
        for y0 in -7..H as isize + 3 {
            for x0 in -7..W as isize + 3 {
                for (rows, need) in [(1, 1), (3, 5), (6, 9)] {
                    let fits = x0 >= -4
                        && y0 >= -4
                        && x0 + need as isize <= (W + 4) as isize
                        && y0 + rows as isize <= (H + 4) as isize;
                    let got = read(&mut borders, &image, margin, (x0, y0), rows, need);
                    assert_eq!(got.is_some(), fits, "at ({x0}, {y0}) {rows}x{need}");
                    let Some(block) = got else {
                        refused += 1;
                        continue;
                    };
                    for (i, row) in block.iter().enumerate() {
                        for (j, &v) in row.iter().enumerate() {
                            let want = clamped(&image, x0 + j as isize, y0 + i as isize);
                            assert_eq!(v, want, "at ({x0}, {y0}) row {i} byte {j}");
                        }
                    }
                    read_blocks += 1;
                }
            }
        }
        assert!(
            read_blocks > 300 && refused > 100,
            "{read_blocks} read, {refused} refused"
        );
        assert_eq!(borders.served, read_blocks);
    }

    #[test]
    fn an_image_is_copied_after_the_set_number_of_windows_and_for_a_wider_margin() {
        let px = picture();
        let image = ImageView::packed(&px, W, H).unwrap();
        // The same bytes (address and length) seen with another geometry.
        let strided = ImageView::new(&px, W - 2, H - 1, W).unwrap();
        let mut borders = Borders::new();
        for _ in 1..COPY_AFTER {
            assert!(read(&mut borders, &image, 2, (-1, -1), 2, 3).is_none());
        }
        // The other view of the same bytes counts apart.
        assert!(read(&mut borders, &strided, 2, (-1, -1), 2, 3).is_none());
        let block = read(&mut borders, &image, 2, (-1, -1), 2, 3).unwrap();
        assert_eq!(block[0], [px[0], px[0], px[1]]);
        // A wider margin: copied again at once (its windows are counted).
        assert_eq!(
            read(&mut borders, &image, 5, (-5, 0), 1, 2).unwrap()[0],
            [px[0], px[0]]
        );
        assert!(read(&mut borders, &image, 2, (-2, 0), 1, 2).is_some());
        assert!(read(&mut borders, &image, 5, (-6, 0), 1, 2).is_none());
    }

    #[test]
    fn the_copies_are_bounded_and_a_full_table_copies_nothing() {
        let px = picture();
        let mut borders = Borders::new();
        borders.copy_after = 1;
        for k in 0..MAX_IMAGES + 3 {
            let image = ImageView::packed(&px[k..], 8, 8).unwrap();
            let got = read(&mut borders, &image, 2, (-1, -1), 2, 3);
            assert_eq!(got.is_some(), k < MAX_IMAGES, "image {k}");
        }
    }
}
