//! The feature extractor: the four marks' sub-pixel centres in an image, in the board's mark order.

use image::GrayImage;
use vservo_scene::{FeatureVector, MARKS};

use crate::blobs::{Blob, BlobFinder};
pub use vservo_settings::vision::{ExtractorSettings, Threshold};

mod layout;
mod refine;

use layout::{Similarity, match_layout, permutations};
use refine::{MAX_SKEW, refine};

/// Where the marks are expected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Prediction {
    /// Each mark near its position in the previous frame (all four positions given; the caller keeps the
    /// last known one for a mark lost since).
    Tracking(FeatureVector),
    /// Nothing known about this frame: match the blobs to the marks by the board's layout, as seen in this
    /// image of it (for example ξ_d, the image at the desired pose); the layout may be moved, turned and
    /// scaled.
    Layout(FeatureVector),
}

/// Why an image could not be used at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ImageProblem {
    /// Not the configured size.
    #[error("image is {got_width}×{got_height} px, expected {width}×{height}")]
    WrongSize {
        /// Expected width.
        width: u32,
        /// Expected height.
        height: u32,
        /// Width given.
        got_width: u32,
        /// Height given.
        got_height: u32,
    },
    /// Every pixel (nearly) the same gray: all black, all white, or no contrast.
    #[error("image has no contrast (gray {min}–{max}): {what}")]
    NoContrast {
        /// Darkest gray.
        min: u8,
        /// Brightest gray.
        max: u8,
        /// "all black", "all white" or "uniform".
        what: &'static str,
    },
}

/// A mark's state in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkStatus {
    /// Found; its feature is valid.
    Valid,
    /// Its expected position is outside the image.
    OutsideImage,
    /// Its blob touches the image border: part of it is cut off.
    CutByBorder,
    /// Run together with another mark (zero-based index) into one blob.
    MergedWith(usize),
    /// Its blob has the wrong shape (partly occluded, or run into clutter).
    Irregular,
    /// No blob where it should be (occluded, or too faint).
    NotFound,
    /// A blob was found for it, but the blobs seen fit the board's layout as other marks too, and the
    /// image does not say which (some marks are missing): reported missing rather than perhaps swapped.
    Ambiguous,
    /// The image itself is unusable.
    BadImage(ImageProblem),
}

impl MarkStatus {
    /// Whether the feature is valid.
    pub fn is_valid(&self) -> bool {
        *self == MarkStatus::Valid
    }

    /// A reason for people: empty when valid.
    pub fn reason(&self) -> String {
        match self {
            MarkStatus::Valid => String::new(),
            MarkStatus::OutsideImage => "outside the image".into(),
            MarkStatus::CutByBorder => "cut by the image border".into(),
            MarkStatus::MergedWith(other) => format!("merged with mark {}", other + 1),
            MarkStatus::Irregular => "irregular shape (partly occluded?)".into(),
            MarkStatus::NotFound => "not found (occluded or too faint?)".into(),
            MarkStatus::Ambiguous => "ambiguous (the marks seen could be other marks)".into(),
            MarkStatus::BadImage(problem) => format!("bad image: {problem}"),
        }
    }
}

/// One frame's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extraction {
    /// ξ (px); NaN for a mark that is not valid.
    pub features: FeatureVector,
    /// Each mark's state.
    pub status: [MarkStatus; MARKS],
    /// Mark-like dark blobs that belong to no mark.
    pub extra_blobs: usize,
    /// The gray level used to separate dark from bright.
    pub threshold: u8,
    /// Blobs of a mark's size beyond the [`MAX_SIZED_BLOBS`] the extractor considers (in the order found):
    /// not looked at, so a mark among them would be missed. 0 on any image of the board alone.
    pub sized_blobs_over_cap: usize,
    /// With an AprilTag target, how its corners were measured (`None` for disc marks, or no tag found).
    pub tag_quality: Option<crate::tag::TagQuality>,
}

impl Extraction {
    /// Per-mark validity.
    pub fn valid(&self) -> [bool; MARKS] {
        self.status.map(|s| s.is_valid())
    }

    /// Whether all four marks are valid.
    pub fn all_valid(&self) -> bool {
        self.status.iter().all(MarkStatus::is_valid)
    }

    /// Per mark, whether its position is vservo's own sub-pixel measurement: every valid disc (its centre from
    /// the pixels' coverage), a valid tag corner refined on both its edges (not the decoder's own corner).
    pub fn refined(&self) -> [bool; MARKS] {
        let valid = self.valid();
        match &self.tag_quality {
            Some(quality) => std::array::from_fn(|m| valid[m] && quality.refined[m]),
            None => valid,
        }
    }

