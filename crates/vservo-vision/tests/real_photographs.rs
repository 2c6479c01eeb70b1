//! The tag detector on real photographs someone else took and checked: AprilRobotics' own test data (three
//! photographs from NASA's Swarmathon, 799 × 533 colour JPEGs holding 47 tag36h11 tags of 20–45 px, all of id
//! 0), with the C library's expected detections at full resolution, as `scripts/setup-tag-photos.sh` puts them
//! in target/tag-photos/ (docs/VISION.md, "Real photographs"). Never against vservo's own renders: the truth
//! here is the reference library's published answer.

use std::path::{Path, PathBuf};

use nalgebra::Point2;
use vservo_scene::{FeatureVector, MARKS};
use vservo_vision::tag::{detect_tags, reference_detections, reference_detections_full_resolution};
use vservo_vision::tag_refine::Straight;
use vservo_vision::{GrayImage, TagExtractor, TagVerdict};

/// One tag the C library's test expects: id and corners in vservo's pixels (its pixel centres are at integers,
/// ours at + ½).
struct Expected {
    id: u32,
    corners: [Point2<f64>; MARKS],
}

fn photo_folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/tag-photos")
}

/// Every photograph with its expected tags; the premise: the set is there, whole (run scripts/setup.sh).
fn photographs() -> Vec<(PathBuf, GrayImage, Vec<Expected>)> {
    let folder = photo_folder();
    let mut photos: Vec<PathBuf> = std::fs::read_dir(&folder)
        .unwrap_or_else(|e| panic!("{}: {e} (scripts/setup-tag-photos.sh makes it)", folder.display()))
        .flatten()
        .map(|entry| entry.path())
        .filter(|path| path.extension().is_some_and(|e| e == "jpg"))
        .collect();
    photos.sort();
    assert_eq!(photos.len(), 3, "the three photographs of the C library's test data");
    photos
        .into_iter()
        .map(|path| {
            let (image, colour) = vservo_vision::source::read_image_as_gray(&path).expect("a JPEG");
            assert!(colour.has_color(), "the photographs are colour JPEGs");
            let expected = expected_tags(&path.with_extension("txt"));
            (path, image, expected)
        })
        .collect()
}

/// The C library's test's detections of one photograph.
fn expected_tags(path: &Path) -> Vec<Expected> {
    vservo_vision::source::read_apriltag_test_detections(path)
        .expect("the expected detections")
        .into_iter()
        .map(|(id, corners)| Expected { id, corners })
        .collect()
}

/// The largest distance between corresponding corners (px).
fn farthest_px(a: &[Point2<f64>; MARKS], b: &[Point2<f64>; MARKS]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).fold(0.0, f64::max)
}

fn centre(corners: &[Point2<f64>; MARKS]) -> Point2<f64> {
    corners.iter().fold(Point2::origin(), |sum, c| sum + c.coords / MARKS as f64)
}

/// The index of the expected tag of `id` whose centre lies within 3 px of the centre of `corners` (the same
/// tag: the nearest two tags in the set are 20 px apart; the corners themselves differ by up to a few pixels
/// between the library's modes on the smallest and most oblique tags), if any.
fn matching(expected: &[Expected], id: u32, corners: &[Point2<f64>; MARKS]) -> Option<usize> {
    expected.iter().position(|e| e.id == id && (centre(&e.corners) - centre(corners)).norm() <= 3.0)
}

/// The median and the largest of the farthest-corner distances.
fn median_and_max(mut distances: Vec<f64>) -> (f64, f64) {
    distances.sort_by(f64::total_cmp);
    (distances[distances.len() / 2], distances[distances.len() - 1])
}

