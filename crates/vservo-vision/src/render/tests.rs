//! Unit tests of `render`.

use super::lens::{footprint, supersample_between};
use super::*;
use nalgebra::{Point3, Rotation3, Translation3, Vector3};
use vservo_scene::{AprilTag, Distortion};

/// config/vservo-distorted.toml's camera.
fn lens_camera() -> CameraIntrinsics {
    let lens = Distortion::new([-0.25, 0.08, 0.0, 0.0, 0.0]).expect("finite");
    CameraIntrinsics::with_lens([600.0, 606.0], Point2::new(322.0, 237.0), 640, 480, lens).expect("valid")
}

/// Through the lens, a pixel the renderer takes as wholly one surface (without sampling it) must see
/// only that surface: checked on a 9 × 9 grid over each such pixel, its borders included, on every
/// other row, for the board in view, tilted, and half out of the image.
#[test]
fn through_a_lens_every_pixel_not_sampled_sees_one_surface() {
    let camera = lens_camera();
    let tag = AprilTag::tag36h11(3, 0.16, Point2::new(-0.01, -0.135)).expect("a tag36h11 id");
    let tag_board = Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
    let poses = [
        (Translation3::new(0.01, 0.13, 0.35), Vector3::new(0.0, 0.0, 0.0)),
        (Translation3::new(0.03, 0.10, 0.40), Vector3::new(0.25, -0.3, 0.4)),
        (Translation3::new(0.2, 0.05, 0.3), Vector3::new(-0.1, 0.2, -0.2)),
    ];
    for board in [Board::paper(), tag_board, bundle_board()] {
        every_pixel_not_sampled_sees_one_surface(&camera, &board, &poses, 10);
    }
    // a grid of 35 tags has many more edges between colours
    for board in grid_boards() {
        every_pixel_not_sampled_sees_one_surface(&camera, &board, &grid_views(), 5);
    }
}

/// config/vservo-bundle.toml's target: four 70 mm tags 20 mm apart on the paper's board.
fn bundle_board() -> Board {
    let tag = |id, x, y| AprilTag::tag36h11(id, 0.07, Point2::new(x, y)).expect("an id");
    let tags = [tag(10, -0.055, -0.09), tag(11, 0.035, -0.09), tag(12, 0.035, -0.18), tag(13, -0.055, -0.18)];
    let bundle = vservo_scene::TagBundle::new(&tags).expect("a bundle");
    Board::with_bundle(bundle, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)])
}

/// Views of the calibration grid of [`grid_boards`]: square on, tilted, rolled and from aside.
fn grid_views() -> [(Translation3<f64>, Vector3<f64>); 3] {
    [
        (Translation3::new(0.0, 0.0, 0.45), Vector3::new(0.0, 0.0, 0.0)),
        (Translation3::new(0.02, -0.03, 0.5), Vector3::new(0.35, -0.3, 0.8)),
        (Translation3::new(-0.05, 0.04, 0.42), Vector3::new(-0.2, 0.45, -0.3)),
    ]
}

/// The default calibration grid (5 × 7 tags of 28 mm, 8 mm apart) printed on a board whose target is its
/// centre tag (id 17), and the same with two of the target's corners covered.
fn grid_boards() -> [Board; 2] {
    let grid = vservo_scene::TagGrid::new(5, 7, 0.028, 0.008, 0).expect("a grid");
    let target = grid.tag_with_id(17).expect("the centre tag");
    let mut board = Board::with_apriltag(target, grid.extent_in_board());
    board.calibration_grid = Some(grid);
    let mut covered = Board::with_apriltag(target.with_corners_covered(0b0101), grid.extent_in_board());
    covered.calibration_grid = Some(grid);
    [board, covered]
}

