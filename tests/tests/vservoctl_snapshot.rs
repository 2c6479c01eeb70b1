//! `vservoctl snapshot`: the running camera's picture as a PNG with the marks drawn on it, read back as a person's
//! viewer would read it: each mark's green cross where `vservoctl echo features` (another reader of the same
//! stream) puts it, a red ring where the servo wants it, the numbers as JSON; what cannot be done is refused.

use std::time::Duration;

use serde_json::Value;
use vservo_system_tests::{
    Daemon, config_from, echo_lines, exclusive, numbers, run, status, unique, wait_until,
};

/// The colour of the pixel holding (x, y) in vservo's pixels (a pixel's centre at + ½).
fn colour_at(picture: &image::RgbImage, x: f64, y: f64) -> [u8; 3] {
    picture.get_pixel(x.floor() as u32, y.floor() as u32).0
}

#[test]
fn a_snapshot_draws_the_marks_where_the_features_are_and_where_the_servo_wants_them() {
    let _one = exclusive();
    let instance = unique("snapshot");
    // held at its start: nothing moves, so the snapshot and a later reader see the marks at the same places
    let config = config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("driver = \"simulated\"", "driver = \"simulated\"\nstart = \"held\""),
        ],
    );
    let daemon = Daemon::start(&config);
    // held (a safe stop of cause start_held), the vision node publishing features
    assert!(
        wait_until(Duration::from_secs(15), || status(&instance).is_some()
            && !echo_lines(&instance, "features", "0.3").is_empty()),
        "{}",
        daemon.log()
    );
    let out = std::env::temp_dir().join(format!("vservo-snapshot-{}.png", std::process::id()));
    let _ = std::fs::remove_file(&out);
    let output =
        run("vservoctl", &["snapshot", "--instance", &instance, "--out", out.to_str().expect("utf-8")]);
    assert!(output.status.success(), "{}\n{}", String::from_utf8_lossy(&output.stderr), daemon.log());
    let summary: Value = serde_json::from_slice(&output.stdout).expect("one JSON object");
    let picture = image::open(&out).expect("a PNG").to_rgb8();
    let _ = std::fs::remove_file(&out);
    assert_eq!((picture.width(), picture.height()), (512, 512));

    let echoed = echo_lines(&instance, "features", "0.5").pop().expect("features");
    let features = numbers(&echoed["features_px"]);
    let desired = numbers(&summary["desired_features_px"]);
    for mark in 0..4 {
        let (x, y) = (features[2 * mark], features[2 * mark + 1]);
        // the cross's centre and its arms three pixels out are the found mark's green
        for (dx, dy) in [(0.0, 0.0), (3.0, 0.0), (-3.0, 0.0), (0.0, 3.0), (0.0, -3.0)] {
            let c = colour_at(&picture, x + dx, y + dy);
            assert!(
                c[1] > 150 && c[0] < 60 && c[2] < 60,
                "mark {} at ({x:.1}, {y:.1}) + ({dx}, {dy}): {c:?}",
                mark + 1
            );
        }
        // the ring round the desired place is red, eleven pixels out
        let c = colour_at(&picture, desired[2 * mark] + 11.0, desired[2 * mark + 1]);
        assert!(c[0] > 150 && c[1] < 60, "mark {}'s desired ring: {c:?}", mark + 1);
        let error = summary["marks"][mark]["error_px"].as_f64().expect("an error");
        let found = numbers(&summary["marks"][mark]["found_px"]);
        assert!((found[0] - x).hypot(found[1] - y) < 0.05, "a held cell: {found:?} and ({x}, {y})");
        let apart = (found[0] - desired[2 * mark]).hypot(found[1] - desired[2 * mark + 1]);
        assert!((error - apart).abs() < 1e-9, "mark {}: error {error} px, {apart} px apart", mark + 1);
    }
    // the rest of the picture is the camera's gray
    let corner = colour_at(&picture, 5.5, 500.5);
    assert!(corner[0] == corner[1] && corner[1] == corner[2], "{corner:?}");

    // refused: not a PNG name, an instance that is not running (exit 1, naming it)
    let refused = run("vservoctl", &["snapshot", "--instance", &instance, "--out", "/tmp/x.jpg"]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains(".png"));
    let absent = run("vservoctl", &["snapshot", "--instance", "no-such-instance-here", "--timeout-s", "0.5"]);
    assert!(!absent.status.success());
    assert!(String::from_utf8_lossy(&absent.stderr).contains("no-such-instance-here"));
    daemon.stop();
}
