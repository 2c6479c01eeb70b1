//! Speed of the simulated camera and the extractor on the paper's 512 × 512 image:
//! `cargo bench -p vservo-vision`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Rotation3, Translation3, Vector3};
use vservo_scene::{Board, CameraIntrinsics, IsometryMatrix3};
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

criterion_group!(benches, vision);
criterion_main!(benches);
