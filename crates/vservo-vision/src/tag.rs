//! The AprilTag extractor: the four corners of one tag36h11 tag, in the tag's own order, refined to
//! sub-pixel, or a verdict and no features (docs/VISION.md).
//!
//! Steps: detect (the reference C library, AprilRobotics' apriltag 3.x, through the `apriltag` crate; quads
//! searched on the image decimated by 2, then at full resolution, which finds the small and far tags the
//! decimated search misses: first in a region around the previous detection, then in the whole image, the
//! full-resolution search on at most [`FULL_RESOLUTION_MAX_PIXELS`], a larger image one scan tile a frame, [`crate::scan`]) → pick the configured id → check every corner is inside the image → refine each of the four edges of
//! the black square on the pixels' area coverage ([`crate::tag_refine`]) and intersect them. A corner the
//! refinement cannot measure is the decoder's own: a tag the decoder accepted is never dropped, and its
//! [`TagQuality`] says which corners were refined.
//!
//! [`detect_tags`] lists every tag in an image the same way (`vservoctl tags`).
//!
//! Corner order (the C library's `apriltag_detection_t::p`): tag coordinates (−1, +1), (+1, +1), (+1, −1),
//! (−1, −1), i.e. bottom left, bottom right, top right, top left of the tag as printed; the order of
//! `vservo_scene::AprilTag::corners_in_board`, so feature k is always the same physical corner.

use std::cell::{Cell, RefCell};

use image::GrayImage;
use nalgebra::Point2;
use vservo_scene::{Board, CameraIntrinsics, FeatureVector, MARKS, TagBundle};

use crate::extract::{Extraction, ImageProblem, MarkStatus};
use crate::scan::scan_tiles;
use crate::tag_refine::{Straight, refine_corners};

/// Pixels added on every side of the previous detection's bounding box to make the search region, at least.
pub const SEARCH_MARGIN_PX: u32 = 24;

/// The most pixels the extractor searches for quads at full resolution in one frame: 640 × 480. There the
/// search took 53 ms with noise of σ = 5 gray levels (2.9 ms clean), within the 85 ms vision period with the
/// decimated search before it; at 1280 × 1024 it took 287 ms (docs/BENCHMARKS.md). A larger image is searched
/// at full resolution in the region around the previous detection, and, with none, one of its scan tiles a
/// frame ([`crate::scan`]).
pub const FULL_RESOLUTION_MAX_PIXELS: u32 = 640 * 480;

/// A region of the image, (u0, v0, u1, v1) with exclusive ends.
type Region = (u32, u32, u32, u32);

/// Whether `region` is small enough for a full-resolution search in a frame.
/// The C library thresholds in tiles of 4 × 4 pixels of the image it searches for quads, 8 × 8 of the original
/// at the decimation of 2; a search region starts on a multiple of this.
pub(crate) const TILE_GRID_PX: u32 = 8;

fn affordable_at_full_resolution((u0, v0, u1, v1): Region) -> bool {
    (u1 - u0).saturating_mul(v1 - v0) <= FULL_RESOLUTION_MAX_PIXELS
}

/// What the extractor concluded about one image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TagVerdict {
    /// The configured tag, its four corners refined.
    Found,
    /// No tag of the configured id (and none other) was detected, or its edges could not be refined.
    NotFound,
    /// Only a tag of another id was detected (the first such id).
    WrongId(u32),
    /// The configured id was detected more than once (which would be which?): the count.
    Repeated(usize),
    /// The image cannot be used (not the camera's size).
    Unusable(ImageProblem),
    /// The configured tag, but its corner `k` (zero-based, the tag's order) is outside the image.
    CornerOutside(usize),
    /// The configured tag, but its corner `k` could not be refined and lies nearer the image's edge than the
    /// tag's white margin (one cell): the decoder's quad may follow the image's edge rather than the tag's.
    CornerAtTheEdge(usize),
}

impl TagVerdict {
    /// A reason for people: empty when found.
    pub fn reason(&self) -> String {
        match self {
            TagVerdict::Found => String::new(),
            TagVerdict::NotFound => "tag not found".into(),
            TagVerdict::WrongId(id) => format!("another tag found (id {id})"),
            TagVerdict::Repeated(count) => format!("the tag's id is seen {count} times"),
            TagVerdict::Unusable(problem) => problem.to_string(),
            TagVerdict::CornerOutside(k) => format!("tag corner {} outside the image", k + 1),
            TagVerdict::CornerAtTheEdge(k) => {
                format!("tag corner {} too near the image's edge to measure", k + 1)
            }
        }
    }
}