    fn unusable(problem: ImageProblem, threshold: u8) -> Self {
        Self {
            features: FeatureVector::from_element(f64::NAN),
            status: [MarkStatus::BadImage(problem); MARKS],
            extra_blobs: 0,
            threshold,
            sized_blobs_over_cap: 0,
            tag_quality: None,
        }
    }
}

/// Most candidate blobs the association considers (the largest mark-like ones).
const MAX_CANDIDATES: usize = 8;

/// Most blobs of a mark's size the extractor sorts for its candidates, in the order found; the others are
/// counted ([`Extraction::sized_blobs_over_cap`]).
pub const MAX_SIZED_BLOBS: usize = 32;

/// The extractor and its buffers, sized once for the image.
#[derive(Debug, Clone)]
pub struct Extractor {
    settings: ExtractorSettings,
    width: u32,
    height: u32,
    finder: BlobFinder,
}

#[derive(Debug, Clone, Copy)]
struct Candidate {
    blob: Blob,
    mark_like: bool,
}

impl Extractor {
    /// An extractor for images of `width` × `height`.
    pub fn new(settings: ExtractorSettings, width: u32, height: u32) -> Self {
        Self { settings, width, height, finder: BlobFinder::with_capacity(width, height) }
    }

    /// The settings.
    pub fn settings(&self) -> &ExtractorSettings {
        &self.settings
    }

    /// Extracts the four marks: the threshold, the candidate blobs, their association with the marks, each
    /// mark's status, and the valid marks' centres.
    pub fn extract(&mut self, image: &GrayImage, prediction: &Prediction) -> Extraction {
        let threshold = match self.threshold_of(image) {
            Ok(threshold) => threshold,
            Err(problem) => return Extraction::unusable(problem, 0),
        };
        let settings = self.settings;
        let blobs = self.finder.find_blobs(image, threshold);
        let found = Candidates::of(blobs, &settings);
        let candidates = found.as_slice();
        let (assignment, expected) = associate(candidates, prediction, settings.gate_px);
        let look = Look { image, threshold, blobs, settings: &settings, expected: &expected };
        let tracking = matches!(prediction, Prediction::Tracking(_));
        let ambiguous = look.labels_ambiguous(candidates, &assignment, tracking);
        let mut status: [MarkStatus; MARKS] = std::array::from_fn(|mark| match assignment[mark] {
            Some(_) if ambiguous => MarkStatus::Ambiguous,
            Some(index) => look.assigned_status(mark, &candidates[index]),
            None => look.unassigned_status(mark),
        });
        spread_merges(&mut status);
        let features = refined_features(image, threshold, candidates, &assignment, &mut status);
        let mut used = [false; MAX_CANDIDATES];
        for index in assignment.iter().flatten() {
            used[*index] = true;
        }
        let extra_blobs = candidates.iter().enumerate().filter(|(i, c)| c.mark_like && !used[*i]).count();
        Extraction {
            features,
            status,
            extra_blobs,
            threshold,
            sized_blobs_over_cap: found.over_cap,
            tag_quality: None,
        }
    }

    /// The gray level that separates dark from bright, or why the image cannot be used (not the configured
    /// size, or no contrast).
    fn threshold_of(&self, image: &GrayImage) -> Result<u8, ImageProblem> {
        let (w, h) = image.dimensions();
        if (w, h) != (self.width, self.height) {
            return Err(ImageProblem::WrongSize {
                width: self.width,
                height: self.height,
                got_width: w,
                got_height: h,
            });
        }
        let mut histogram = [0_u32; 256];
        for &p in image.as_raw() {
            histogram[p as usize] += 1;
        }
        let min = histogram.iter().position(|&c| c > 0).unwrap_or(0) as u8;
        let max = histogram.iter().rposition(|&c| c > 0).unwrap_or(0) as u8;
        if max.saturating_sub(min) < 16 {
            let what = if max < 32 {
                "all black"
            } else if min > 223 {
                "all white"
            } else {
                "uniform"
            };
            return Err(ImageProblem::NoContrast { min, max, what });
        }
        Ok(match self.settings.threshold {
            Threshold::Fixed(level) => level,
            Threshold::Otsu => otsu(&histogram),
        })
    }
}

/// The candidates of an image: the largest blobs of a mark's size (of the first [`MAX_SIZED_BLOBS`] found),
/// largest first.
struct Candidates {
    list: [Candidate; MAX_CANDIDATES],
    count: usize,
    /// Blobs of a mark's size found beyond [`MAX_SIZED_BLOBS`]: not considered.
    over_cap: usize,
}

