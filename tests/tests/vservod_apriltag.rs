//! The bench's target through a real lens in real time (config/vservo-apriltag.toml: a tag36h11 tag, a
//! 640 × 480 camera with k1 = −0.25, k2 = 0.08, the robust law): the simulated camera renders the tag through
//! the lens on the camera's clock, the vision node finds its corners with the AprilTag detector and
//! undistorts them, and the servo converges below 1 px. The calibration demo (a grid of 35 tags) does too, its
//! camera rendering every frame within its period.

use std::time::Duration;

use serde_json::Value;
use vservo_protocol::Verdict;
use vservo_system_tests::{
    ScratchDir, echo_lines, exclusive, numbers, run, running, running_daemon_of, running_daemon_with, status,
    unique, wait_until,
};

#[test]
fn an_apriltag_through_a_lens_converges_below_one_pixel_in_real_time() {
    let _one = exclusive();
    let instance = unique("apriltag");
    let (_config, daemon) = running_daemon_of("config/vservo-apriltag.toml", &instance);
    let twists = echo_lines(&instance, "camera_twist", "8");
    let errors: Vec<f64> = twists.iter().filter_map(|t| t["feature_error_px"].as_f64()).collect();
    // the tag was found in every frame: no corner was ever missing
    let (servoing, waiting) = (u64::from(Verdict::Servoing.code()), u64::from(Verdict::Waiting.code()));
    let verdicts: Vec<u64> = twists.iter().filter_map(|t| t["verdict"].as_u64()).collect();
    assert!(verdicts.len() > 40, "{} twists in 8 s\n{}", verdicts.len(), daemon.log());
    assert!(verdicts.iter().all(|&v| v == servoing || v == waiting), "{verdicts:?}\n{}", daemon.log());
    assert_eq!(verdicts.last(), Some(&servoing), "{verdicts:?}");
    let last = errors.last().copied().unwrap_or(f64::NAN);
    println!("feature error: first {:?} px, last {last:.3} px", errors.first());
    assert!(last < 1.0, "feature error at the end {last} px: {errors:?}\n{}", daemon.log());
    assert!(running(&status(&instance).expect("status")), "{}", daemon.log());
    the_features_say_how_each_corner_was_measured(&instance);
    the_snapshot_outlines_the_target_where_the_vision_node_found_it(&instance);
    daemon.stop();
}

/// At the target, each of the tag's corners is refined on its two edges, which fitted well; the decoder was sure.
fn the_features_say_how_each_corner_was_measured(instance: &str) {
    let features = echo_lines(instance, "features", "0.5");
    let last = features.last().expect("features");
    println!(
        "refined_mask {}, edge_rms_px {}, decision_margin {}, bits_corrected {}",
        last["refined_mask"], last["edge_rms_px"], last["decision_margin"], last["bits_corrected"]
    );
    assert_eq!(last["refined_mask"], 0b1111, "{last}");
    let edges = numbers(&last["edge_rms_px"]);
    assert!(edges.len() == 4 && edges.iter().all(|rms| (0.0..0.35).contains(rms)), "{last}");
    assert!(last["decision_margin"].as_f64().is_some_and(|m| m > 20.0), "{last}");
    assert_eq!(last["bits_corrected"], 0, "{last}");
}

/// The same cell with a camera whose shutter stays open 30 ms (the board's motion over it blurs each frame,
/// `vision.render.exposure_s`; up to 17 px at the start, docs/VISION.md) and pixel noise of σ = 4: the tag is
/// found in every frame and the servo converges below 1 px.
#[test]
fn an_apriltag_through_a_lens_blurred_by_the_motion_and_noisy_converges_below_one_pixel_in_real_time() {
    let _one = exclusive();
    let instance = unique("apriltag-blur");
    let blurred =
        [("exposure_s = 0.0", "exposure_s = 0.03"), ("noise_sigma_gray = 1.0", "noise_sigma_gray = 4.0")];
    let (_config, daemon) = running_daemon_with("config/vservo-apriltag.toml", &instance, &blurred);
    let twists = echo_lines(&instance, "camera_twist", "8");
    let verdicts: Vec<u64> = twists.iter().filter_map(|t| t["verdict"].as_u64()).collect();
    let (servoing, waiting) = (u64::from(Verdict::Servoing.code()), u64::from(Verdict::Waiting.code()));
    assert!(verdicts.len() > 40, "{} twists in 8 s\n{}", verdicts.len(), daemon.log());
    assert!(verdicts.iter().all(|&v| v == servoing || v == waiting), "{verdicts:?}\n{}", daemon.log());
    let errors: Vec<f64> = twists.iter().filter_map(|t| t["feature_error_px"].as_f64()).collect();
    let last = errors.last().copied().unwrap_or(f64::NAN);
    println!("blurred and noisy: feature error first {:?} px, last {last:.3} px", errors.first());
    assert!(last < 1.0, "feature error at the end {last} px: {errors:?}\n{}", daemon.log());
    assert!(running(&status(&instance).expect("status")), "{}", daemon.log());
    // the camera reports its exposure with each image (its gain is not modelled)
    let image = echo_lines(&instance, "camera_image", "0.3").pop().expect("an image");
    assert_eq!(image["exposure_us"].as_f64(), Some(30_000.0), "{image}");
    assert!(image["gain_db"].is_null(), "{image}");
    daemon.stop();
}