/// Through a pinhole (the grid boards, and a bundle), a pixel the tags' judgement gives one gray sees that surface at every point, and the
/// black share it gives a pixel where cells of both colours meet equals a 64 × 64 sampling of the pixel.
#[test]
fn through_a_pinhole_every_pixel_of_the_grid_not_sampled_sees_one_surface() {
    let camera =
        CameraIntrinsics::with_lens([600.0, 606.0], Point2::new(322.0, 237.0), 640, 480, Distortion::NONE)
            .expect("valid");
    // the bundle's views: its centre on the optical axis, as the grid's, tilted only: square on, its edges lie
    // along the pixels', where the 64 × 64 sampling's own error averages a quarter of its step (measured: 0.0038
    // on the grid's square view, against 0.0003 tilted), the bound of `Shares::check`
    let bundle_views: Vec<_> = grid_views()[1..]
        .iter()
        .map(|(t, r)| (Translation3::new(t.x + 0.01, t.y + 0.135, t.z), *r))
        .collect();
    let views = grid_boards()
        .map(|board| (board, grid_views().to_vec()))
        .into_iter()
        .chain([(bundle_board(), bundle_views)]);
    for (board, views) in views {
        for (translation, rotation) in views {
            let pose = IsometryMatrix3::from_parts(translation, Rotation3::from_scaled_axis(rotation));
            let scene = Scene::new(&camera, &board, &pose);
            let (mut whole, mut covered, mut sampled) = (0usize, Shares::default(), 0usize);
            for v in (0..480i64).step_by(3) {
                for u in 0..640i64 {
                    let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                        .map(|(du, dv)| scene.on_board(u as f64 + du, v as f64 + dv));
                    let Some(points) = corners.iter().copied().collect::<Option<Vec<_>>>() else { continue };
                    let points: [Point2<f64>; 4] = points.try_into().expect("four");
                    match printed_footprint(scene.board, &points, 0.0) {
                        Printed::Tags(Footprint::Whole(surface)) => {
                            whole += 1;
                            for j in 0..=8 {
                                for i in 0..=8 {
                                    let (x, y) =
                                        (u as f64 + f64::from(i) / 8.0, v as f64 + f64::from(j) / 8.0);
                                    let seen = scene.surface(x, y);
                                    // the board's outline is judged before the tags, on the whole row
                                    assert!(
                                        seen == surface || seen == Surface::Background,
                                        "pixel ({u}, {v}) taken as one surface, but ({x}, {y}) sees another"
                                    );
                                }
                            }
                        }
                        Printed::Tags(Footprint::Covered(share)) => {
                            let pixel = (u as f64, v as f64);
                            if let Some(sampled) = sampled_black_share(|x, y| scene.surface(x, y), pixel) {
                                covered.add(u, v, share, sampled);
                            }
                        }
                        _ => sampled += 1,
                    }
                }
            }
            covered.check();
            assert!(whole > 10 * (covered.count + sampled), "{whole} whole, {covered:?}, {sampled} sampled");
            // the edges between cells are computed, not sampled
            assert!(covered.count > 20 * sampled, "{covered:?}, {sampled} sampled");
        }
    }
}

/// The black share of the pixel whose top left corner is `(u, v)`, from 64 × 64 points of it; `None` when one
/// sees the background (the board's outline is judged before the tags).
fn sampled_black_share(surface: impl Fn(f64, f64) -> Surface, (u, v): (f64, f64)) -> Option<f64> {
    let mut black = 0usize;
    for j in 0..64 {
        for i in 0..64 {
            match surface(u + (f64::from(i) + 0.5) / 64.0, v + (f64::from(j) + 0.5) / 64.0) {
                Surface::Background => return None,
                Surface::Mark => black += 1,
                Surface::Board => {}
            }
        }
    }
    Some(black as f64 / 4096.0)
}

/// The black shares the tags' judgement computed against those sampled.
#[derive(Debug, Default)]
struct Shares {
    count: usize,
    sum_of_differences: f64,
}

impl Shares {
    fn add(&mut self, u: i64, v: i64, computed: f64, sampled: f64) {
        let difference = (computed - sampled).abs();
        // a 64 × 64 sampling is off by a row or column of points per edge crossing the pixel, a corner two
        assert!(difference <= 2.0 / 64.0 + 1e-9, "pixel ({u}, {v}): {computed} computed, {sampled} sampled");
        self.count += 1;
        self.sum_of_differences += difference;
    }

    fn check(&self) {
        assert!(self.count > 100, "{self:?}");
        // on average far below a sampling step: the computed share is not a coarser sampling
        let mean = self.sum_of_differences / self.count as f64;
        assert!(mean < 0.25 / 64.0, "mean difference {mean} ({self:?})");
    }
}

