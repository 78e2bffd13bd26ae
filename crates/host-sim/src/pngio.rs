//! Grayscale PNG reading and writing (8-bit; colour and 16-bit inputs are
//! converted to 8-bit luma, ITU-R BT.601 weights).

use crate::error::CliError;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// An owned 8-bit grayscale image, row-major, tightly packed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GrayImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` bytes.
    pub data: Vec<u8>,
}

impl GrayImage {
    /// A borrowed view for the no_std crates.
    pub fn view(&self) -> Result<vslam_core::image::ImageView<'_>, vslam_core::image::ImageError> {
        vslam_core::image::ImageView::packed(&self.data, self.width, self.height)
    }
}

/// Reads a PNG file as 8-bit grayscale.
pub fn load_gray(path: &Path) -> Result<GrayImage, CliError> {
    let file = File::open(path).map_err(|e| CliError::file(path, format!("cannot open: {e}")))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder
        .read_info()
        .map_err(|e| CliError::file(path, format!("not a readable PNG: {e}")))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| CliError::file(path, "PNG too large"))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| CliError::file(path, format!("corrupt PNG data: {e}")))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => {
            return Err(CliError::file(path, "indexed PNG was not expanded"));
        }
    };
    let line = info.line_size;
    if channels == 1 && line == w && w > 0 && h > 0 && buf.len() >= w * h {
        // 8-bit gray, rows packed: the decoder's buffer is the image.
        buf.truncate(w * h);
        return Ok(GrayImage {
            width: w,
            height: h,
            data: buf,
        });
    }
    let mut data = Vec::with_capacity(w * h);
    for row in buf.chunks(line).take(h) {
        for px in row.chunks_exact(channels).take(w) {
            let v = match *px {
                [g] | [g, _] => g,
                [r, g, b] | [r, g, b, _] => {
                    ((299 * r as u32 + 587 * g as u32 + 114 * b as u32 + 500) / 1000) as u8
                }
                _ => 0,
            };
            data.push(v);
        }
    }
    if data.len() != w * h || w == 0 || h == 0 {
        return Err(CliError::file(
            path,
            "PNG has no pixels or a truncated image",
        ));
    }
    Ok(GrayImage {
        width: w,
        height: h,
        data,
    })
}

/// Writes an 8-bit grayscale PNG.
pub fn save_gray(path: &Path, img: &GrayImage) -> Result<(), CliError> {
    let file =
        File::create(path).map_err(|e| CliError::file(path, format!("cannot create: {e}")))?;
    let mut enc = png::Encoder::new(BufWriter::new(file), img.width as u32, img.height as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc
        .write_header()
        .map_err(|e| CliError::file(path, format!("cannot write PNG: {e}")))?;
    w.write_image_data(&img.data)
        .map_err(|e| CliError::file(path, format!("cannot write PNG: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_bad_file() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let img = GrayImage {
            width: 3,
            height: 2,
            data: vec![0, 10, 20, 30, 40, 255],
        };
        let p = dir.join("a.png");
        save_gray(&p, &img).unwrap();
        assert_eq!(load_gray(&p).unwrap(), img);
        let bad = dir.join("bad.png");
        std::fs::write(&bad, b"not a png").unwrap();
        let e = load_gray(&bad).unwrap_err();
        assert!(e.to_string().contains("bad.png"), "{e}");
        assert_eq!(e.exit_code(), 2);
    }
}