/// vservo finds every tag the C library finds at full resolution on the same pixels (its decoder's corners
/// those of the library), and each of them is one the library's own test expects, at the same place (the
/// expected come without the library's edge refinement): no false detection. A tag the test
/// expects but neither finds is the JPEG decoder's doing (the expected come from the library's own decoder;
/// OpenCV's, through pupil-apriltags, misses another one), and is counted.
#[test]
fn vservo_finds_what_the_c_library_finds_at_full_resolution_and_nothing_unexpected() {
    let (mut expected_total, mut found_total, mut decoded_away) = (0, 0, 0);
    let mut agreement = Vec::new();
    for (path, image, expected) in photographs() {
        let found = detect_tags(&image, Straight::InImage);
        let reference = reference_detections_full_resolution(&image);
        assert_eq!(found.len(), reference.len(), "{}", path.display());
        for (tag, (id, corners)) in found.iter().zip(&reference) {
            assert_eq!((tag.id, tag.decoder_corners), (*id, *corners), "{}", path.display());
        }
        let mut matched = vec![0; expected.len()];
        for tag in &found {
            let index = matching(&expected, tag.id, &tag.decoder_corners).unwrap_or_else(|| {
                panic!("{}: id {} at {:?} is not expected", path.display(), tag.id, tag.corners)
            });
            matched[index] += 1;
            agreement.push(farthest_px(&tag.corners, &expected[index].corners));
        }
        for (e, count) in expected.iter().zip(&matched) {
            assert!(*count <= 1, "{}: the tag at {:?} found {count} times", path.display(), e.corners);
            if *count == 0 {
                eprintln!(
                    "{}: the tag at {:?} is not in these pixels for the C library either",
                    path.display(),
                    e.corners
                );
                decoded_away += 1;
            }
        }
        expected_total += expected.len();
        found_total += found.len();
    }
    assert_eq!(expected_total, 47);
    let (median, max) = median_and_max(agreement);
    eprintln!(
        "{found_total} of the {expected_total} expected tags found; {decoded_away} lost to the JPEG decoder; \
         farthest corner from the expected: median {median:.2} px, max {max:.2} px"
    );
    assert_eq!(found_total + decoded_away, expected_total);
}

/// The refinement never drops a tag the decoder accepted, at vservo's first settings (quads on the decimated
/// image) or at full resolution: every decoder detection comes out with four finite corners, each refined or
/// the decoder's own, and a refined corner stays near the decoder's.
#[test]
fn the_refinement_keeps_every_tag_the_decoder_accepted() {
    let (mut corners, mut refined) = (0, 0);
    for (path, image, _) in photographs() {
        let decimated = reference_detections(&image).len();
        let listed = detect_tags(&image, Straight::InImage);
        assert!(listed.len() >= decimated, "{}: {} of {decimated}", path.display(), listed.len());
        for tag in &listed {
            for k in 0..MARKS {
                let (corner, decoder) = (tag.corners[k], tag.decoder_corners[k]);
                assert!(
                    corner.x.is_finite() && corner.y.is_finite(),
                    "{}: {:?}",
                    path.display(),
                    tag.corners
                );
                if tag.quality.refined[k] {
                    assert!((corner - decoder).norm() <= 2.0, "{}: {corner} from {decoder}", path.display());
                } else {
                    assert_eq!(corner, decoder);
                }
            }
            corners += MARKS;
            refined += tag.quality.refined_count();
        }
    }
    eprintln!("{refined} of {corners} corners refined, the others the decoder's");
}