impl Candidates {
    fn of(blobs: &[Blob], settings: &ExtractorSettings) -> Self {
        let mut sized_blobs = [EMPTY_BLOB; MAX_SIZED_BLOBS];
        let (mut sized, mut over_cap) = (0, 0);
        for blob in blobs.iter().filter(|b| b.area >= settings.min_area_px && b.area <= settings.max_area_px)
        {
            if sized < sized_blobs.len() {
                sized_blobs[sized] = *blob;
                sized += 1;
            } else {
                over_cap += 1;
            }
        }
        let sized_blobs = &mut sized_blobs[..sized];
        sized_blobs.sort_unstable_by_key(|b| std::cmp::Reverse(b.area));
        let mut list = [Candidate { blob: EMPTY_BLOB, mark_like: false }; MAX_CANDIDATES];
        let mut count = 0;
        for blob in sized_blobs.iter().take(MAX_CANDIDATES) {
            let mark_like = !blob.touches_border
                && blob.elongation() <= settings.max_elongation
                && blob.ellipse_fill() >= settings.min_ellipse_fill;
            list[count] = Candidate { blob: *blob, mark_like };
            count += 1;
        }
        Self { list, count, over_cap }
    }

    fn as_slice(&self) -> &[Candidate] {
        &self.list[..self.count]
    }
}

/// Which candidate each mark is, and where each mark was expected: by tracking the previous frame's marks
/// (by the layout instead when it places more of them), or by the layout.
fn associate(
    candidates: &[Candidate],
    prediction: &Prediction,
    gate_px: f64,
) -> ([Option<usize>; MARKS], FeatureVector) {
    match prediction {
        Prediction::Tracking(previous) => {
            let tracked = track(candidates, previous, gate_px);
            let assigned = tracked.iter().flatten().count();
            if assigned < MARKS && candidates.iter().filter(|c| c.mark_like).count() > assigned {
                let by_layout = match_layout(candidates, previous);
                if by_layout.0.iter().flatten().count() > assigned {
                    return by_layout;
                }
            }
            (tracked, *previous)
        }
        Prediction::Layout(layout) => match_layout(candidates, layout),
    }
}

/// Whether image point (x, y) is in a blob's bounding box, widened by a pixel or two.
fn in_box(b: &Blob, x: f64, y: f64) -> bool {
    let (u0, v0, u1, v1) = b.bbox;
    x >= f64::from(u0) - 1.0
        && x <= f64::from(u1) + 2.0
        && y >= f64::from(v0) - 1.0
        && y <= f64::from(v1) + 2.0
}

/// What a mark's status is decided from: the image, its threshold and blobs, and where the marks were
/// expected.
struct Look<'a> {
    image: &'a GrayImage,
    threshold: u8,
    blobs: &'a [Blob],
    settings: &'a ExtractorSettings,
    expected: &'a FeatureVector,
}

impl Look<'_> {
    /// Another mark expected inside `blob`'s box, if one is.
    fn other_mark_in(&self, mark: usize, blob: &Blob) -> Option<usize> {
        (0..MARKS).find(|&o| o != mark && in_box(blob, self.expected[2 * o], self.expected[2 * o + 1]))
    }

    /// A mark with a candidate: valid, cut by the border, merged with another or irregular.
    fn assigned_status(&self, mark: usize, c: &Candidate) -> MarkStatus {
        if c.blob.touches_border {
            MarkStatus::CutByBorder
        } else if let Some(other) = self.other_mark_in(mark, &c.blob).filter(|_| !c.mark_like) {
            MarkStatus::MergedWith(other)
        } else if c.mark_like {
            MarkStatus::Valid
        } else {
            MarkStatus::Irregular
        }
    }

    /// A mark with no candidate: outside the image, or, if its expected position is dark, why the blob
    /// there was not one (merged, cut by the border, irregular), else not found.
    fn unassigned_status(&self, mark: usize) -> MarkStatus {
        let (x, y) = (self.expected[2 * mark], self.expected[2 * mark + 1]);
        let (w, h) = self.image.dimensions();
        if !vservo_scene::image_contains(w, h, &nalgebra::Point2::new(x, y), 0.0) {
            return MarkStatus::OutsideImage;
        }
        match self.dark_blob_at(x, y) {
            None => MarkStatus::NotFound,
            Some(blob) => match self.other_mark_in(mark, blob) {
                Some(o) => MarkStatus::MergedWith(o),
                None if blob.touches_border => MarkStatus::CutByBorder,
                None => MarkStatus::Irregular,
            },
        }
    }

    /// The smallest blob of a mark's size whose box holds image point (x, y), if the pixel there is dark.
    fn dark_blob_at(&self, x: f64, y: f64) -> Option<&Blob> {
        let sized = |b: &&Blob| (self.settings.min_area_px..=self.settings.max_area_px).contains(&b.area);
        dark_at(self.image, self.threshold, x, y)
            .then(|| self.blobs.iter().filter(sized).filter(|b| in_box(b, x, y)).min_by_key(|b| b.area))
            .flatten()
    }
}

