//! The AprilTag extractor on rendered images: corners against the projection of the true corners (never
//! against the detector itself), the verdicts, and robustness to noise, blur, a lighting gradient and a
//! partly covered tag.

use image::GrayImage;
use nalgebra::{Point2, Rotation3, Translation3, Vector3};
use vservo_scene::{AprilTag, Board, CameraIntrinsics, FeatureVector, IsometryMatrix3};
use vservo_vision::{RenderSettings, Renderer, TagExtraction, TagExtractor, TagVerdict};

const ID: u32 = 3;

fn camera(width: u32, height: u32) -> CameraIntrinsics {
    let c = Point2::new(f64::from(width) / 2.0, f64::from(height) / 2.0);
    CameraIntrinsics::new(500.0 * f64::from(width) / 640.0, c, width, height).expect("valid camera")
}

fn board(id: u32) -> Board {
    let tag = AprilTag::tag36h11(id, 0.16, Point2::new(-0.01, -0.135)).expect("a tag36h11 id");
    Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)])
}

/// Poses that show the tag 150–250 px wide at 640 × 480, shifted, tilted and rolled.
fn poses() -> Vec<IsometryMatrix3<f64>> {
    // the tag's centre at t in the camera frame, the board turned by r about it
    let pose = |t: [f64; 3], r: [f64; 3]| {
        IsometryMatrix3::from_parts(
            Translation3::from(Vector3::from(t)),
            Rotation3::from_scaled_axis(Vector3::from(r)),
        ) * IsometryMatrix3::from_parts(Translation3::new(0.01, 0.135, 0.0), Rotation3::identity())
    };
    vec![
        pose([0.0, 0.0, 0.5], [0.0, 0.0, 0.0]),
        pose([0.031, -0.017, 0.45], [0.0, 0.0, 0.3]),
        pose([-0.04, 0.02, 0.55], [0.2, -0.15, 0.05]),
        pose([0.02, 0.03, 0.4], [-0.25, 0.1, -0.6]),
        pose([-0.013, -0.021, 0.48], [0.1, 0.3, 1.2]),
        pose([0.05, -0.04, 0.62], [0.0, 0.0, 2.5]),
    ]
}

fn render(
    board: &Board,
    pose: &IsometryMatrix3<f64>,
    settings: RenderSettings,
    size: (u32, u32),
) -> GrayImage {
    let mut renderer = Renderer::new(camera(size.0, size.1), settings);
    renderer.render(board, pose, 7).clone()
}

fn clean() -> RenderSettings {
    RenderSettings { noise_sigma_gray: 0.0, lighting_gradient: [0.0, 0.0], ..Default::default() }
}

fn noisy() -> RenderSettings {
    RenderSettings { noise_sigma_gray: 5.0, lighting_gradient: [0.0, 0.0], ..Default::default() }
}

/// RMS over the corners of the distance between extracted and true corners (px).
fn rms_px(found: &FeatureVector, truth: &FeatureVector) -> f64 {
    ((found - truth).norm_squared() / 4.0).sqrt()
}

/// A found tag's corners against the truth: each refined corner within 0.3 px, as every corner was before the
/// refinement kept tags it cannot measure; each corner it could not refine (the decoder's own, marked so in its
/// quality) within the refinement's own bound on the decoder's corners, 2 px. How many were the decoder's.
fn assert_right_corners(found: &TagExtraction, truth: &FeatureVector, what: &str) -> usize {
    let quality = found.quality.expect("a found tag's quality");
    for k in 0..4 {
        let error = (found.features.fixed_rows::<2>(2 * k) - truth.fixed_rows::<2>(2 * k)).norm();
        let bar = if quality.refined[k] { 0.3 } else { 2.0 };
        assert!(error < bar, "{what}: corner {k} {error:.3} px off (refined: {})", quality.refined[k]);
    }
    4 - quality.refined_count()
}

