//! The cell through a distorting lens (config/vservo-distorted.toml: 640 × 480, k1 = −0.25, k2 = 0.08, the
//! robust law): the simulated camera renders through the lens, the vision stage undistorts the marks, and the
//! servo converges below 1 px of the true (pinhole) features. The same cell with `vision.undistort = false`
//! (the comparison's switch only) puts the lens's error into the law: it settles where the *observed* marks
//! are at ξ_d, pixels away from the true target. The same for an AprilTag target (config/vservo-apriltag.toml).

use vservo_config::Config;
use vservo_lockstep::summary::summarize;
use vservo_lockstep::{Lockstep, Trace};

fn distorted() -> Config {
    Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-distorted.toml"))
        .expect("config/vservo-distorted.toml is valid")
}

fn run(config: &Config) -> Trace {
    let trace = Lockstep::new(config).expect("reachable").run(|_| {});
    assert!(!trace.faults.any_limit(), "{:?}", trace.faults);
    trace
}

/// The largest distance (px) between where the extractor found a mark (in the distorted image) and its true
/// pinhole pixel, in the last frame: what the lens does to the marks at the target.
fn lens_displacement_px(trace: &Trace) -> f64 {
    let last = trace.frames.last().expect("frames");
    (0..4)
        .map(|m| {
            let dx = last.measured[2 * m] - last.truth[2 * m];
            let dy = last.measured[2 * m + 1] - last.truth[2 * m + 1];
            dx.hypot(dy)
        })
        .fold(0.0, f64::max)
}

#[test]
fn through_the_lens_the_servo_converges_below_one_pixel_and_without_undistortion_it_does_not() {
    let mut config = distorted();
    config.cell.scenario.duration_s = 8.0;
    let trace = run(&config);
    let summary = summarize(&trace, &config.cell.scenario.object);
    let displacement = lens_displacement_px(&trace);
    println!(
        "undistorted features: final error {:.3} px, settling {:?} s; the lens moves the marks by up to {displacement:.2} px",
        summary.final_error_px, summary.settling_time_s
    );
    assert!(summary.final_error_px < 1.0, "{summary:?}");
    assert!(displacement > 2.0, "the test's premise: the lens moves the marks by pixels ({displacement} px)");

    config.cell.vision.undistort = false;
    let ignored = summarize(&run(&config), &config.cell.scenario.object);
    println!(
        "features left distorted: final error {:.3} px ({:.1}× the undistorted run's)",
        ignored.final_error_px,
        ignored.final_error_px / summary.final_error_px
    );
    assert!(ignored.final_error_px > 2.0, "{ignored:?}");
    assert!(ignored.final_error_px > 5.0 * summary.final_error_px, "{ignored:?} against {summary:?}");
}

/// The bench's target through the same lens (config/vservo-apriltag.toml: a tag36h11 tag's corners, found by
/// the AprilTag detector in the distorted image, then undistorted): converges below 1 px of the true pinhole
/// corners; with the corners left distorted the servo settles where the lens shows them at ξ_d, the lens's
/// displacement of the corners away from the truth.
#[test]
fn an_apriltag_through_the_lens_converges_below_one_pixel_and_without_undistortion_does_worse() {
    let mut config = Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-apriltag.toml"))
        .expect("config/vservo-apriltag.toml is valid");
    assert!(
        config.cell.board.apriltag().is_some() && !config.cell.camera.distortion().is_none(),
        "the premise"
    );
    config.cell.scenario.duration_s = 8.0;
    let trace = run(&config);
    let summary = summarize(&trace, &config.cell.scenario.object);
    let displacement = lens_displacement_px(&trace);
    println!(
        "tag corners undistorted: final error {:.3} px, settling {:?} s; the lens moves the corners by up to {displacement:.2} px",
        summary.final_error_px, summary.settling_time_s
    );
    assert!(summary.final_error_px < 1.0, "{summary:?}");
    assert!(
        displacement > 1.0,
        "the test's premise: the lens moves the corners by pixels ({displacement} px)"
    );

    config.cell.vision.undistort = false;
    let ignored = summarize(&run(&config), &config.cell.scenario.object);
    println!(
        "tag corners left distorted: final error {:.3} px ({:.1}× the undistorted run's)",
        ignored.final_error_px,
        ignored.final_error_px / summary.final_error_px
    );
    assert!(
        ignored.final_error_px > 0.5 * displacement,
        "{ignored:?}: the lens moves the corners {displacement} px"
    );
    assert!(ignored.final_error_px > 2.0 * summary.final_error_px, "{ignored:?} against {summary:?}");
}

