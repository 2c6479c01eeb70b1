//! Speed of the simulated camera and the extractor on the paper's 512 × 512 image:
//! `cargo bench -p vservo-vision`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point2, Rotation3, Translation3, Vector3};
use vservo_scene::{AprilTag, Board, CameraIntrinsics, Distortion, IsometryMatrix3, TagGrid};
use vservo_vision::{Extractor, ExtractorSettings, Prediction, RenderSettings, Renderer};

fn vision(c: &mut Criterion) {
    let camera = CameraIntrinsics::paper();
    let board = Board::paper();
    // a little off the desired pose, tilted, so that marks are ellipses
    let pose = IsometryMatrix3::from_parts(
        Translation3::new(0.01, -0.02, 0.52),
        Rotation3::from_scaled_axis(Vector3::new(0.1, -0.15, 0.05)),
    );
    let desired = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Rotation3::identity());
    let xi_d = camera.project_marks(&board, &desired).expect("in front");
    for (name, sigma, gradient) in
        [("render_clean", 0.0, [0.0, 0.0]), ("render_noise_gradient", 2.0, [0.1, -0.05])]
    {
        let settings =
            RenderSettings { noise_sigma_gray: sigma, lighting_gradient: gradient, ..Default::default() };
        let mut renderer = Renderer::new(camera, settings);
        let mut frame = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                frame += 1;
                renderer.render(black_box(&board), black_box(&pose), frame).as_raw().len()
            })
        });
    }
    render_through_a_lens(c, &board);
    let settings =
        RenderSettings { noise_sigma_gray: 2.0, lighting_gradient: [0.1, -0.05], ..Default::default() };
    let mut renderer = Renderer::new(camera, settings);
    let image = renderer.render(&board, &pose, 1).clone();
    let mut extractor = Extractor::new(ExtractorSettings::default(), 512, 512);
    let tracking = Prediction::Tracking(extractor.extract(&image, &Prediction::Layout(xi_d)).features);
    c.bench_function("extract_tracking", |b| b.iter(|| extractor.extract(black_box(&image), &tracking)));
    let layout = Prediction::Layout(xi_d);
    c.bench_function("extract_layout", |b| b.iter(|| extractor.extract(black_box(&image), &layout)));
}

/// config/vservo-distorted.toml's camera (640 × 480, k1 = −0.25, k2 = 0.08) near its desired view, and the
/// same camera without distortion.
fn render_through_a_lens(c: &mut Criterion, board: &Board) {
    let pose = IsometryMatrix3::from_parts(
        Translation3::new(0.02, 0.11, 0.37),
        Rotation3::from_scaled_axis(Vector3::new(0.1, -0.15, 0.05)),
    );
    let settings =
        RenderSettings { noise_sigma_gray: 1.0, lighting_gradient: [0.1, -0.05], ..Default::default() };
    for (name, distortion) in
        [("render_640x480_pinhole", [0.0; 5]), ("render_640x480_lens", [-0.25, 0.08, 0.0, 0.0, 0.0])]
    {
        let lens = Distortion::new(distortion).expect("finite");
        let camera = CameraIntrinsics::with_lens([600.0, 606.0], Point2::new(322.0, 237.0), 640, 480, lens)
            .expect("valid");
        let mut renderer = Renderer::new(camera, settings);
        let mut frame = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                frame += 1;
                renderer.render(black_box(board), black_box(&pose), frame).as_raw().len()
            })
        });
    }
    // config/vservo-apriltag.toml's tag through the same lens
    let tag = AprilTag::tag36h11(3, 0.16, Point2::new(-0.01, -0.135)).expect("a tag36h11 id");
    let tag_board = Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
    let lens = Distortion::new([-0.25, 0.08, 0.0, 0.0, 0.0]).expect("finite");
    let camera = CameraIntrinsics::with_lens([600.0, 606.0], Point2::new(322.0, 237.0), 640, 480, lens)
        .expect("valid");
    let mut renderer = Renderer::new(camera, settings);
    let mut frame = 0;
    c.bench_function("render_640x480_lens_apriltag", |b| {
        b.iter(|| {
            frame += 1;
            renderer.render(black_box(&tag_board), black_box(&pose), frame).as_raw().len()
        })
    });
    // config/calibration-demo.toml's calibration board (`vservoctl board`'s 5 × 7 grid of 28 mm tags) 0.3 m
    // away, tilted, through the same lens
    let grid = TagGrid::new(7, 5, 0.028, 0.008, 0).expect("a grid");
    let target = grid.tag(17).expect("tag 17");
    let [low, high] = grid.tags_extent_in_board();
    let margin = Vector3::new(0.02, 0.02, 0.0).xy();
    let mut grid_board = Board::with_apriltag(target, [low - margin, high + margin]);
    grid_board.calibration_grid = Some(grid);
    let grid_pose = IsometryMatrix3::from_parts(
        Translation3::new(0.01, -0.01, 0.3),
        Rotation3::from_scaled_axis(Vector3::new(0.25, -0.2, 0.3)),
    );
    c.bench_function("render_640x480_lens_calibration_grid", |b| {
        b.iter(|| {
            frame += 1;
            renderer.render(black_box(&grid_board), black_box(&grid_pose), frame).as_raw().len()
        })
    });
}

criterion_group!(benches, vision);
criterion_main!(benches);