fn every_pixel_not_sampled_sees_one_surface(
    camera: &CameraIntrinsics,
    board: &Board,
    poses: &[(Translation3<f64>, Vector3<f64>)],
    whole_per_sampled: usize,
) {
    let corners = pinhole_corners(camera);
    for &(translation, rotation) in poses {
        let pose = IsometryMatrix3::from_parts(translation, Rotation3::from_scaled_axis(rotation));
        let scene = Scene::new(camera, board, &pose);
        let (mut whole, mut covered, mut sampled) = (0usize, Shares::default(), 0usize);
        for v in (0..480usize).step_by(2) {
            for u in 0..640usize {
                let top = v * 641;
                let corner_at = |i: usize| scene.on_board(corners[i].x, corners[i].y);
                let judged = footprint(
                    &scene,
                    [top + u, top + u + 1, top + 641 + u + 1, top + 641 + u].map(corner_at),
                );
                let surface = match judged {
                    Footprint::Whole(surface) => surface,
                    Footprint::Covered(share) => {
                        let pinhole =
                            [top + u, top + u + 1, top + 641 + u + 1, top + 641 + u].map(|i| corners[i]);
                        let black = |surface| if surface == Surface::Mark { 1.0 } else { 0.0 };
                        let pixel = (u as f64, v as f64);
                        covered.add(
                            u as i64,
                            v as i64,
                            share,
                            supersample_between(&scene, pixel, &pinhole, 64, &black).into(),
                        );
                        continue;
                    }
                    Footprint::NearMark | Footprint::NearOutline => {
                        sampled += 1;
                        continue;
                    }
                };
                whole += 1;
                for j in 0..=8 {
                    for i in 0..=8 {
                        let (x, y) = (u as f64 + f64::from(i) / 8.0, v as f64 + f64::from(j) / 8.0);
                        assert!(
                            scene.surface(x, y) == surface,
                            "pixel ({u}, {v}) taken as one surface, but ({x}, {y}) sees another (pose {translation:?})"
                        );
                    }
                }
            }
        }
        if board.target_is_tags() {
            covered.check();
        }
        // the judgement spares most pixels the sampling
        assert!(
            whole > whole_per_sampled * (covered.count + sampled),
            "{whole} pixels judged whole, {covered:?}, {sampled} sampled"
        );
    }
}

/// A pixel near an edge is sampled at points whose pinhole points are bilinear between its corners'; the
/// lens's own inverse at every sample gives the same gray but where a sample lies within the bend (under
/// 1e-3 px) of an edge: checked on every sampled pixel of a frame with the tag and of one with the marks.
#[test]
fn through_a_lens_sampling_between_the_corners_agrees_with_the_lens_inverse() {
    let camera = lens_camera();
    let tag = AprilTag::tag36h11(3, 0.16, Point2::new(-0.01, -0.135)).expect("a tag36h11 id");
    let tag_board = Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
    let corners = pinhole_corners(&camera);
    let pose = IsometryMatrix3::from_parts(
        Translation3::new(0.03, 0.10, 0.40),
        Rotation3::from_scaled_axis(Vector3::new(0.25, -0.3, 0.4)),
    );
    let gray = |surface: Surface| match surface {
        Surface::Background => 40.0,
        Surface::Board => 230.0,
        Surface::Mark => 20.0,
    };
    for board in [Board::paper(), tag_board, bundle_board()] {
        let scene = Scene::new(&camera, &board, &pose);
        let (mut sampled, mut differing) = (0usize, 0usize);
        for v in 0..480usize {
            for u in 0..640usize {
                let top = v * 641;
                let pinhole = [top + u, top + u + 1, top + 641 + u + 1, top + 641 + u].map(|i| corners[i]);
                if let Footprint::Whole(_) = footprint(&scene, pinhole.map(|p| scene.on_board(p.x, p.y))) {
                    continue;
                }
                sampled += 1;
                let between = supersample_between(&scene, (u as f64, v as f64), &pinhole, 4, &gray);
                let mut exact = 0.0;
                for j in 0..4 {
                    for i in 0..4 {
                        let (x, y) =
                            (u as f64 + (f64::from(i) + 0.5) / 4.0, v as f64 + (f64::from(j) + 0.5) / 4.0);
                        exact += gray(scene.surface(x, y)) / 16.0;
                    }
                }
                let difference = (f64::from(between) - exact).abs();
                // one sample of 16 changing surface at most
                assert!(difference <= 210.0 / 16.0 + 1e-3, "pixel ({u}, {v}): {between} vs {exact}");
                if difference > 1e-3 {
                    differing += 1;
                }
            }
        }
        assert!(sampled > 1000, "{sampled} pixels sampled");
        assert!(differing * 1000 < sampled, "{differing} of {sampled} sampled pixels differ");
    }
}

