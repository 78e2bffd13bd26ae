//! The corners the photograph LK tests track: 100 Shi-Tomasi corners at
//! least 8 px apart and 16 px clear of the border.

use vslam_core::corners::{Corner, CornerConfig, detect_corners, scratch_len};
use vslam_core::geometry::Vec2;
use vslam_core::image::ImageView;

/// The 100 corners of `view` (a photograph named `name`, for the message).
pub fn hundred_corners(view: &ImageView<'_>, name: &str) -> Vec<Vec2> {
    let config = CornerConfig {
        min_distance: 8.0,
        border: 16,
        ..CornerConfig::default()
    };
    let mut scratch = vec![0f32; scratch_len(view.width(), view.height(), config.block_size)];
    let mut corners = [Corner::default(); 100];
    let n = detect_corners(view, &config, &mut scratch, &mut corners).unwrap();
    assert_eq!(n, 100, "{name}: only {n} corners");
    corners[..n].iter().map(Corner::position).collect()
}