impl Look<'_> {
    /// The labelling check, when some marks but not all have a blob: the labels predict where the missing
    /// marks are (`expected` carried onto the marks seen by a similarity; by a shift for one mark). If the
    /// image contradicts that (a missing mark predicted inside the image on bright board) while another
    /// labelling of the same blobs, as plausible in shape, explains it (each of its missing marks outside
    /// the image or in a dark blob of a mark's size), the image does not say which marks were seen: a board
    /// that jumped so that two marks left the image shows the other two where the first two were. When
    /// `tracking` (the previous frame's positions), both labellings must also keep the view's turn and
    /// scale near the previous frame's.
    fn labels_ambiguous(
        &self,
        candidates: &[Candidate],
        assignment: &[Option<usize>; MARKS],
        tracking: bool,
    ) -> bool {
        let mut seen = [(0_usize, (0.0, 0.0)); MARKS];
        let mut n_seen = 0;
        for (mark, index) in assignment.iter().enumerate() {
            if let Some(index) = index {
                seen[n_seen] = (mark, candidates[*index].blob.centroid);
                n_seen += 1;
            }
        }
        if n_seen == 0 || n_seen == MARKS {
            return false;
        }
        let seen = &seen[..n_seen];
        let mut labels = [0_usize; MARKS];
        for (label, (mark, _)) in labels.iter_mut().zip(seen) {
            *label = *mark;
        }
        let Some(chosen) = self.carry(&labels[..n_seen], seen) else { return false };
        // tracked from the previous frame, a view of the board moves little: a labelling that turns or
        // scales it much is no alternative, and a chosen one that does is not judged
        let near_previous = |fit: &Similarity| !tracking || fit.as_plausible_as(&Similarity::IDENTITY);
        if !near_previous(&chosen) || self.explains(&chosen, &labels[..n_seen]) {
            return false;
        }
        let mut another_explains = false;
        permutations(&[0, 1, 2, 3], n_seen, &mut |other: &[usize]| {
            if another_explains || other == &labels[..n_seen] {
                return;
            }
            if let Some(fit) = self.carry(other, seen)
                && fit.as_plausible_as(&chosen)
                && near_previous(&fit)
                && self.explains(&fit, other)
            {
                another_explains = true;
            }
        });
        another_explains
    }

    /// The similarity that carries the expected positions of marks `labels` onto the blobs `seen` (a shift
    /// for one), or `None` when the blobs do not have the marks' shape.
    fn carry(&self, labels: &[usize], seen: &[(usize, (f64, f64))]) -> Option<Similarity> {
        let expected = |m: usize| (self.expected[2 * m], self.expected[2 * m + 1]);
        if let [(_, (u, v))] = seen {
            let (x, y) = expected(labels[0]);
            return Some(Similarity { a: 1.0, b: 0.0, tx: u - x, ty: v - y });
        }
        let mut pairs = [((0.0, 0.0), (0.0, 0.0)); MARKS];
        for (pair, (&label, (_, point))) in pairs.iter_mut().zip(labels.iter().zip(seen)) {
            *pair = (expected(label), *point);
        }
        let (fit, misfit) = Similarity::fit(&pairs[..seen.len()]);
        (misfit < 0.02).then_some(fit)
    }

    /// Whether the image agrees with `fit` for the marks not in `labels`: each is predicted outside the
    /// image or in a dark blob of a mark's size (run into another, or cut by the border). Bright board, or
    /// the background beyond the board's edge, where a mark is predicted contradicts it.
    fn explains(&self, fit: &Similarity, labels: &[usize]) -> bool {
        let (w, h) = self.image.dimensions();
        (0..MARKS).filter(|m| !labels.contains(m)).all(|m| {
            let (x, y) = fit.apply((self.expected[2 * m], self.expected[2 * m + 1]));
            !vservo_scene::image_contains(w, h, &nalgebra::Point2::new(x, y), 0.0)
                || self.dark_blob_at(x, y).is_some()
        })
    }
}

