//! The segmentation model seam: a camera image in, a class-label map out.
//!
//! Seed 004 (claims 1, 18, 21; FIG. 5) starts every claim by generating a
//! segmentation map of an image with a model. A [`Segmenter`] is that model:
//! it reads an 8-bit grayscale [`ImageView`] and writes one class id per map
//! cell into a buffer the caller owns, so a model runs in fixed memory with no
//! allocator. The map may be coarser than the image (a model that labels
//! 2x2 blocks gives a half-resolution map); [`Segmenter::map_size`] says how
//! large, before any buffer is handed over.

use core::fmt;

use crate::image::{ImageError, ImageView, LabelView};

/// Why a segmentation could not be computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SegmentError {
    /// The model does not take images of this size.
    UnsupportedSize,
    /// The output buffer is shorter than the map.
    OutputTooSmall,
    /// The map's dimensions are not a valid label view.
    Map(ImageError),
}

impl fmt::Display for SegmentError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SegmentError::UnsupportedSize => f.write_str("image size not supported by the model"),
            SegmentError::OutputTooSmall => f.write_str("label buffer too small for the map"),
            SegmentError::Map(e) => write!(f, "label map: {e}"),
        }
    }
}

impl core::error::Error for SegmentError {}

/// A segmentation model: image -> class-label map, in fixed memory.
pub trait Segmenter {
    /// `(width, height)` of the map for an image of `width x height`, or why
    /// such an image cannot be labelled.
    fn map_size(&self, width: usize, height: usize) -> Result<(usize, usize), SegmentError>;

    /// Labels `image` into `out` (row-major, packed, `map_size` cells) and
    /// returns the map as a view of `out`.
    fn segment<'o>(
        &mut self,
        image: &ImageView<'_>,
        out: &'o mut [u8],
    ) -> Result<LabelView<'o>, SegmentError>;
}
