//! A bundle of tags on rendered images: its four outer corners against where the camera (through its lens)
//! images the true ones, with every tag in view, with each tag covered in turn, and through a lens; the
//! verdicts when none of its tags is seen.

use nalgebra::{Point2, Rotation3, Translation3, Vector3};
use vservo_scene::{
    AprilTag, Board, CameraIntrinsics, Distortion, FeatureVector, IsometryMatrix3, TagBundle,
};
use vservo_vision::{RenderSettings, Renderer, TagExtractor, TagVerdict};

/// Four 60 mm tags (ids 10 to 13) 20 mm apart on a 140 mm square, in the corner order: tag k's corner k is
/// the bundle's corner k.
fn bundle() -> TagBundle {
    let tag = |id, x, y| AprilTag::tag36h11(id, 0.06, Point2::new(x, y)).expect("an id");
    TagBundle::new(&[tag(10, -0.04, 0.04), tag(11, 0.04, 0.04), tag(12, 0.04, -0.04), tag(13, -0.04, -0.04)])
        .expect("a bundle")
}

fn board(bundle: TagBundle) -> Board {
    Board::with_bundle(bundle, bundle.sheet_extent_in_board())
}

fn pinhole() -> CameraIntrinsics {
    CameraIntrinsics::new(500.0, Point2::new(320.0, 240.0), 640, 480).expect("a camera")
}

/// config/vservo-apriltag.toml's lens: 640 × 480, fx 600, fy 606, k1 = −0.25, k2 = 0.08.
fn lens() -> CameraIntrinsics {
    let distortion = Distortion::new([-0.25, 0.08, 0.0, 0.0, 0.0]).expect("finite");
    CameraIntrinsics::with_lens([600.0, 606.0], Point2::new(322.0, 237.0), 640, 480, distortion)
        .expect("a camera")
}

/// The bundle 0.4–0.6 m away (about 120–200 px wide), shifted, tilted and rolled.
fn poses() -> Vec<IsometryMatrix3<f64>> {
    let pose = |t: [f64; 3], r: [f64; 3]| {
        IsometryMatrix3::from_parts(
            Translation3::from(Vector3::from(t)),
            Rotation3::from_scaled_axis(Vector3::from(r)),
        )
    };
    vec![
        pose([0.0, 0.0, 0.5], [0.0, 0.0, 0.0]),
        pose([0.031, -0.017, 0.45], [0.0, 0.0, 0.3]),
        pose([-0.04, 0.02, 0.55], [0.2, -0.15, 0.05]),
        pose([0.02, 0.03, 0.4], [-0.25, 0.1, -0.6]),
        pose([-0.013, -0.021, 0.6], [0.1, 0.3, 1.2]),
    ]
}

fn noisy() -> RenderSettings {
    RenderSettings { noise_sigma_gray: 5.0, lighting_gradient: [0.0, 0.0], ..Default::default() }
}

/// Where `camera` (through its lens) images the bundle's outer corners at `pose`.
fn truth(camera: &CameraIntrinsics, board: &Board, pose: &IsometryMatrix3<f64>) -> FeatureVector {
    let mut truth = FeatureVector::zeros();
    for (k, corner) in board.marks_in_board.iter().enumerate() {
        let seen = camera.project_observed(&(pose * corner)).expect("in front");
        truth[2 * k] = seen.x;
        truth[2 * k + 1] = seen.y;
    }
    truth
}

/// The largest corner error (px) of the bundle extracted from `shown` (the board rendered, some tags perhaps
/// covered) against the truth of the whole bundle, over the poses; asserts each is found from the tags shown.
fn worst_corner_px(camera: &CameraIntrinsics, hidden: u8) -> f64 {
    let whole = board(bundle());
    let shown = Board {
        target: vservo_scene::Target::Bundle(bundle().with_tags_covered(hidden).expect("one left")),
        ..whole
    };
    let extractor = TagExtractor::for_board(&whole, camera).expect("a bundle's extractor");
    let mut worst: f64 = 0.0;
    for (i, pose) in poses().iter().enumerate() {
        let image = Renderer::new(*camera, noisy()).render(&shown, pose, i as u64).clone();
        let found = extractor.extract(&image, None);
        assert_eq!(found.verdict, TagVerdict::Found, "pose {i}, tags {hidden:04b} covered");
        let quality = found.quality.expect("a found bundle's quality");
        assert_eq!(quality.tags_used, 0b1111 & !hidden, "pose {i}: the tags shown, and only they, are used");
        let truth = truth(camera, &whole, pose);
        for k in 0..4 {
            let error = (found.features.fixed_rows::<2>(2 * k) - truth.fixed_rows::<2>(2 * k)).norm();
            worst = worst.max(error);
        }
    }
    worst
}

/// Every tag in view: the outer corners within 0.3 px (a lone tag's refined corners' bar) through a pinhole
/// and through the lens, with noise of σ = 5.
#[test]
fn the_outer_corners_are_found_from_every_tag() {
    for (camera, what) in [(pinhole(), "pinhole"), (lens(), "lens")] {
        let worst = worst_corner_px(&camera, 0);
        println!("{what}: all four tags, worst corner {worst:.3} px");
        assert!(worst < 0.3, "{what}: {worst} px");
    }
}

/// Any one tag covered: the bundle is still found, from the other three, its corners within 0.5 px (the
/// covered tag's corner extrapolated a tag's width from the nearest seen corner).
#[test]
fn one_tag_covered_costs_accuracy_not_the_target() {
    for (camera, what) in [(pinhole(), "pinhole"), (lens(), "lens")] {
        for k in 0..4 {
            let worst = worst_corner_px(&camera, 1 << k);
            println!("{what}: tag {k} covered, worst corner {worst:.3} px");
            assert!(worst < 0.5, "{what}, tag {k} covered: {worst} px");
        }
        // one tag alone: its corners' errors carried 2.3 tag widths to the far corner
        let worst = worst_corner_px(&camera, 0b0111);
        println!("{what}: one tag alone, worst corner {worst:.3} px");
        assert!(worst < 2.0, "{what}, one tag alone: {worst} px");
    }
}

/// No tag of the bundle in the image: not found, or another id named; never features.
#[test]
fn without_its_tags_the_bundle_is_not_found() {
    let camera = pinhole();
    let extractor = TagExtractor::for_board(&board(bundle()), &camera).expect("a bundle's extractor");
    let stranger = AprilTag::tag36h11(3, 0.1, Point2::origin()).expect("an id");
    let other = Board::with_apriltag(stranger, stranger.sheet_extent_in_board());
    let image = Renderer::new(camera, noisy()).render(&other, &poses()[0], 1).clone();
    let found = extractor.extract(&image, None);
    assert_eq!(found.verdict, TagVerdict::WrongId(3));
    assert!(found.features.iter().all(|v| v.is_nan()) && found.quality.is_none());
    let blank = vservo_vision::GrayImage::from_pixel(640, 480, image::Luma([200]));
    assert_eq!(extractor.extract(&blank, None).verdict, TagVerdict::NotFound);
}
