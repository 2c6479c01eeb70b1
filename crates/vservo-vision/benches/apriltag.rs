//! Speed of the AprilTag extractor (detection + sub-pixel refinement) against the reference C detector alone
//! on the same images: one tag36h11 tag about 200 px wide at 640 × 480 (400 px at 1280 × 1024), clean and
//! with Gaussian noise of σ = 5 gray levels; the extractor on the whole image and with the previous frame's
//! detection; the C detector with its quads searched at full resolution (what the extractor falls back to when
//! the decimated search misses its tag), and `detect_tags` (every tag, full resolution, refined) on the real
//! photographs of scripts/setup-tag-photos.sh when they are there. `cargo bench -p vservo-vision --bench
//! apriltag` (docs/BENCHMARKS.md).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point2, Rotation3, Translation3, Vector3};
use vservo_scene::{AprilTag, Board, CameraIntrinsics, IsometryMatrix3};
use vservo_vision::tag::{detect_tags, reference_detections, reference_detections_full_resolution};
use vservo_vision::tag_refine::Straight;
use vservo_vision::{RenderSettings, Renderer, TagExtractor, TagVerdict};

fn apriltag(c: &mut Criterion) {
    let tag = AprilTag::tag36h11(3, 0.16, Point2::new(-0.01, -0.135)).expect("a tag36h11 id");
    let board = Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
    // 0.4 m away, a little tilted and rolled
    let pose = IsometryMatrix3::from_parts(
        Translation3::new(0.02, 0.15, 0.4),
        Rotation3::from_scaled_axis(Vector3::new(0.1, -0.15, 0.3)),
    );
    let mut group = c.benchmark_group("apriltag");
    group.sample_size(30).measurement_time(std::time::Duration::from_secs(3));
    for (width, height) in [(640u32, 480u32), (1280, 1024)] {
        let focal = 500.0 * f64::from(width) / 640.0;
        let centre = Point2::new(f64::from(width) / 2.0, f64::from(height) / 2.0);
        let camera = CameraIntrinsics::new(focal, centre, width, height).expect("valid camera");
        for (noise, sigma) in [("clean", 0.0), ("sigma5", 5.0)] {
            let settings = RenderSettings {
                noise_sigma_gray: sigma,
                lighting_gradient: [0.0, 0.0],
                ..Default::default()
            };
            let image = Renderer::new(camera, settings).render(&board, &pose, 1).clone();
            let extractor = TagExtractor::new(3, width, height);
            let first = extractor.extract(&image, None);
            assert_eq!(first.verdict, TagVerdict::Found, "{width}x{height} {noise}");
            let name = format!("{width}x{height}_{noise}");
            group.bench_function(format!("extract_full_{name}"), |b| {
                b.iter(|| extractor.extract(black_box(&image), None))
            });
            group.bench_function(format!("extract_previous_{name}"), |b| {
                b.iter(|| extractor.extract(black_box(&image), Some(&first.features)))
            });
            group.bench_function(format!("c_detector_full_{name}"), |b| {
                b.iter(|| reference_detections(black_box(&image)).len())
            });
            group.bench_function(format!("c_detector_full_resolution_{name}"), |b| {
                b.iter(|| reference_detections_full_resolution(black_box(&image)).len())
            });
        }
    }
    group.finish();
    acquisition_and_bundle(c);
    real_photographs(c);
}