/// How one detection was measured: the decoder's confidence and which corners the refinement measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagQuality {
    /// The decoder's decision margin (the C library's `decision_margin`: the mean difference between the code
    /// cells' grays and the threshold; larger is surer).
    pub decision_margin: f32,
    /// How many bits of the code the decoder corrected (0 or 1 at vservo's settings).
    pub bits_corrected: u8,
    /// Per corner (the tag's order): refined on the pixels' coverage, or the decoder's own.
    pub refined: [bool; MARKS],
    /// Per edge k (corner k to corner k + 1): its fit's RMS (px), NaN where it could not be measured.
    pub edge_rms_px: [f64; MARKS],
    /// Whether the quads were searched at full resolution (the decimated search had not found the tag).
    pub full_resolution: bool,
    /// Which of the target's tags gave the corners, bit k for tag k: 1 for a single tag; for a bundle, the
    /// tags seen (the rest hidden, out of view or refused), the other fields then the worst over them.
    pub tags_used: u8,
}

impl TagQuality {
    /// How many of the four corners were refined.
    pub fn refined_count(&self) -> usize {
        self.refined.iter().filter(|&&r| r).count()
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
    /// How the corners were measured; `None` unless found.
    pub quality: Option<TagQuality>,
}

impl TagExtraction {
    pub(crate) fn refused(verdict: TagVerdict) -> Self {
        Self {
            features: FeatureVector::from_element(f64::NAN),
            verdict,
            found_near_previous: false,
            quality: None,
        }
    }

    /// As the marks' [`Extraction`]: every corner valid, or none (all `NotFound`, or all `OutsideImage`
    /// for a corner outside), so that the cell treats a tag like four marks.
    pub fn to_extraction(&self) -> Extraction {
        let status = match self.verdict {
            TagVerdict::Found => MarkStatus::Valid,
            TagVerdict::CornerOutside(_) | TagVerdict::CornerAtTheEdge(_) => MarkStatus::OutsideImage,
            TagVerdict::NotFound
            | TagVerdict::WrongId(_)
            | TagVerdict::Repeated(_)
            | TagVerdict::Unusable(_) => MarkStatus::NotFound,
        };
        Extraction {
            features: self.features,
            status: [status; MARKS],
            extra_blobs: 0,
            threshold: 0,
            sized_blobs_over_cap: 0,
            tag_quality: self.quality,
        }
    }
}

/// A detection of the C library: id, corners (px, the tag's order) and the decoder's confidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Detected {
    pub(crate) id: u32,
    pub(crate) corners: [Point2<f64>; MARKS],
    decision_margin: f32,
    bits_corrected: u8,
}

/// How finely the C detector searches for quads: on the image decimated by 2 (quick; decoding stays at full
/// resolution), or at full resolution (finds small and far tags the decimated search misses).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum QuadSearch {
    Decimated,
    FullResolution,
}

impl QuadSearch {
    fn decimation(self) -> f32 {
        match self {
            QuadSearch::Decimated => 2.0,
            QuadSearch::FullResolution => 1.0,
        }
    }
}

/// One tag in an image, as [`detect_tags`] lists it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagDetection {
    /// The tag36h11 id.
    pub id: u32,
    /// The corners (px, the tag's order): refined where [`TagQuality::refined`] says so, else the decoder's.
    pub corners: [Point2<f64>; MARKS],
    /// The decoder's own corners (px, the tag's order; the C library's edge-refined quad).
    pub decoder_corners: [Point2<f64>; MARKS],
    /// How they were measured.
    pub quality: TagQuality,
}

/// The extractor of one tag36h11 id, or of a bundle of tags.
#[derive(Debug, Clone)]
pub struct TagExtractor {
    target: TagTarget,
    width_px: u32,
    height_px: u32,
    /// The camera, when its lens distorts: the edges are fitted on its pinhole image.
    lens: Option<CameraIntrinsics>,
    /// In an image too large for one full-resolution search: the scan tile the next acquisition searches.
    next_tile: Cell<u32>,
}