/// The RMS corner error over all poses, every one of which must be found.
fn rms_over_poses(settings: RenderSettings, filter: impl Fn(&GrayImage) -> GrayImage) -> f64 {
    let board = board(ID);
    let extractor = TagExtractor::new(ID, 640, 480);
    let mut sum = 0.0;
    for (i, pose) in poses().iter().enumerate() {
        let image = filter(&render(&board, pose, settings, (640, 480)));
        let truth = camera(640, 480).project_marks(&board, pose).expect("in front");
        let found = extractor.extract(&image, None);
        assert_eq!(found.verdict, TagVerdict::Found, "pose {i}");
        let rms = rms_px(&found.features, &truth);
        eprintln!("pose {i}: {rms:.4} px RMS");
        sum += rms * rms;
    }
    (sum / poses().len() as f64).sqrt()
}

#[test]
fn corners_are_within_a_tenth_of_a_pixel_rms_of_the_projected_true_corners_on_clean_images() {
    let rms = rms_over_poses(clean(), GrayImage::clone);
    assert!(rms <= 0.1, "{rms} px RMS");
}

#[test]
fn corners_are_within_three_tenths_of_a_pixel_rms_with_noise_of_sigma_five() {
    let rms = rms_over_poses(noisy(), GrayImage::clone);
    assert!(rms <= 0.3, "{rms} px RMS");
}

#[test]
fn the_previous_detection_gives_the_same_corners_as_the_full_image() {
    let board = board(ID);
    let extractor = TagExtractor::new(ID, 640, 480);
    for pose in poses() {
        let image = render(&board, &pose, noisy(), (640, 480));
        let full = extractor.extract(&image, None);
        let near = extractor.extract(&image, Some(&full.features));
        assert!(near.found_near_previous, "{:?} {:?}", full, near);
        assert_eq!(near.verdict, TagVerdict::Found);
        assert!(
            (near.features - full.features).amax() < 0.05,
            "{} px apart",
            (near.features - full.features).amax()
        );
    }
}

#[test]
fn a_stale_previous_detection_falls_back_to_the_whole_image() {
    let board = board(ID);
    let extractor = TagExtractor::new(ID, 640, 480);
    let image = render(&board, &poses()[0], clean(), (640, 480));
    // the tag was last seen in the top-left corner of the image
    let stale = FeatureVector::from([10.0, 60.0, 60.0, 60.0, 60.0, 10.0, 10.0, 10.0]);
    let found = extractor.extract(&image, Some(&stale));
    assert_eq!(found.verdict, TagVerdict::Found);
    assert!(!found.found_near_previous);
}

#[test]
fn no_tag_in_the_image_is_not_found_with_no_features() {
    let marks = Board::paper();
    let image = render(&marks, &poses()[0], noisy(), (640, 480));
    let found = TagExtractor::new(ID, 640, 480).extract(&image, None);
    assert_eq!(found.verdict, TagVerdict::NotFound);
    assert!(found.features.iter().all(|v| v.is_nan()));
}

#[test]
fn another_id_is_the_verdict_wrong_id_with_no_features() {
    let image = render(&board(ID + 1), &poses()[1], noisy(), (640, 480));
    let found = TagExtractor::new(ID, 640, 480).extract(&image, None);
    assert_eq!(found.verdict, TagVerdict::WrongId(ID + 1));
    assert!(found.features.iter().all(|v| v.is_nan()));
    assert!(found.to_extraction().status.iter().all(|s| !s.is_valid()));
}

