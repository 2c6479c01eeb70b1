//! The AprilTag extractor: the four corners of one tag36h11 tag, in the tag's own order, refined to
//! sub-pixel, or a verdict and no features (docs/VISION.md).
//!
//! Steps: detect (the reference C library, AprilRobotics' apriltag 3.x, through the `apriltag` crate; first
//! in a region around the previous detection, then, if the tag is not there, in the whole image) → pick the
//! configured id → check every corner is inside the image → refine each of the four edges of the black
//! square on the pixels' area coverage ([`crate::tag_refine`]) and intersect them.
//!
//! Corner order (the C library's `apriltag_detection_t::p`): tag coordinates (−1, +1), (+1, +1), (+1, −1),
//! (−1, −1), i.e. bottom left, bottom right, top right, top left of the tag as printed; the order of
//! `vservo_scene::AprilTag::corners_in_board`, so feature k is always the same physical corner.

use std::cell::RefCell;

use image::GrayImage;
use nalgebra::Point2;
use vservo_scene::{CameraIntrinsics, FeatureVector, MARKS};

use crate::extract::{Extraction, MarkStatus};
use crate::tag_refine::{Straight, refine_corners};

/// Pixels added on every side of the previous detection's bounding box to make the search region, at least.
pub const SEARCH_MARGIN_PX: u32 = 24;

/// What the extractor concluded about one image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TagVerdict {
    /// The configured tag, its four corners refined.
    Found,
    /// No tag of the configured id (and none other) was detected, or its edges could not be refined.
    NotFound,
    /// Only a tag of another id was detected (the first such id).
    WrongId(u32),
    /// The configured tag, but its corner `k` (zero-based, the tag's order) is outside the image.
    CornerOutside(usize),
}

impl TagVerdict {
    /// A reason for people: empty when found.
    pub fn reason(&self) -> String {
        match self {
            TagVerdict::Found => String::new(),
            TagVerdict::NotFound => "tag not found".into(),
            TagVerdict::WrongId(id) => format!("another tag found (id {id})"),
            TagVerdict::CornerOutside(k) => format!("tag corner {} outside the image", k + 1),
        }
    }
}

/// One image's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagExtraction {
    /// The four corners (px) in the tag's order, all NaN unless the verdict is [`TagVerdict::Found`].
    pub features: FeatureVector,
    /// The verdict.
    pub verdict: TagVerdict,
    /// Whether the tag was found in the region around the previous detection (no full-image search).
    pub found_near_previous: bool,
}

impl TagExtraction {
    fn refused(verdict: TagVerdict) -> Self {
        Self { features: FeatureVector::from_element(f64::NAN), verdict, found_near_previous: false }
    }

    /// As the marks' [`Extraction`]: every corner valid, or none (all `NotFound`, or all `OutsideImage`
    /// for a corner outside), so that the cell treats a tag like four marks.
    pub fn to_extraction(&self) -> Extraction {
        let status = match self.verdict {
            TagVerdict::Found => MarkStatus::Valid,
            TagVerdict::CornerOutside(_) => MarkStatus::OutsideImage,
            TagVerdict::NotFound | TagVerdict::WrongId(_) => MarkStatus::NotFound,
        };
        Extraction {
            features: self.features,
            status: [status; MARKS],
            extra_blobs: 0,
            threshold: 0,
            sized_blobs_over_cap: 0,
        }
    }
}

/// A detection of the C library: id and corners (px, the tag's order).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Detected {
    id: u32,
    corners: [Point2<f64>; MARKS],
}

/// The extractor of one tag36h11 id.
#[derive(Debug, Clone)]
pub struct TagExtractor {
    id: u32,
    width_px: u32,
    height_px: u32,
    /// The camera, when its lens distorts: the edges are fitted on its pinhole image.
    lens: Option<CameraIntrinsics>,
}

thread_local! {
    /// The C detector, made once per thread (its tag family's decode table takes a while to build; the
    /// crate's detector is neither `Send` nor `Clone`).
    static DETECTOR: RefCell<Option<apriltag::Detector>> = const { RefCell::new(None) };
}

impl TagExtractor {
    /// An extractor of tag `id` in images of `width_px` × `height_px`.
    pub fn new(id: u32, width_px: u32, height_px: u32) -> Self {
        Self { id, width_px, height_px, lens: None }
    }

    /// An extractor of tag `id` in `camera`'s images: through a lens that distorts, the corners are those
    /// of the lines fitted to the edges on the pinhole image (where they are straight), taken back through
    /// the lens; the same as [`TagExtractor::new`] for a pinhole camera.
    pub fn for_camera(id: u32, camera: &CameraIntrinsics) -> Self {
        let lens = (!camera.distortion().is_none()).then_some(*camera);
        Self { id, width_px: camera.width_px(), height_px: camera.height_px(), lens }
    }