/// Each mark's dark area is centred where the lens images its centre (within 0.3 px: a disc's image
/// centroid is not exactly its centre's image), 2 px and more from where a pinhole would.
#[test]
fn through_a_lens_the_marks_are_drawn_where_the_lens_images_them() {
    let camera = lens_camera();
    let board = Board::paper();
    let pose = IsometryMatrix3::from_parts(Translation3::new(0.01, 0.13, 0.35), Rotation3::identity());
    let mut renderer = Renderer::new(camera, RenderSettings::default());
    let image = renderer.render(&board, &pose, 0).clone();
    for mark in &board.marks_in_board {
        let in_camera = pose * Point3::new(mark.x, mark.y, 0.0);
        let observed = camera.project_observed(&in_camera).expect("in front");
        let pinhole = camera.project(&in_camera).expect("in front");
        // the darkness-weighted centroid of a 40 × 40 px window around it (board 230, mark 20)
        let (mut weight, mut sum_x, mut sum_y) = (0.0, 0.0, 0.0);
        for v in (observed.y as i64 - 20)..(observed.y as i64 + 20) {
            for u in (observed.x as i64 - 20)..(observed.x as i64 + 20) {
                let darkness = (230.0 - f64::from(image.get_pixel(u as u32, v as u32)[0])).max(0.0);
                weight += darkness;
                sum_x += darkness * (u as f64 + 0.5);
                sum_y += darkness * (v as f64 + 0.5);
            }
        }
        let drawn = Point2::new(sum_x / weight, sum_y / weight);
        assert!((drawn - observed).norm() < 0.3, "mark drawn at {drawn}, the lens images it at {observed}");
        assert!((observed - pinhole).norm() > 2.0, "the lens moves the mark ({observed} vs {pinhole})");
    }
}

/// An exposure of one pose, or of several that do not move, is the instant's image bit for bit; a board that
/// moves along x during it is smeared along x: each image column is the mean of the instants' columns (no
/// noise, no light), and a row across the motion is wider in gray.
#[test]
fn an_exposure_averages_the_instants_and_a_still_one_is_the_instant() {
    let camera = CameraIntrinsics::paper();
    let settings = RenderSettings { noise_sigma_gray: 2.0, exposure_s: 0.02, ..Default::default() };
    let pose = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Rotation3::identity());
    let instant = Renderer::new(camera, settings).render(&Board::paper(), &pose, 3).clone();
    let mut renderer = Renderer::new(camera, settings);
    assert_eq!(renderer.render_exposure(&Board::paper(), &[pose], 3), &instant);
    assert_eq!(renderer.render_exposure(&Board::paper(), &[pose; 4], 3), &instant);

    let clean = RenderSettings { exposure_s: 0.02, lighting_gradient: [0.0, 0.0], ..Default::default() };
    let shifted =
        |dx: f64| IsometryMatrix3::from_parts(Translation3::new(dx, 0.0, 0.5), Rotation3::identity());
    // the paper's camera: 3 mm at 0.5 m is a few pixels
    let instants: Vec<_> = (0..4).map(|k| shifted(0.001 * k as f64)).collect();
    let mut blurred = Renderer::new(camera, clean);
    let image = blurred.render_exposure(&Board::paper(), &instants, 0).clone();
    let singles: Vec<_> =
        instants.iter().map(|p| Renderer::new(camera, clean).render(&Board::paper(), p, 0).clone()).collect();
    let mut edges_blurred = 0;
    for (index, pixel) in image.as_raw().iter().enumerate() {
        let mean = singles.iter().map(|s| f64::from(s.as_raw()[index])).sum::<f64>() / 4.0;
        // each instant's pixel is rounded once, the mean of the albedos once: within a level
        assert!((f64::from(*pixel) - mean).abs() <= 1.0, "pixel {index}: {pixel} against a mean of {mean}");
        let gray = |s: &GrayImage| s.as_raw()[index];
        if singles.iter().all(|s| gray(s) == gray(&singles[0])) {
            assert_eq!(*pixel, gray(&singles[0]), "a pixel the motion does not change stays");
        } else {
            edges_blurred += 1;
        }
    }
    assert!(edges_blurred > 100, "the marks' edges are smeared ({edges_blurred} pixels)");
}