/// The board jumps sideways by `shift_m` (camera frame) from the centred pose: what is expected is either
/// the right corners (the tag wholly in view) or a verdict with no features, never wrong corners.
#[test]
fn a_board_jump_that_takes_the_tag_partly_out_of_view_gives_a_verdict_never_wrong_corners() {
    let board = board(ID);
    let extractor = TagExtractor::new(ID, 640, 480);
    let centred = poses()[0];
    let mut refused = 0;
    for step in 0..=40 {
        let shift = -0.6 + 0.03 * f64::from(step);
        let pose =
            IsometryMatrix3::from_parts(Translation3::new(shift, 0.0, 0.0), Rotation3::identity()) * centred;
        let image = render(&board, &pose, noisy(), (640, 480));
        let truth = camera(640, 480).project_marks(&board, &pose).expect("in front");
        let previous = camera(640, 480).project_marks(&board, &centred).expect("in front");
        let found = extractor.extract(&image, Some(&previous));
        let all_in = truth.iter().step_by(2).all(|&x| (0.0..640.0).contains(&x));
        match found.verdict {
            TagVerdict::Found => {
                assert!(all_in, "shift {shift}: found with a corner out of view");
                assert_right_corners(&found, &truth, &format!("shift {shift}"));
            }
            TagVerdict::NotFound | TagVerdict::CornerOutside(_) | TagVerdict::CornerAtTheEdge(_) => {
                assert!(found.features.iter().all(|v| v.is_nan()));
                refused += 1;
                assert!(
                    !all_in || truth.iter().step_by(2).any(|&x| !(40.0..600.0).contains(&x)),
                    "shift {shift}: a tag well inside the image was not found"
                );
            }
            TagVerdict::WrongId(id) => panic!("shift {shift}: id {id} read from a tag partly out of view"),
            TagVerdict::Repeated(count) => panic!("shift {shift}: one tag seen {count} times"),
            TagVerdict::Unusable(problem) => panic!("shift {shift}: {problem}"),
        }
    }
    assert!(refused >= 10, "the jumps took the tag out of view {refused} times");
}

/// Box blur of radius 1 (3 × 3) and a Gaussian of σ = 1 px: the tag is found, corners within 0.3 px.
#[test]
fn corners_survive_a_box_blur_and_a_gaussian_blur() {
    let box3 = |image: &GrayImage| imageproc::filter::box_filter(image, 1, 1);
    let rms = rms_over_poses(noisy(), box3);
    assert!(rms <= 0.3, "box blur: {rms} px RMS");
    let gauss = |image: &GrayImage| imageproc::filter::gaussian_blur_f32(image, 1.0);
    let rms = rms_over_poses(noisy(), gauss);
    assert!(rms <= 0.3, "gaussian blur: {rms} px RMS");
}

/// A lighting gradient of 40 % across the image left to right and 20 % top to bottom: corners within 0.3 px.
#[test]
fn corners_survive_a_lighting_gradient() {
    let lit = RenderSettings { lighting_gradient: [0.4, -0.2], ..noisy() };
    let rms = rms_over_poses(lit, GrayImage::clone);
    assert!(rms <= 0.3, "{rms} px RMS");
}

/// A gray patch over part of the tag: over two code cells the code is misread (not found is expected, the
/// decoder corrects one bit only); over one cell of the border edge the edge fit drops the strips it covers,
/// or the corners of that edge stay the decoder's. In every case: the right corners or none, never others.
#[test]
fn a_partly_covered_tag_gives_the_right_corners_or_none() {
    let board = board(ID);
    let extractor = TagExtractor::new(ID, 640, 480);
    let pose = poses()[0];
    let truth = camera(640, 480).project_marks(&board, &pose).expect("in front");
    let clean_image = render(&board, &pose, noisy(), (640, 480));
    // the tag spans 160 px centred at (320, 240): cells 20 px; cover patches of the image
    let patches: [(u32, u32, u32, u32); 5] = [
        (262, 262, 40, 20),   // two code cells
        (242, 300, 80, 20),   // four code cells
        (300, 155, 40, 20),   // across the top border edge
        (150, 150, 120, 120), // a whole corner of the tag
        (330, 182, 20, 20),   // one code cell
    ];
    let mut found_count = 0;
    for (i, &(u0, v0, w, h)) in patches.iter().enumerate() {
        let mut image = clean_image.clone();
        for v in v0..v0 + h {
            for u in u0..u0 + w {
                image.put_pixel(u, v, image::Luma([128]));
            }
        }
        let found = extractor.extract(&image, None);
        match found.verdict {
            TagVerdict::Found => {
                found_count += 1;
                let unrefined = assert_right_corners(&found, &truth, &format!("patch {i}"));
                eprintln!("patch {i}: {unrefined} corner(s) the decoder's");
            }
            TagVerdict::WrongId(id) => panic!("patch {i}: id {id} read from a covered tag"),
            _ => assert!(found.features.iter().all(|v| v.is_nan())),
        }
        eprintln!("patch {i}: {:?}", found.verdict);
    }
    assert!(found_count < patches.len(), "a whole corner covered cannot be found");
}