/// The servo's path, tracking: each tag alone in the photograph (the rest of it a flat gray, so that its id is
/// not repeated), its last corners 2 px off where they are now, is found by the extractor wherever the C library
/// at full resolution finds it in those pixels — through the full-resolution search around the last corners
/// where the decimated one misses it (the photograph, 799 × 533, is over the full-resolution budget for the
/// whole image) — at the place the C library's test expects it; or refused with a verdict when an unrefined
/// corner lies at the image's edge. With no last corners, from scratch, it is acquired within as many frames as
/// the photograph has scan tiles (two: each frame searches the next at full resolution, `vservo_vision::scan`).
#[test]
fn the_extractor_finds_each_tag_alone_in_the_photograph() {
    let (mut found, mut at_full_resolution, mut at_the_edge, mut total, mut kept_before) = (0, 0, 0, 0, 0);
    let (mut acquisitions, mut by_a_scan_tile) = (0, 0);
    let mut agreement = Vec::new();
    for (path, image, expected) in photographs() {
        let extractor = TagExtractor::new(0, image.width(), image.height());
        for tag in &expected {
            let alone = only_around(&image, &tag.corners);
            // not in these pixels for the library either, or a neighbour too near to mask away
            if reference_detections_full_resolution(&alone).len() != 1 {
                continue;
            }
            total += 1;
            let last = FeatureVector::from_fn(|i, _| {
                if i % 2 == 0 { tag.corners[i / 2].x + 2.0 } else { tag.corners[i / 2].y - 2.0 }
            });
            let result = extractor.extract(&alone, Some(&last));
            let tiles = vservo_vision::scan::scan_tiles(image.width(), image.height()).count();
            assert_eq!(tiles, 2, "799 × 533 is over the budget for one full-resolution search");
            let acquired = (0..tiles)
                .map(|_| extractor.extract(&alone, None))
                .find(|a| a.verdict != TagVerdict::NotFound);
            let acquired_where_expected = acquired.is_some_and(|a| {
                let corners: [Point2<f64>; MARKS] =
                    std::array::from_fn(|k| Point2::new(a.features[2 * k], a.features[2 * k + 1]));
                a.verdict == result.verdict
                    && (a.verdict != TagVerdict::Found
                        || matching(std::slice::from_ref(tag), 0, &corners).is_some())
            });
            assert!(
                acquired_where_expected,
                "{}: the tag at {:?} not acquired within {tiles} frames as it is tracked ({:?}): {acquired:?}",
                path.display(),
                tag.corners,
                result.verdict
            );
            acquisitions += 1;
            by_a_scan_tile +=
                usize::from(acquired.and_then(|a| a.quality).is_some_and(|q| q.full_resolution));
            if let TagVerdict::CornerAtTheEdge(_) = result.verdict {
                at_the_edge += 1;
                continue;
            }
            assert_eq!(
                result.verdict,
                TagVerdict::Found,
                "{}: the tag at {:?}: {:?}",
                path.display(),
                tag.corners,
                result.quality
            );
            let corners: [Point2<f64>; MARKS] =
                std::array::from_fn(|k| Point2::new(result.features[2 * k], result.features[2 * k + 1]));
            let here = std::slice::from_ref(tag);
            assert!(
                matching(here, 0, &corners).is_some(),
                "{}: {corners:?} for {:?}",
                path.display(),
                tag.corners
            );
            agreement.push(farthest_px(&corners, &tag.corners));
            found += 1;
            at_full_resolution += usize::from(result.quality.is_some_and(|q| q.full_resolution));
            // what the extractor kept until it kept unrefined corners: the decimated search, all four refined
            kept_before +=
                usize::from(result.quality.is_some_and(|q| !q.full_resolution && q.refined_count() == MARKS));
        }
    }
    let (median, max) = median_and_max(agreement);
    eprintln!(
        "{found} of {total} found ({at_full_resolution} by the full-resolution search; {kept_before} would have been \
         kept before), {at_the_edge} at the edge, {acquisitions} acquired from scratch as tracked ({by_a_scan_tile} by a scan tile); farthest corner \
         from the expected: median {median:.2} px, max {max:.2} px"
    );
    assert!(total >= 40, "{total} tags alone in view");
    assert!(at_the_edge <= 1, "{at_the_edge} refused at the image's edge");
}

/// `image` with everything farther than a third of the tag's size from its corners' box a flat mid gray.
fn only_around(image: &GrayImage, corners: &[Point2<f64>; MARKS]) -> GrayImage {
    let (mut low, mut high) = (Point2::new(f64::MAX, f64::MAX), Point2::new(f64::MIN, f64::MIN));
    for c in corners {
        low = Point2::new(low.x.min(c.x), low.y.min(c.y));
        high = Point2::new(high.x.max(c.x), high.y.max(c.y));
    }
    let grow = (high.x - low.x).max(high.y - low.y) / 3.0;
    GrayImage::from_fn(image.width(), image.height(), |u, v| {
        let (x, y) = (f64::from(u) + 0.5, f64::from(v) + 0.5);
        let inside = x >= low.x - grow && x <= high.x + grow && y >= low.y - grow && y <= high.y + grow;
        if inside { *image.get_pixel(u, v) } else { image::Luma([128]) }
    })
}