/// What the extractor looks for.
#[derive(Debug, Clone)]
enum TagTarget {
    /// One tag: its corners are the features.
    One(u32),
    /// A bundle: the features are its outer corners, through the homography of the tags seen
    /// ([`crate::bundle`]).
    Bundle(Box<TagBundle>),
}

thread_local! {
    /// The C detector, made once per thread (its tag family's decode table takes a while to build; the
    /// crate's detector is neither `Send` nor `Clone`).
    static DETECTOR: RefCell<Option<apriltag::Detector>> = const { RefCell::new(None) };
}

impl TagExtractor {
    /// An extractor of tag `id` in images of `width_px` × `height_px`.
    pub fn new(id: u32, width_px: u32, height_px: u32) -> Self {
        Self { target: TagTarget::One(id), width_px, height_px, lens: None, next_tile: Cell::new(0) }
    }

    /// An extractor of tag `id` in `camera`'s images: through a lens that distorts, the corners are those
    /// of the lines fitted to the edges on the pinhole image (where they are straight), taken back through
    /// the lens; the same as [`TagExtractor::new`] for a pinhole camera.
    pub fn for_camera(id: u32, camera: &CameraIntrinsics) -> Self {
        let lens = (!camera.distortion().is_none()).then_some(*camera);
        let (width_px, height_px) = (camera.width_px(), camera.height_px());
        Self { target: TagTarget::One(id), width_px, height_px, lens, next_tile: Cell::new(0) }
    }

    /// The extractor of `board`'s target in `camera`'s images: its tag ([`TagExtractor::for_camera`]) or its
    /// bundle (the features its outer corners, found through the homography of every tag of it seen); `None`
    /// for disc marks.
    pub fn for_board(board: &Board, camera: &CameraIntrinsics) -> Option<Self> {
        if let Some(tag) = board.apriltag() {
            return Some(Self::for_camera(tag.id(), camera));
        }
        let bundle = board.bundle()?;
        Some(Self { target: TagTarget::Bundle(Box::new(*bundle)), ..Self::for_camera(0, camera) })
    }

    /// Whether a tag of id `id` is one the extractor looks for.
    fn wants(&self, id: u32) -> bool {
        match &self.target {
            TagTarget::One(ours) => *ours == id,
            TagTarget::Bundle(bundle) => bundle.tag_with_id(id).is_some(),
        }
    }

    /// The lens, when it distorts.
    pub(crate) fn lens(&self) -> Option<&CameraIntrinsics> {
        self.lens.as_ref()
    }

    /// The tag in `image`, looked for first near `previous` (the last frame's corners, if it had them); then in
    /// the whole image, decimated, and where that misses it at full resolution: the whole image up to
    /// [`FULL_RESOLUTION_MAX_PIXELS`], else the next of its [`crate::scan`] (each call the next one, so that a
    /// small tag anywhere in a large image is acquired within as many frames as there are tiles).
    pub fn extract(&self, image: &GrayImage, previous: Option<&FeatureVector>) -> TagExtraction {
        if image.width() != self.width_px || image.height() != self.height_px {
            return TagExtraction::refused(TagVerdict::Unusable(ImageProblem::WrongSize {
                width: self.width_px,
                height: self.height_px,
                got_width: image.width(),
                got_height: image.height(),
            }));
        }
        let region = previous.and_then(|p| self.search_region(p));
        if let Some(region) = region {
            for search in [QuadSearch::Decimated, QuadSearch::FullResolution] {
                if search == QuadSearch::FullResolution && !affordable_at_full_resolution(region) {
                    break;
                }
                if let Some(result) = self.near(image, region, search) {
                    return result;
                }
            }
        }
        let whole = (0, 0, self.width_px, self.height_px);
        let decimated = detect(image, whole, QuadSearch::Decimated);
        if decimated.iter().any(|d| self.wants(d.id)) {
            return self.pick(image, &decimated, QuadSearch::Decimated);
        }
        if affordable_at_full_resolution(whole) {
            return self.pick(
                image,
                &detect(image, whole, QuadSearch::FullResolution),
                QuadSearch::FullResolution,
            );
        }
        self.scan_next_tile(image).unwrap_or_else(|| self.pick(image, &decimated, QuadSearch::Decimated))
    }