#[test]
fn the_tag_is_found_at_1280_by_1024_too() {
    let board = board(ID);
    let extractor = TagExtractor::new(ID, 1280, 1024);
    let pose = poses()[2];
    let image = render(&board, &pose, noisy(), (1280, 1024));
    let truth = camera(1280, 1024).project_marks(&board, &pose).expect("in front");
    let found = extractor.extract(&image, None);
    assert_eq!(found.verdict, TagVerdict::Found);
    assert!(rms_px(&found.features, &truth) <= 0.3);
}

/// Through a lens (config/vservo-apriltag.toml's: 640 × 480, fx 600, fy 606, k1 = −0.25, k2 = 0.08) the
/// square's edges are curves: fitted on the camera's pinhole image, the corners are within 0.1 px RMS of
/// where the lens images the true corners on clean images and 0.3 px with σ = 5; straight lines fitted in
/// the distorted image put them farther out (measured and stated, the premise).
#[test]
fn through_a_lens_the_corners_are_fitted_on_the_pinhole_image() {
    let lens = vservo_scene::Distortion::new([-0.25, 0.08, 0.0, 0.0, 0.0]).expect("finite");
    let camera = CameraIntrinsics::with_lens([600.0, 606.0], Point2::new(322.0, 237.0), 640, 480, lens)
        .expect("valid camera");
    let board = board(ID);
    let through_lens = TagExtractor::for_camera(ID, &camera);
    let in_image = TagExtractor::new(ID, 640, 480);
    for (settings, bar) in [(clean(), 0.1), (noisy(), 0.3)] {
        let (mut sum, mut sum_in_image) = (0.0, 0.0);
        for (i, pose) in poses().iter().enumerate() {
            let image = Renderer::new(camera, settings).render(&board, pose, 7).clone();
            let mut truth = FeatureVector::zeros();
            for (k, corner) in board.marks_in_board.iter().enumerate() {
                let seen = camera.project_observed(&(pose * corner)).expect("in front");
                truth[2 * k] = seen.x;
                truth[2 * k + 1] = seen.y;
            }
            let found = through_lens.extract(&image, None);
            assert_eq!(
                found.verdict,
                TagVerdict::Found,
                "pose {i}: truth {truth}, detector {:?}",
                vservo_vision::tag::reference_detections(&image)
            );
            sum += rms_px(&found.features, &truth).powi(2);
            let straight_in_image = in_image.extract(&image, None);
            if straight_in_image.verdict == TagVerdict::Found {
                sum_in_image += rms_px(&straight_in_image.features, &truth).powi(2);
            }
        }
        let n = poses().len() as f64;
        let (rms, rms_in_image) = ((sum / n).sqrt(), (sum_in_image / n).sqrt());
        println!(
            "σ = {}: {rms:.4} px RMS on the pinhole image, {rms_in_image:.4} px fitted in the image",
            settings.noise_sigma_gray
        );
        assert!(rms <= bar, "{rms} px RMS");
        assert!(
            rms_in_image > 2.0 * rms,
            "the premise: the lens bends the edges ({rms_in_image} px in the image)"
        );
    }
}