/// `vservoctl snapshot` lists every tag in view: here the one target, refined, its corners where the vision node
/// found the marks of the same frame (both refine the same edges; the snapshot's search is at full resolution).
fn the_snapshot_outlines_the_target_where_the_vision_node_found_it(instance: &str) {
    let scratch = ScratchDir::new(&unique("apriltag-snapshot"));
    let out = scratch.0.join("snapshot.png");
    let output =
        run("vservoctl", &["snapshot", "--instance", instance, "--out", out.to_str().expect("utf-8")]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    let tags = summary["tags"].as_array().expect("tags");
    assert_eq!(tags.len(), 1, "{summary}");
    assert_eq!(tags[0]["target"], true, "{summary}");
    assert_eq!(tags[0]["refined"], serde_json::json!([true, true, true, true]), "{summary}");
    for k in 0..4 {
        let (corner, found) = (numbers(&tags[0]["corners_px"][k]), numbers(&summary["marks"][k]["found_px"]));
        let apart = (corner[0] - found[0]).hypot(corner[1] - found[1]);
        assert!(apart < 0.1, "corner {k}: {corner:?} and the mark {found:?} {apart} px apart");
    }
}

/// The calibration demo (config/calibration-demo.toml: the 5 × 7 grid of tags through a lens, its centre tag
/// the target) servos in real time: the simulated camera renders the whole grid within its period, so every
/// frame of 4 s comes, numbered one after the other at the camera's rate, and the servo converges below 1 px.
#[test]
fn the_calibration_demo_renders_every_frame_and_converges_in_real_time() {
    let _one = exclusive();
    let instance = unique("calibration-demo");
    let (_config, daemon) = running_daemon_of("config/calibration-demo.toml", &instance);
    let window_s = 4.0;
    let frames: Vec<u64> = echo_lines(&instance, "camera_image", &window_s.to_string())
        .iter()
        .filter_map(|image| image["frame"].as_u64())
        .collect();
    let expected = window_s / 0.085;
    println!("{} frames in {window_s} s (the period gives {expected:.0})", frames.len());
    assert!(
        frames.len() as f64 >= 0.9 * expected,
        "{} frames in {window_s} s\n{}",
        frames.len(),
        daemon.log()
    );
    let gaps: Vec<_> = frames.windows(2).filter(|pair| pair[1] != pair[0] + 1).collect();
    assert!(gaps.is_empty(), "frames skipped: {gaps:?}\n{}", daemon.log());
    // and the servo brings the error below 1 px (the twists' error, within 15 s of the start)
    let below = || {
        echo_lines(&instance, "camera_twist", "0.3")
            .last()
            .and_then(|twist| twist["feature_error_px"].as_f64())
            .is_some_and(|error| error < 1.0)
    };
    assert!(wait_until(Duration::from_secs(11), below), "{:?}\n{}", status(&instance), daemon.log());
    daemon.stop();
}

/// A bundle of four tags through the lens (config/vservo-bundle.toml), its second tag covered from 2 s to 6 s
/// while the camera still moves: every frame has its four marks (the bundle's outer corners, from the tags
/// seen), the features say which tags gave them, and the servo converges below 1 px in real time.
#[test]
fn a_bundle_with_a_tag_covered_keeps_every_frame_and_converges_below_one_pixel_in_real_time() {
    let _one = exclusive();
    let instance = unique("bundle");
    let (_config, daemon) = running_daemon_of("config/vservo-bundle.toml", &instance);
    let features = echo_lines(&instance, "features", "8");
    assert!(features.len() > 40, "{} frames in 8 s\n{}", features.len(), daemon.log());
    let masks: Vec<u64> = features.iter().filter_map(|f| f["tags_used_mask"].as_u64()).collect();
    let valid: Vec<u64> = features.iter().filter_map(|f| f["valid_mask"].as_u64()).collect();
    assert!(
        valid.iter().all(|&v| v == 0b1111),
        "a frame without its four marks: {valid:?}\n{}",
        daemon.log()
    );
    assert!(masks.contains(&0b1101), "the covered tag (2) left out while covered: {masks:?}");
    assert_eq!(masks.last(), Some(&0b1111), "every tag used once uncovered: {masks:?}");
    let twists = echo_lines(&instance, "camera_twist", "0.5");
    let last = twists.iter().rev().find_map(|t| t["feature_error_px"].as_f64()).unwrap_or(f64::NAN);
    println!("bundle: tags used {masks:?}; feature error at the end {last:.3} px");
    assert!(last < 1.0, "feature error at the end {last} px\n{}", daemon.log());
    assert!(running(&status(&instance).expect("status")), "{}", daemon.log());
    // the snapshot marks each of the bundle's tags as the target's
    let scratch = ScratchDir::new(&unique("bundle-snapshot"));
    let out = scratch.0.join("snapshot.png");
    let output =
        run("vservoctl", &["snapshot", "--instance", &instance, "--out", out.to_str().expect("utf-8")]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    let mut ids: Vec<u64> =
        summary["tags"].as_array().expect("tags").iter().filter_map(|t| t["id"].as_u64()).collect();
    ids.sort_unstable();
    assert_eq!(ids, [10, 11, 12, 13], "{summary}");
    assert!(summary["tags"].as_array().expect("tags").iter().all(|t| t["target"] == true), "{summary}");
    daemon.stop();
}
