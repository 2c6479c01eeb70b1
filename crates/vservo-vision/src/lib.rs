//! # vservo-vision — what the hand camera sees, and the features in it
//!
//! This crate owns the vision core of vservo (the vision *process* comes with the runtime):
//! - [`render::Renderer`]: the simulated camera. Given `camera_from_board`, the intrinsics and the board,
//!   it renders the 8-bit grayscale image: perspective-correct (discs become ellipses), anti-aliased by
//!   exact-area supersampling at edges, a background of another gray, and, configurable and seeded, Gaussian
//!   pixel noise and a lighting gradient. Through a distorting lens each pixel is judged by its corners' board
//!   points (their pinhole points mapped once per camera, then each frame's homography), with a margin for
//!   the lens's bend, and a pixel near an edge is sampled at points bilinear between its corners' pinhole
//!   points; without distortion, the pinhole path. With an AprilTag target (or a bundle) it draws the tags'
//!   cells.
//! - [`extract::Extractor`]: the four marks in an image — threshold (Otsu or a set level), connected
//!   components, area and shape filters, coverage-weighted sub-pixel centroids, and association of blobs
//!   to marks so that the order of ξ never changes, with per-mark validity and a reason when a mark is
//!   missing, cut by the border, merged with another, or when extra dark blobs appear. `extract` reads as
//!   its steps: threshold, candidates, association (by tracking, [`Prediction::Tracking`], or by the board's
//!   layout, [`Prediction::Layout`]), status, refinement. With marks missing, blobs that fit the layout as
//!   other marks as well are [`MarkStatus::Ambiguous`], not swapped; a lopsided mark's image (its coverage
//!   weights skewed beyond a bound) is [`MarkStatus::Irregular`]. It considers the first
//!   [`extract::MAX_SIZED_BLOBS`] blobs of a mark's size and counts the rest
//!   ([`Extraction::sized_blobs_over_cap`]).
//! - [`tag::TagExtractor`]: with an AprilTag target, the four corners of the configured tag36h11 tag in the
//!   tag's own order (the reference C detector near the last detection, then on the whole image; then a
//!   sub-pixel edge refinement from the pixels' area coverage, [`tag_refine`], fitted on the pinhole image
//!   through a lens that distorts: [`tag_refine::Straight`], [`TagExtractor::for_camera`]), or a verdict (not
//!   found, another id, a corner outside the image) and no features; with a bundle of tags
//!   ([`TagExtractor::for_board`], [`bundle`]), its four outer corners through the homography of every tag of
//!   it seen, so that a tag hidden costs accuracy, not the target. docs/VISION.md.
//! - [`source`]: image sources — the simulated camera (whose [`source::SimulatedCamera::capture_hiding`]
//!   covers a scenario's hidden marks, or a tag's corners), and a directory of PGM or PNG files (recorded
//!   real images).
//!
//! Pixel convention: pixel (u, v) covers [u, u+1) × [v, v+1) in image coordinates, so its centre is
//! (u + ½, v + ½); a point projected to (x, y) (docs/ARCHITECTURE.md, Conventions) lands in pixel (⌊x⌋, ⌊y⌋).
//!
//! The per-frame paths (`Renderer::render`, `Extractor::extract`) do not allocate: buffers are sized once
//! for the configured image (but for the C detector's own buffers).

pub mod blobs;
mod bundle;
pub mod extract;
pub mod noise;
pub mod render;
pub mod scan;
pub mod source;
pub mod tag;
pub mod tag_refine;

pub use extract::{Extraction, Extractor, ExtractorSettings, MarkStatus, Prediction, Threshold};
pub use image::GrayImage;
pub use render::{RenderSettings, Renderer};
pub use tag::{TagDetection, TagExtraction, TagExtractor, TagQuality, TagVerdict};
