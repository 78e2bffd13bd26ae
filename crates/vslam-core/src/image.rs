//! Borrowed 8-bit grayscale images and label maps.
//!
//! [`ImageView`] is validated once at construction (dimensions non-zero, the
//! buffer holds `stride * (height - 1) + width` bytes, `stride >= width`), so
//! every accessor afterwards is panic-free. [`LabelView`] is the same shape
//! carrying class ids from an external segmentation model instead of intensity.

use core::fmt;

/// Why an image view could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageError {
    /// Width or height is zero.
    Empty,
    /// The stride is smaller than the width.
    StrideTooSmall,
    /// The buffer is shorter than `stride * (height - 1) + width`.
    BufferTooSmall,
    /// The dimensions overflow `usize`.
    TooLarge,
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ImageError::Empty => "image has zero width or height",
            ImageError::StrideTooSmall => "image stride is smaller than its width",
            ImageError::BufferTooSmall => "image buffer is too small for its dimensions",
            ImageError::TooLarge => "image dimensions overflow",
        })
    }
}

impl core::error::Error for ImageError {}

/// Bytes a `width x height` image with `stride` needs.
pub fn required_len(width: usize, height: usize, stride: usize) -> Result<usize, ImageError> {
    if width == 0 || height == 0 {
        return Err(ImageError::Empty);
    }
    if stride < width {
        return Err(ImageError::StrideTooSmall);
    }
    stride
        .checked_mul(height - 1)
        .and_then(|v| v.checked_add(width))
        .ok_or(ImageError::TooLarge)
}

/// A borrowed, row-major, 8-bit grayscale image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageView<'a> {
    data: &'a [u8],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a> ImageView<'a> {
    /// Checks the dimensions against the buffer.
    pub fn new(
        data: &'a [u8],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<Self, ImageError> {
        let need = required_len(width, height, stride)?;
        if data.len() < need {
            return Err(ImageError::BufferTooSmall);
        }
        Ok(ImageView {
            data,
            width,
            height,
            stride,
        })
    }

    /// A tightly packed image (`stride == width`).
    pub fn packed(data: &'a [u8], width: usize, height: usize) -> Result<Self, ImageError> {
        Self::new(data, width, height, width)
    }

    /// Width in pixels (never zero).
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels (never zero).
    pub fn height(&self) -> usize {
        self.height
    }
    /// Bytes from one row to the next.
    pub fn stride(&self) -> usize {
        self.stride
    }
    /// The underlying buffer.
    pub fn data(&self) -> &'a [u8] {
        self.data
    }

    /// Row `y`, exactly `width` bytes, or `None` outside the image.
    pub fn row(&self, y: usize) -> Option<&'a [u8]> {
        if y >= self.height {
            return None;
        }
        let start = y * self.stride;
        self.data.get(start..start + self.width)
    }

    /// The pixel at `(x, y)`, or `None` outside the image.
    pub fn get(&self, x: usize, y: usize) -> Option<u8> {
        if x >= self.width {
            return None;
        }
        self.row(y).and_then(|r| r.get(x).copied())
    }
}

/// A borrowed label map: one class id per pixel, from an external segmentation model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LabelView<'a>(ImageView<'a>);

impl<'a> LabelView<'a> {
    /// Checks the dimensions against the buffer.
    pub fn new(
        data: &'a [u8],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<Self, ImageError> {
        ImageView::new(data, width, height, stride).map(LabelView)
    }
    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.0.width()
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.0.height()
    }
    /// Row `y` of class ids.
    pub fn row(&self, y: usize) -> Option<&'a [u8]> {
        self.0.row(y)
    }
    /// The class id at `(x, y)`.
    pub fn get(&self, x: usize, y: usize) -> Option<u8> {
        self.0.get(x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn construction_checks_and_accessors() {
        let buf = [0u8, 1, 2, 99, 3, 4, 5];
        let img = ImageView::new(&buf, 3, 2, 4).unwrap();
        assert_eq!(img.row(1), Some(&[3u8, 4, 5][..]));
        assert_eq!(img.get(2, 0), Some(2));
        assert_eq!(img.get(3, 0), None);
        assert_eq!(img.get(0, 2), None);
        assert_eq!(
            ImageView::new(&buf, 3, 2, 5).err(),
            Some(ImageError::BufferTooSmall)
        );
        assert_eq!(
            ImageView::new(&buf, 3, 2, 2).err(),
            Some(ImageError::StrideTooSmall)
        );
        assert_eq!(ImageView::new(&buf, 0, 2, 4).err(), Some(ImageError::Empty));
        assert_eq!(
            ImageView::new(&buf, usize::MAX, 3, usize::MAX).err(),
            Some(ImageError::TooLarge)
        );
    }
}