/// A mark merged into another's blob makes that one invalid too.
fn spread_merges(status: &mut [MarkStatus; MARKS]) {
    for mark in 0..MARKS {
        if let MarkStatus::MergedWith(other) = status[mark]
            && (status[other].is_valid() || status[other] == MarkStatus::Irregular)
        {
            status[other] = MarkStatus::MergedWith(mark);
        }
    }
}

/// The sub-pixel centres of the valid marks (NaN for the others), each refined without the other marks'
/// blobs; a mark whose image is lopsided (skew above [`MAX_SKEW`]: partly covered) becomes irregular.
fn refined_features(
    image: &GrayImage,
    threshold: u8,
    candidates: &[Candidate],
    assignment: &[Option<usize>; MARKS],
    status: &mut [MarkStatus; MARKS],
) -> FeatureVector {
    let mut features = FeatureVector::from_element(f64::NAN);
    for mark in 0..MARKS {
        if let Some(index) = assignment[mark]
            && status[mark].is_valid()
        {
            let others: [Option<Blob>; MARKS] =
                std::array::from_fn(|o| assignment[o].filter(|_| o != mark).map(|i| candidates[i].blob));
            let refined = refine(image, &candidates[index].blob, threshold, &others);
            if refined.skew > MAX_SKEW {
                status[mark] = MarkStatus::Irregular;
                continue;
            }
            let (x, y) = refined.centre;
            features[2 * mark] = x;
            features[2 * mark + 1] = y;
        }
    }
    features
}

/// Whether the pixel under image point (x, y) is darker than the threshold.
fn dark_at(image: &GrayImage, threshold: u8, x: f64, y: f64) -> bool {
    let (u, v) = (x.floor(), y.floor());
    u >= 0.0
        && v >= 0.0
        && u < f64::from(image.width())
        && v < f64::from(image.height())
        && image.get_pixel(u as u32, v as u32)[0] < threshold
}

const EMPTY_BLOB: Blob = Blob {
    area: 0,
    centroid: (0.0, 0.0),
    covariance: (0.0, 0.0, 0.0),
    bbox: (0, 0, 0, 0),
    touches_border: false,
};

/// Otsu's threshold: the level that maximizes the between-class variance of the histogram. Pixels below the
/// returned level are dark. (Computed from the histogram the extractor already built for its image checks;
/// `imageproc::contrast::otsu_level` would take another pass over the image. The tests compare the two.)
pub fn otsu(histogram: &[u32; 256]) -> u8 {
    let total: f64 = histogram.iter().map(|&c| f64::from(c)).sum();
    let sum_all: f64 = histogram.iter().enumerate().map(|(i, &c)| i as f64 * f64::from(c)).sum();
    let (mut weight_dark, mut sum_dark) = (0.0, 0.0);
    let (mut best, mut best_variance) = (0_usize, -1.0);
    for (level, &count) in histogram.iter().enumerate() {
        weight_dark += f64::from(count);
        sum_dark += level as f64 * f64::from(count);
        let weight_bright = total - weight_dark;
        if weight_dark == 0.0 || weight_bright == 0.0 {
            continue;
        }
        let mean_dark = sum_dark / weight_dark;
        let mean_bright = (sum_all - sum_dark) / weight_bright;
        let variance = weight_dark * weight_bright * (mean_dark - mean_bright).powi(2);
        if variance > best_variance {
            best_variance = variance;
            best = level;
        }
    }
    // levels 0..=best form the dark class
    (best + 1).min(255) as u8
}

/// Nearest mark-like candidate within the gate for each mark, closest pairs first, each candidate once.
fn track(candidates: &[Candidate], previous: &FeatureVector, gate_px: f64) -> [Option<usize>; MARKS] {
    let mut assignment = [None; MARKS];
    let mut taken = [false; MAX_CANDIDATES];
    loop {
        let mut best: Option<(f64, usize, usize)> = None;
        for mark in (0..MARKS).filter(|&m| assignment[m].is_none()) {
            let (x, y) = (previous[2 * mark], previous[2 * mark + 1]);
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            for (i, c) in candidates.iter().enumerate().filter(|(i, _)| !taken[*i]) {
                let d = ((c.blob.centroid.0 - x).powi(2) + (c.blob.centroid.1 - y).powi(2)).sqrt();
                if d <= gate_px && best.is_none_or(|(b, _, _)| d < b) {
                    best = Some((d, mark, i));
                }
            }
        }
        match best {
            Some((_, mark, i)) => {
                assignment[mark] = Some(i);
                taken[i] = true;
            }
            None => return assignment,
        }
    }
}
