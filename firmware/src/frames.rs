//! Embedded camera frames for the front-end measurement:
//! `firmware/data/frames160.bin`, written by the same generator as
//! [`crate::sample`] (a few consecutive frames of the simulated upward
//! camera, 2x2 box-averaged from 320x240 to 160x120).
//!
//! Layout (little-endian): magic `TRFR`, version `u16`, width `u16`, height
//! `u16`, intrinsics `fu fv cu cv` (4 `f32`), frame count `u16`, then per
//! frame `t u64` and `width * height` bytes, row-major.

use traction::vslam_core::Timestamp;

/// First four bytes.
pub const MAGIC: [u8; 4] = *b"TRFR";
/// Format version.
pub const VERSION: u16 = 1;

/// The frames' geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramesHeader {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// `fu, fv, cu, cv`, pixels.
    pub intrinsics: [f32; 4],
    /// Frames that follow.
    pub count: usize,
}

/// Reads the header; gives it and the frames `(t, pixels)`, or `None` if the
/// bytes are not frame data of this version or are truncated.
pub fn open(bytes: &[u8]) -> Option<(FramesHeader, impl Iterator<Item = (Timestamp, &[u8])>)> {
    let (magic, rest) = bytes.split_first_chunk::<4>()?;
    let (version, rest) = rest.split_first_chunk::<2>()?;
    let (w, rest) = rest.split_first_chunk::<2>()?;
    let (h, rest) = rest.split_first_chunk::<2>()?;
    let (k, rest) = rest.split_first_chunk::<16>()?;
    let (n, rest) = rest.split_first_chunk::<2>()?;
    if *magic != MAGIC || u16::from_le_bytes(*version) != VERSION {
        return None;
    }
    let f = |i: usize| {
        k.get(i * 4..i * 4 + 4)
            .and_then(|b| b.try_into().ok())
            .map(f32::from_le_bytes)
            .unwrap_or(f32::NAN)
    };
    let header = FramesHeader {
        width: usize::from(u16::from_le_bytes(*w)),
        height: usize::from(u16::from_le_bytes(*h)),
        intrinsics: [f(0), f(1), f(2), f(3)],
        count: usize::from(u16::from_le_bytes(*n)),
    };
    let frame = 8 + header.width * header.height;
    if rest.len() < frame * header.count {
        return None;
    }
    let frames = rest.chunks_exact(frame).take(header.count).filter_map(|c| {
        let (t, pixels) = c.split_first_chunk::<8>()?;
        Some((Timestamp(u64::from_le_bytes(*t)), pixels))
    });
    Some((header, frames))
}

/// Writes the header through `out`.
pub fn write_header(h: &FramesHeader, out: &mut impl FnMut(&[u8])) {
    out(&MAGIC);
    out(&VERSION.to_le_bytes());
    out(&(h.width as u16).to_le_bytes());
    out(&(h.height as u16).to_le_bytes());
    for v in h.intrinsics {
        out(&v.to_le_bytes());
    }
    out(&(h.count as u16).to_le_bytes());
}

/// Writes one frame through `out`.
pub fn write_frame(t: Timestamp, pixels: &[u8], out: &mut impl FnMut(&[u8])) {
    out(&t.0.to_le_bytes());
    out(pixels);
}
