//! # test-support
//!
//! Helpers shared by the tests, benches and examples of the traction
//! workspace (a dev-dependency only, never published): [`images`] loads the
//! photographs of `data/images` as 8-bit grayscale, crops them, warps them by
//! a known homography and shifts them by a known sub-pixel offset, so a
//! tracker's answer can be checked against the truth.
//!
//! It depends on no crate of the workspace (the library crates' own tests use
//! it); a caller views a [`images::Gray`] through its public `data`, `width`
//! and `height`, e.g. `vslam_core::image::ImageView::packed`.
#![allow(missing_docs)]

pub mod images;
