//! A bundle's four features from the tags of it that an image shows: each tag seen once is checked and
//! refined as a lone tag is ([`TagExtractor`]); their corners, taken to the pinhole image through the lens,
//! fix the board plane's homography ([`vservo_scene::fit_homography`]); the bundle's outer corners go through
//! it and back through the lens. One tag seen is enough (its four corners fix the homography exactly); every
//! further one averages its corners' errors in. A tag whose id the image shows twice is left out (which would
//! be which?), as is one cut by the image's edge.

use image::GrayImage;
use nalgebra::Point2;
use vservo_scene::{FeatureVector, MARKS, MAX_BUNDLE_TAGS, TagBundle, apply_homography, fit_homography};

use crate::tag::{Detected, QuadSearch, TagExtraction, TagExtractor, TagQuality, TagVerdict};

/// The bundle's outer corners in `image`, from the detections `all`.
pub(crate) fn extract(
    extractor: &TagExtractor,
    bundle: &TagBundle,
    image: &GrayImage,
    all: &[Detected],
    search: QuadSearch,
) -> TagExtraction {
    let mut pairs = [(Point2::origin(), Point2::origin()); MARKS * MAX_BUNDLE_TAGS];
    let (mut paired, mut quality, mut refusal) = (0, None::<TagQuality>, None);
    for (k, tag) in bundle.tags().iter().enumerate() {
        let mut ours = all.iter().filter(|d| d.id == tag.id());
        let (Some(detected), None) = (ours.next(), ours.next()) else { continue };
        let (corners, measured) = match extractor.checked(image, detected, search) {
            Ok(measured) => measured,
            Err(verdict) => {
                refusal.get_or_insert(verdict);
                continue;
            }
        };
        for (in_board, seen) in tag.corners_in_board().iter().zip(&corners) {
            if let Some(pinhole) = to_pinhole(extractor, seen) {
                pairs[paired] = (in_board.xy(), pinhole);
                paired += 1;
            }
        }
        quality = Some(worst(quality, &measured, k));
    }
    let (Some(quality), Some(homography)) = (quality, fit_homography(&pairs[..paired])) else {
        return TagExtraction::refused(refusal.unwrap_or_else(|| nothing_of_ours(bundle, all)));
    };
    let mut features = FeatureVector::zeros();
    for (k, corner) in bundle.outer_corners_in_board().iter().enumerate() {
        let Some(seen) = apply_homography(&homography, &corner.xy()).map(|p| to_observed(extractor, &p))
        else {
            return TagExtraction::refused(TagVerdict::NotFound);
        };
        features[2 * k] = seen.x;
        features[2 * k + 1] = seen.y;
    }
    TagExtraction { features, verdict: TagVerdict::Found, found_near_previous: false, quality: Some(quality) }
}

/// Why no tag of the bundle was used when none was measured: a tag of its seen more than once, another tag
/// only, or nothing.
fn nothing_of_ours(bundle: &TagBundle, all: &[Detected]) -> TagVerdict {
    let repeated = bundle.tags().iter().map(|tag| all.iter().filter(|d| d.id == tag.id()).count()).max();
    match (repeated, all.first()) {
        (Some(count), _) if count > 1 => TagVerdict::Repeated(count),
        (_, Some(other)) if bundle.tag_with_id(other.id).is_none() => TagVerdict::WrongId(other.id),
        _ => TagVerdict::NotFound,
    }
}

/// A measured corner's pinhole pixel: through the lens when it distorts; `None` where the lens cannot
/// undistort it.
fn to_pinhole(extractor: &TagExtractor, observed: &Point2<f64>) -> Option<Point2<f64>> {
    match extractor.lens() {
        Some(lens) => lens.pinhole_of_observed(observed),
        None => Some(*observed),
    }
}

/// Where the lens shows a pinhole pixel.
fn to_observed(extractor: &TagExtractor, pinhole: &Point2<f64>) -> Point2<f64> {
    extractor.lens().map_or(*pinhole, |lens| lens.observed_of_pinhole(pinhole))
}

/// The bundle's quality so far with tag `k`'s measurement added: the smallest decision margin, the most bits
/// corrected, every outer corner refined only where every corner of every tag used was (each outer corner
/// comes from all of them), each edge's largest RMS (NaN where a tag could not measure it), a full-resolution
/// search if any, and tag `k` among those used.
fn worst(so_far: Option<TagQuality>, tag: &TagQuality, k: usize) -> TagQuality {
    let all_refined = tag.refined.iter().all(|&r| r);
    let Some(so_far) = so_far else {
        return TagQuality { refined: [all_refined; MARKS], tags_used: 1 << k, ..*tag };
    };
    TagQuality {
        decision_margin: so_far.decision_margin.min(tag.decision_margin),
        bits_corrected: so_far.bits_corrected.max(tag.bits_corrected),
        refined: [so_far.refined[0] && all_refined; MARKS],
        edge_rms_px: std::array::from_fn(|e| {
            let (a, b) = (so_far.edge_rms_px[e], tag.edge_rms_px[e]);
            if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
        }),
        full_resolution: so_far.full_resolution || tag.full_resolution,
        tags_used: so_far.tags_used | 1 << k,
    }
}