    /// The next scan tile searched at full resolution: our tag (or bundle) if it is there.
    fn scan_next_tile(&self, image: &GrayImage) -> Option<TagExtraction> {
        let tiles = scan_tiles(self.width_px, self.height_px);
        let k = self.next_tile.get() % tiles.count();
        self.next_tile.set((k + 1) % tiles.count());
        let in_tile = detect(image, tiles.tile(k), QuadSearch::FullResolution);
        in_tile
            .iter()
            .any(|d| self.wants(d.id))
            .then(|| self.pick(image, &in_tile, QuadSearch::FullResolution))
    }

    /// Our tag (or bundle) in the region around the previous detection, found and measured, if it is there.
    fn near(&self, image: &GrayImage, region: Region, search: QuadSearch) -> Option<TagExtraction> {
        let near = detect(image, region, search);
        if !near.iter().any(|d| self.wants(d.id)) {
            return None;
        }
        let mut result = self.pick(image, &near, search);
        result.found_near_previous = true;
        (result.verdict == TagVerdict::Found).then_some(result)
    }

    /// Our id among the detections: found once, another id only, or repeated; or our bundle's tags.
    fn pick(&self, image: &GrayImage, all: &[Detected], search: QuadSearch) -> TagExtraction {
        let id = match &self.target {
            TagTarget::One(id) => *id,
            TagTarget::Bundle(bundle) => return crate::bundle::extract(self, bundle, image, all, search),
        };
        let ours: Vec<&Detected> = all.iter().filter(|d| d.id == id).collect();
        match (ours.as_slice(), all.first()) {
            ([one], _) => self.finish(image, one, search),
            ([], Some(other)) => TagExtraction::refused(TagVerdict::WrongId(other.id)),
            ([], None) => TagExtraction::refused(TagVerdict::NotFound),
            (many, _) => TagExtraction::refused(TagVerdict::Repeated(many.len())),
        }
    }

    /// One detection checked (every corner in the image, none unrefined at the image's edge) and measured.
    pub(crate) fn checked(
        &self,
        image: &GrayImage,
        detected: &Detected,
        search: QuadSearch,
    ) -> Result<([Point2<f64>; MARKS], TagQuality), TagVerdict> {
        for (k, corner) in detected.corners.iter().enumerate() {
            if !vservo_scene::image_contains(self.width_px, self.height_px, corner, 0.0) {
                return Err(TagVerdict::CornerOutside(k));
            }
        }
        let straight = self.lens.as_ref().map_or(Straight::InImage, Straight::OnPinhole);
        let (corners, quality) = measure(image, detected, straight, search);
        if let Some(k) = (0..MARKS).find(|&k| !quality.refined[k] && self.margin_cut(&corners, k)) {
            return Err(TagVerdict::CornerAtTheEdge(k));
        }
        Ok((corners, quality))
    }

    /// The checks and the refinement of one detection of our id.
    fn finish(&self, image: &GrayImage, detected: &Detected, search: QuadSearch) -> TagExtraction {
        let (corners, quality) = match self.checked(image, detected, search) {
            Ok(measured) => measured,
            Err(verdict) => return TagExtraction::refused(verdict),
        };
        let mut features = FeatureVector::zeros();
        for (k, c) in corners.iter().enumerate() {
            features[2 * k] = c.x;
            features[2 * k + 1] = c.y;
        }
        TagExtraction {
            features,
            verdict: TagVerdict::Found,
            found_near_previous: false,
            quality: Some(quality),
        }
    }

    /// Whether corner `k` lies nearer the image's edge than one cell of the tag (an eighth of its shorter
    /// adjacent edge): the white margin a quad needs is then not all in view.
    fn margin_cut(&self, corners: &[Point2<f64>; MARKS], k: usize) -> bool {
        let (previous, next) = (&corners[(k + MARKS - 1) % MARKS], &corners[(k + 1) % MARKS]);
        let cell = (corners[k] - previous).norm().min((next - corners[k]).norm()) / 8.0;
        let (width, height) = (f64::from(self.width_px), f64::from(self.height_px));
        let to_edge = corners[k].x.min(corners[k].y).min(width - corners[k].x).min(height - corners[k].y);
        to_edge < cell
    }