/// With nothing to track, at 1280 × 1024 with noise of σ = 5: a tag of about 16 px, which the decimated search
/// misses, acquired by the scan (each frame the decimated whole image and one scan tile at full resolution:
/// `vservo_vision::scan`; the mean over the tiles); and config/vservo-bundle.toml's bundle of four tags at
/// 640 × 480, from scratch and tracked.
fn acquisition_and_bundle(c: &mut Criterion) {
    let mut group = c.benchmark_group("apriltag_acquisition");
    group.sample_size(30).measurement_time(std::time::Duration::from_secs(3));
    let noisy = RenderSettings { noise_sigma_gray: 5.0, lighting_gradient: [0.0, 0.0], ..Default::default() };
    let camera = CameraIntrinsics::new(1000.0, Point2::new(640.0, 512.0), 1280, 1024).expect("valid camera");
    let far = IsometryMatrix3::from_parts(Translation3::new(0.21, -0.17, 1.0), Rotation3::identity());
    // the largest tag (10–30 mm at 1 m: 10–30 px) that the decimated search misses and the full-resolution one finds
    let render_small = |size_m: f64| {
        let small = AprilTag::tag36h11(3, size_m, Point2::new(0.0, 0.0)).expect("a tag36h11 id");
        let board = Board::with_apriltag(small, small.sheet_extent_in_board());
        Renderer::new(camera, noisy).render(&board, &far, 1).clone()
    };
    let (size_mm, image) = (10..=30)
        .rev()
        .map(|size_mm| (size_mm, render_small(f64::from(size_mm) / 1000.0)))
        .find(|(_, image)| {
            reference_detections(image).is_empty() && !reference_detections_full_resolution(image).is_empty()
        })
        .expect("the premise: a tag the decimated search misses and the full-resolution one finds");
    println!("a tag of {size_mm} px, missed by the decimated search");
    let extractor = TagExtractor::new(3, 1280, 1024);
    let tiles = vservo_vision::scan::scan_tiles(1280, 1024).count();
    let acquired =
        (0..tiles).map(|_| extractor.extract(&image, None)).find(|a| a.verdict == TagVerdict::Found);
    assert!(acquired.is_some(), "the scan acquires it within {tiles} frames");
    group.bench_function("scan_frame_1280x1024_sigma5", |b| {
        b.iter(|| extractor.extract(black_box(&image), None))
    });

    let tag = |id, x, y| AprilTag::tag36h11(id, 0.07, Point2::new(x, y)).expect("an id");
    let tags = [tag(10, -0.055, -0.09), tag(11, 0.035, -0.09), tag(12, 0.035, -0.18), tag(13, -0.055, -0.18)];
    let bundle = vservo_scene::TagBundle::new(&tags).expect("a bundle");
    let board = Board::with_bundle(bundle, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
    let camera = CameraIntrinsics::new(500.0, Point2::new(320.0, 240.0), 640, 480).expect("valid camera");
    let pose = IsometryMatrix3::from_parts(
        Translation3::new(0.02, 0.15, 0.45),
        Rotation3::from_scaled_axis(Vector3::new(0.1, -0.15, 0.3)),
    );
    let image = Renderer::new(camera, noisy).render(&board, &pose, 1).clone();
    let extractor = TagExtractor::for_board(&board, &camera).expect("a bundle's extractor");
    let first = extractor.extract(&image, None);
    assert_eq!(first.verdict, TagVerdict::Found);
    group.bench_function("bundle_full_640x480_sigma5", |b| {
        b.iter(|| extractor.extract(black_box(&image), None))
    });
    group.bench_function("bundle_previous_640x480_sigma5", |b| {
        b.iter(|| extractor.extract(black_box(&image), Some(&first.features)))
    });
    group.finish();
}

/// Every tag of each real photograph (799 × 533, 10–25 tags of 12–45 px), as `vservoctl tags` finds them.
fn real_photographs(c: &mut Criterion) {
    let folder = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/tag-photos");
    let Ok(entries) = std::fs::read_dir(&folder) else { return };
    let mut photos: Vec<_> =
        entries.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|e| e == "jpg")).collect();
    photos.sort();
    let mut group = c.benchmark_group("apriltag_photographs");
    group.sample_size(20).measurement_time(std::time::Duration::from_secs(3));
    for path in photos {
        let (image, _) = vservo_vision::source::read_image_as_gray(&path).expect("a photograph");
        let name = path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
        group.bench_function(format!("detect_tags_{name}"), |b| {
            b.iter(|| detect_tags(black_box(&image), Straight::InImage).len())
        });
    }
    group.finish();
}

criterion_group!(benches, apriltag);
criterion_main!(benches);
