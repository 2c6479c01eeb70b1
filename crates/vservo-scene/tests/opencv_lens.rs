//! The lens model against OpenCV: `cv2.projectPoints` and `cv2.undistortPointsIter` (iterated to
//! convergence) on three lenses, from `tests/data/opencv_lens.json`, written by `scripts/lens-reference.py`
//! with opencv-python-headless. And the round trip undistort(distort(p)) = p over the image.

use nalgebra::{Point2, Point3};
use proptest::prelude::*;
use serde_json::Value;
use vservo_scene::{CameraIntrinsics, Distortion};

/// Agreement with OpenCV (px): both sides compute in f64; what is left is rounding and OpenCV's own
/// stopping point.
const AGREEMENT_PX: f64 = 1e-9;

fn lenses() -> Vec<(String, CameraIntrinsics, Value)> {
    let text = include_str!("data/opencv_lens.json");
    let data: Value = serde_json::from_str(text).expect("the fixture is JSON");
    data["lenses"]
        .as_array()
        .expect("lenses")
        .iter()
        .map(|lens| {
            let number = |key: &str| lens[key].as_f64().expect(key);
            let coefficients: Vec<f64> = lens["distortion"]
                .as_array()
                .expect("distortion")
                .iter()
                .map(|v| v.as_f64().expect("k"))
                .collect();
            let camera = CameraIntrinsics::with_lens(
                [number("fx_px"), number("fy_px")],
                Point2::new(number("cx_px"), number("cy_px")),
                number("width_px") as u32,
                number("height_px") as u32,
                Distortion::new(coefficients.try_into().expect("five")).expect("finite"),
            )
            .expect("valid");
            (lens["name"].as_str().expect("name").to_string(), camera, lens.clone())
        })
        .collect()
}

fn points(value: &Value) -> Vec<Vec<f64>> {
    value
        .as_array()
        .expect("a list")
        .iter()
        .map(|p| p.as_array().expect("a point").iter().map(|v| v.as_f64().expect("a number")).collect())
        .collect()
}

#[test]
fn projection_through_the_lens_is_opencvs_project_points() {
    for (name, camera, lens) in lenses() {
        let inputs = points(&lens["points_in_camera_m"]);
        let expected = points(&lens["projected_px"]);
        assert!(inputs.len() >= 100, "{name}: the fixture has its points");
        for (point, opencv) in inputs.iter().zip(&expected) {
            let ours = camera.project_observed(&Point3::new(point[0], point[1], point[2])).expect("in front");
            let error = (ours - Point2::new(opencv[0], opencv[1])).norm();
            assert!(
                error < AGREEMENT_PX,
                "{name}: {point:?} images at {ours}, OpenCV {opencv:?} ({error:e} px)"
            );
        }
    }
}

#[test]
fn undistortion_is_opencvs_undistort_points_over_the_whole_image() {
    for (name, camera, lens) in lenses() {
        let observed = points(&lens["observed_px"]);
        let expected = points(&lens["undistorted_px"]);
        let mut worst: f64 = 0.0;
        for (pixel, opencv) in observed.iter().zip(&expected) {
            let ours = camera.pinhole_of_observed(&Point2::new(pixel[0], pixel[1])).expect("inside the lens");
            let error = (ours - Point2::new(opencv[0], opencv[1])).norm();
            worst = worst.max(error);
            assert!(
                error < AGREEMENT_PX,
                "{name}: {pixel:?} undistorts to {ours}, OpenCV {opencv:?} ({error:e} px)"
            );
        }
        println!("{name}: {} pixels, worst difference from OpenCV {worst:.1e} px", observed.len());
    }
}

/// The demo lens of config/vservo-distorted.toml.
fn demo_camera() -> CameraIntrinsics {
    CameraIntrinsics::with_lens(
        [600.0, 606.0],
        Point2::new(322.0, 237.0),
        640,
        480,
        Distortion::new([-0.25, 0.08, 0.001, -0.0005, 0.01]).expect("finite"),
    )
    .expect("valid")
}

proptest! {
    /// Any observed pixel of the image (a margin of 20 px around it too) goes to its pinhole pixel and back
    /// to within 1e-9 px.
    #[test]
    fn undistorting_then_distorting_returns_the_observed_pixel(u in -20.0f64..660.0, v in -20.0f64..500.0) {
        let camera = demo_camera();
        let observed = Point2::new(u, v);
        let pinhole = camera.pinhole_of_observed(&observed).expect("inside the lens");
        let back = camera.observed_of_pinhole(&pinhole);
        prop_assert!((back - observed).norm() < 1e-9, "{observed} → {pinhole} → {back}");
    }

    /// Any pinhole pixel whose observed one is in the image comes back from it to within 1e-9 px.
    #[test]
    fn distorting_then_undistorting_returns_the_pinhole_pixel(u in -40.0f64..680.0, v in -40.0f64..520.0) {
        let camera = demo_camera();
        let pinhole = Point2::new(u, v);
        let observed = camera.observed_of_pinhole(&pinhole);
        let back = camera.pinhole_of_observed(&observed).expect("inside the lens");
        prop_assert!((back - pinhole).norm() < 1e-9, "{pinhole} → {observed} → {back}");
    }
}

#[test]
fn without_distortion_every_mapping_is_the_pinhole_bit_for_bit() {
    let camera = CameraIntrinsics::paper();
    let point = Point3::new(0.031, -0.047, 0.52);
    assert_eq!(camera.project_observed(&point), camera.project(&point));
    let pixel = Point2::new(123.456, 78.9);
    assert_eq!(camera.pinhole_of_observed(&pixel), Some(pixel));
    assert_eq!(camera.observed_of_pinhole(&pixel), pixel);
}