    /// The previous corners' bounding box grown by a quarter of its size (at least [`SEARCH_MARGIN_PX`])
    /// on every side, clipped to the image: (u0, v0, u1, v1), exclusive ends. `None` without finite corners.
    fn search_region(&self, previous: &FeatureVector) -> Option<Region> {
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
        // the region starts on the whole image's grid of the C library's threshold tiles (4 px, 8 at the
        // decimation of 2), so that the region's pixels are thresholded as the whole image's are
        let on_grid = |v: f64| (v / f64::from(TILE_GRID_PX)).floor() * f64::from(TILE_GRID_PX);
        let region = (
            clip(on_grid(x0 - grow), self.width_px),
            clip(on_grid(y0 - grow), self.height_px),
            clip((x1 + grow).ceil(), self.width_px),
            clip((y1 + grow).ceil(), self.height_px),
        );
        (region.2 > region.0 + 8 && region.3 > region.1 + 8).then_some(region)
    }
}

/// The refined corners of one detection and how they were measured.
fn measure(
    image: &GrayImage,
    detected: &Detected,
    straight: Straight,
    search: QuadSearch,
) -> ([Point2<f64>; MARKS], TagQuality) {
    let refined = refine_corners(image, &detected.corners, straight);
    let quality = TagQuality {
        decision_margin: detected.decision_margin,
        bits_corrected: detected.bits_corrected,
        refined: refined.refined,
        edge_rms_px: refined.edge_rms_px,
        full_resolution: search == QuadSearch::FullResolution,
        tags_used: 1,
    };
    (refined.corners, quality)
}

/// Every tag36h11 tag in `image`, quads searched at full resolution, each refined as the extractor refines
/// its tag (`straight`: where the edges are straight, through the camera's lens if it distorts), in the C
/// library's order. A repeated id is listed once per tag.
pub fn detect_tags(image: &GrayImage, straight: Straight) -> Vec<TagDetection> {
    let whole = (0, 0, image.width(), image.height());
    detect(image, whole, QuadSearch::FullResolution)
        .iter()
        .map(|detected| {
            let (corners, quality) = measure(image, detected, straight, QuadSearch::FullResolution);
            TagDetection { id: detected.id, corners, decoder_corners: detected.corners, quality }
        })
        .collect()
}

/// The tags (id and corners in the tag's order, px) the reference C detector alone finds in the whole image,
/// with the extractor's first settings (quads on the decimated image) and no refinement: the baseline of the
/// benchmarks and tests.
pub fn reference_detections(image: &GrayImage) -> Vec<(u32, [Point2<f64>; MARKS])> {
    let whole = (0, 0, image.width(), image.height());
    detect(image, whole, QuadSearch::Decimated).into_iter().map(|d| (d.id, d.corners)).collect()
}

/// The same at full resolution: what the C library finds when it searches every pixel for quads.
pub fn reference_detections_full_resolution(image: &GrayImage) -> Vec<(u32, [Point2<f64>; MARKS])> {
    let whole = (0, 0, image.width(), image.height());
    detect(image, whole, QuadSearch::FullResolution).into_iter().map(|d| (d.id, d.corners)).collect()
}

/// The tags the C detector finds in the region (u0, v0, u1, v1) of `image`, corners in image pixels. The C
/// library's corners are already in vservo's convention, pixel (u, v) covering [u, u+1) × [v, v+1): its quad fit
/// adds the half pixel itself (`fit_quad`'s "adjust for pixel center bias"; measured on renders, a mean offset
/// of 0.006 / 0.005 px as they come, and 0.5 px with a half pixel added, as vservo did until 2026-12-06).
fn detect(image: &GrayImage, (u0, v0, u1, v1): Region, search: QuadSearch) -> Vec<Detected> {
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
        detector.set_decimation(search.decimation());
        detector
            .detect(&region)
            .iter()
            .map(|d| Detected {
                id: d.id() as u32,
                corners: d.corners().map(|[x, y]| Point2::new(x + f64::from(u0), y + f64::from(v0))),
                decision_margin: d.decision_margin(),
                bits_corrected: d.hamming().min(usize::from(u8::MAX)) as u8,
            })
            .collect()
    })
}

/// The C detector for tag36h11, correcting up to one bit (a covered or misread second bit is "not found"),
/// one thread (deterministic), its own edge refinement on; the quad search's decimation is set per search
/// ([`QuadSearch`]).
fn make_detector() -> Option<apriltag::Detector> {
    let mut detector =
        apriltag::Detector::builder().add_family_bits(apriltag::Family::tag_36h11(), 1).build().ok()?;
    detector.set_thread_number(1);
    detector.set_sigma(0.0);
    detector.set_refine_edges(true);
    Some(detector)
}