/// A scenario's occlusion on an AprilTag target covers a corner of the tag (3 × 3 of its cells turn white):
/// the tag is no longer found, so all four corners are missing and the robust law steers back to where the
/// tag was last seen (never frozen, never on wrong corners); uncovered, it converges below 1 px again.
#[test]
fn a_covered_tag_corner_loses_the_tag_and_the_servo_converges_again_once_uncovered() {
    use vservo_cell::ServoVerdict;
    use vservo_config::Occlusion;
    let mut config = Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-apriltag.toml"))
        .expect("config/vservo-apriltag.toml is valid");
    config.cell.scenario.duration_s = 4.0;
    config.cell.scenario.occlusions[0] = Some(Occlusion { mark: 1, from_s: 1.5, until_s: 2.0 });
    let trace = run(&config);
    let during: Vec<_> = trace
        .frames
        .iter()
        .filter(|f| f.t_s > 1.6 && f.t_s < 1.95)
        .map(|f| (f.verdict, f.measured.iter().all(|v| v.is_nan())))
        .collect();
    assert!(!during.is_empty());
    for (verdict, none_measured) in &during {
        assert!(none_measured, "a covered tag gives no corners: {during:?}");
        assert!(matches!(verdict, Some(ServoVerdict::Reacquiring(0b1111))), "{during:?}");
    }
    let summary = summarize(&trace, &config.cell.scenario.object);
    println!("a tag corner covered 1.5–2.0 s: final error {:.3} px", summary.final_error_px);
    assert!(summary.final_error_px < 1.0, "{summary:?}");
}

/// The same tag through the lens, seen by a camera whose shutter stays open 30 ms (the board's motion over it
/// blurs the image: `vision.render.exposure_s`) with pixel noise of σ = 4 gray levels: the detector finds the
/// tag in the blurred frames and the servo converges below 1 px.
#[test]
fn an_apriltag_through_the_lens_blurred_by_the_motion_and_noisy_converges_below_one_pixel() {
    let mut config = Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-apriltag.toml"))
        .expect("config/vservo-apriltag.toml is valid");
    config.cell.scenario.duration_s = 8.0;
    config.cell.vision.render.exposure_s = 0.03;
    config.cell.vision.render.noise_sigma_gray = 4.0;
    let trace = run(&config);
    let summary = summarize(&trace, &config.cell.scenario.object);
    let blur_px: Vec<f64> = trace.frames.iter().map(|f| f.motion_blur_px).collect();
    let largest = blur_px.iter().copied().fold(0.0, f64::max);
    let blurred = blur_px.iter().filter(|&&b| b >= 1.0).count();
    let lost = trace.frames.iter().filter(|f| f.measured.iter().any(|v| v.is_nan())).count();
    println!(
        "motion blur up to {largest:.2} px ({blurred} of {} frames blurred by a pixel or more), {lost} frames \
         without the tag; final error {:.3} px, settling {:?} s",
        blur_px.len(),
        summary.final_error_px,
        summary.settling_time_s
    );
    assert!(largest > 3.0 && blurred >= 3, "the test's premise: frames blurred by pixels ({largest} px)");
    assert_eq!(lost, 0, "the tag is found in every frame, blurred or not");
    assert!(summary.final_error_px < 1.0, "{summary:?}");
}
