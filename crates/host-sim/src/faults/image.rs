//! Vision faults: camera frames and segmentation maps spoiled before they
//! are written into the log (black, saturated, uniform, blurred, frozen
//! frames; label maps without ground or with unknown labels only).

use super::kind::FaultKind;
use crate::pngio::GrayImage;
use crate::sim::world::WALL_CLASS;

/// A label no class table of the simulator knows.
pub const UNKNOWN_LABEL: u8 = 200;

/// One horizontal then one vertical box-blur pass of `radius`.
fn box_blur(img: &mut GrayImage, radius: usize) {
    let (w, h) = (img.width, img.height);
    let mut tmp = vec![0u8; img.data.len()];
    let pass =
        |src: &[u8], dst: &mut [u8], len: usize, stride: usize, lines: usize, step: usize| {
            for line in 0..lines {
                let base = line * step;
                for i in 0..len {
                    let lo = i.saturating_sub(radius);
                    let hi = (i + radius).min(len - 1);
                    let sum: u32 = (lo..=hi).map(|k| src[base + k * stride] as u32).sum();
                    dst[base + i * stride] = (sum / (hi - lo + 1) as u32) as u8;
                }
            }
        };
    pass(&img.data, &mut tmp, w, 1, h, w);
    pass(&tmp, &mut img.data, h, w, w, 1);
}

/// Spoils camera frame `img` as `kind` says; `previous` is the frame before
/// (as written). Returns whether it was spoiled.
pub fn spoil_frame(kind: FaultKind, img: &mut GrayImage, previous: Option<&GrayImage>) -> bool {
    match kind {
        FaultKind::CamBlack => img.data.fill(0),
        FaultKind::CamSaturated => img.data.fill(255),
        FaultKind::CamUniform => img.data.fill(128),
        FaultKind::CamBlur => {
            for _ in 0..3 {
                box_blur(img, 8);
            }
        }
        FaultKind::CamFrozen => match previous {
            Some(p) if p.data.len() == img.data.len() => img.data.copy_from_slice(&p.data),
            _ => return false,
        },
        _ => return false,
    }
    true
}

/// Spoils label map `img` as `kind` says. Returns whether it was spoiled.
pub fn spoil_labels(kind: FaultKind, img: &mut GrayImage) -> bool {
    match kind {
        FaultKind::SegNoGround => img.data.fill(WALL_CLASS),
        FaultKind::SegUnknown => img.data.fill(UNKNOWN_LABEL),
        _ => return false,
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_flattens_edges_and_keeps_the_mean() {
        let mut img = GrayImage {
            width: 40,
            height: 30,
            data: (0..1200)
                .map(|i| if (i / 4) % 2 == 0 { 0 } else { 200 })
                .collect(),
        };
        spoil_frame(FaultKind::CamBlur, &mut img, None);
        let (lo, hi) = img.data[600..640]
            .iter()
            .fold((255u8, 0u8), |(a, b), v| (a.min(*v), b.max(*v)));
        assert!(hi - lo < 30, "{lo}..{hi}");
        let mut black = img.clone();
        spoil_frame(FaultKind::CamBlack, &mut black, None);
        assert!(black.data.iter().all(|v| *v == 0));
        let mut frozen = black.clone();
        assert!(spoil_frame(FaultKind::CamFrozen, &mut frozen, Some(&img)));
        assert_eq!(frozen.data, img.data);
    }
}