    /// The tag in `image`, looked for first near `previous` (the last frame's corners, if it had them).
    pub fn extract(&self, image: &GrayImage, previous: Option<&FeatureVector>) -> TagExtraction {
        if image.width() != self.width_px || image.height() != self.height_px {
            return TagExtraction::refused(TagVerdict::NotFound);
        }
        let region = previous.and_then(|p| self.search_region(p));
        if let Some(region) = region {
            let near = detect(image, region);
            if let Some(found) = near.iter().find(|d| d.id == self.id) {
                let mut result = self.finish(image, found);
                result.found_near_previous = result.verdict == TagVerdict::Found;
                if result.verdict == TagVerdict::Found {
                    return result;
                }
            }
        }
        let all = detect(image, (0, 0, self.width_px, self.height_px));
        let ours: Vec<&Detected> = all.iter().filter(|d| d.id == self.id).collect();
        match (ours.as_slice(), all.first()) {
            ([one], _) => self.finish(image, one),
            ([], Some(other)) => TagExtraction::refused(TagVerdict::WrongId(other.id)),
            // none at all, or the same id twice (which would be which?)
            _ => TagExtraction::refused(TagVerdict::NotFound),
        }
    }

    /// The checks and the refinement of one detection of our id.
    fn finish(&self, image: &GrayImage, detected: &Detected) -> TagExtraction {
        for (k, corner) in detected.corners.iter().enumerate() {
            if !vservo_scene::image_contains(self.width_px, self.height_px, corner, 0.0) {
                return TagExtraction::refused(TagVerdict::CornerOutside(k));
            }
        }
        let straight = self.lens.as_ref().map_or(Straight::InImage, Straight::OnPinhole);
        let Some(corners) = refine_corners(image, &detected.corners, straight) else {
            return TagExtraction::refused(TagVerdict::NotFound);
        };
        let mut features = FeatureVector::zeros();
        for (k, c) in corners.iter().enumerate() {
            features[2 * k] = c.x;
            features[2 * k + 1] = c.y;
        }
        TagExtraction { features, verdict: TagVerdict::Found, found_near_previous: false }
    }

    /// The previous corners' bounding box grown by a quarter of its size (at least [`SEARCH_MARGIN_PX`])
    /// on every side, clipped to the image: (u0, v0, u1, v1), exclusive ends. `None` without finite corners.
    fn search_region(&self, previous: &FeatureVector) -> Option<(u32, u32, u32, u32)> {
        if !previous.iter().all(|v| v.is_finite()) {
            return None;
        }
        let xs = [previous[0], previous[2], previous[4], previous[6]];
        let ys = [previous[1], previous[3], previous[5], previous[7]];
        let (x0, x1) = (
            xs.iter().copied().fold(f64::INFINITY, f64::min),
            xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        let (y0, y1) = (
            ys.iter().copied().fold(f64::INFINITY, f64::min),
            ys.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        let grow = (0.25 * (x1 - x0).max(y1 - y0)).max(f64::from(SEARCH_MARGIN_PX));
        let clip = |v: f64, high: u32| v.clamp(0.0, f64::from(high)) as u32;
        let region = (
            clip((x0 - grow).floor(), self.width_px),
            clip((y0 - grow).floor(), self.height_px),
            clip((x1 + grow).ceil(), self.width_px),
            clip((y1 + grow).ceil(), self.height_px),
        );
        (region.2 > region.0 + 8 && region.3 > region.1 + 8).then_some(region)
    }
}

/// The tags (id and corners in the tag's order, px) the reference C detector alone finds in the whole image,
/// with the extractor's settings and no refinement: the baseline of the benchmarks and tests.
pub fn reference_detections(image: &GrayImage) -> Vec<(u32, [Point2<f64>; MARKS])> {
    detect(image, (0, 0, image.width(), image.height())).into_iter().map(|d| (d.id, d.corners)).collect()
}

/// The tags the C detector finds in the region (u0, v0, u1, v1) of `image`, corners in image pixels (our
/// convention: pixel (u, v) covers [u, u+1) × [v, v+1); the C library's pixel centres are at integers).
fn detect(image: &GrayImage, (u0, v0, u1, v1): (u32, u32, u32, u32)) -> Vec<Detected> {
    let (w, h) = ((u1 - u0) as usize, (v1 - v0) as usize);
    let stride = w.div_ceil(96) * 96;
    let Ok(mut region) = apriltag::Image::zeros_with_stride(w, h, stride) else { return Vec::new() };
    let width = image.width() as usize;
    let pixels = image.as_raw();
    let buffer = region.as_slice_mut();
    for row in 0..h {
        let from = (v0 as usize + row) * width + u0 as usize;
        buffer[row * stride..row * stride + w].copy_from_slice(&pixels[from..from + w]);
    }
    DETECTOR.with(|cell| {
        let mut slot = cell.borrow_mut();
        if slot.is_none() {
            *slot = make_detector();
        }
        let Some(detector) = slot.as_mut() else { return Vec::new() };
        detector
            .detect(&region)
            .iter()
            .map(|d| Detected {
                id: d.id() as u32,
                corners: d
                    .corners()
                    .map(|[x, y]| Point2::new(x + 0.5 + f64::from(u0), y + 0.5 + f64::from(v0))),
            })
            .collect()
    })
}

/// The C detector for tag36h11, correcting up to one bit (a covered or misread second bit is "not found"),
/// one thread (deterministic), quads found on the image decimated by 2 (decoding stays at full resolution;
/// the corners need only be within [`crate::tag_refine::MAX_CORNER_SHIFT_PX`] for the refinement), its own
/// edge refinement on.
fn make_detector() -> Option<apriltag::Detector> {
    let mut detector =
        apriltag::Detector::builder().add_family_bits(apriltag::Family::tag_36h11(), 1).build().ok()?;
    detector.set_thread_number(1);
    detector.set_decimation(2.0);
    detector.set_sigma(0.0);
    detector.set_refine_edges(true);
    Some(detector)
}
