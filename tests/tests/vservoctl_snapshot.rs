//! `vservoctl snapshot`: the running camera's picture as a PNG with the marks drawn on it, read back as a person's
//! viewer would read it: each mark's green cross where `vservoctl echo features` (another reader of the same
//! stream) puts it, a red ring where the servo wants it, an obstacle's wireframe where a pinhole projection of its
//! corners from the camera's pose puts it, the numbers as JSON; what cannot be done is refused.

use std::time::Duration;

use nalgebra::{Matrix3, Point3, Rotation3, Translation3};
use serde_json::Value;
use vservo_system_tests::{
    Daemon, TempConfig, echo_lines, exclusive, numbers, repository_root, run, status, unique, wait_until,
};

/// The colour of the pixel holding (x, y) in vservo's pixels (a pixel's centre at + ½).
fn colour_at(picture: &image::RgbImage, x: f64, y: f64) -> [u8; 3] {
    picture.get_pixel(x.floor() as u32, y.floor() as u32).0
}

#[test]
fn a_snapshot_draws_the_marks_where_the_features_are_and_where_the_servo_wants_them() {
    let _one = exclusive();
    let instance = unique("snapshot");
    // held at its start: nothing moves, so the snapshot and a later reader see the marks at the same places; a
    // thin upright "sign" 1 cm in front of the board, centred on its marks, for the guard (and the picture)
    let default = repository_root().join("config/vservo.toml");
    let sign_centre = marks_centre_in_base(&default) - nalgebra::Vector3::new(0.01, 0.0, 0.0);
    let config = TempConfig::written(&format!(
        "extends = \"{}\"\n\n[instance]\nname = \"{instance}\"\n\n[robot]\nstart = \"held\"\n\n[collision]\n\n\
         [[scene.obstacles]]\nname = \"sign\"\nshape = \"box\"\nsize_m = [0.002, 0.10, 0.06]\n\
         translation_m = [{}, {}, {}]\n",
        default.display(),
        sign_centre.x,
        sign_centre.y,
        sign_centre.z,
    ));
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
    assert_the_sign_is_drawn_where_its_corners_image(&picture, &summary, &echoed, &sign_centre);
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

/// Where `vservoctl scene` puts the board's marks' centre in the base frame.
fn marks_centre_in_base(config: &std::path::Path) -> nalgebra::Vector3<f64> {
    let scene = run("vservoctl", &["scene", "--config", config.to_str().expect("utf-8")]);
    assert!(scene.status.success(), "{}", String::from_utf8_lossy(&scene.stderr));
    let scene: Value = serde_json::from_slice(&scene.stdout).expect("JSON");
    let rows: Vec<Vec<f64>> = (0..3).map(|r| numbers(&scene["base_from_board"][r])).collect();
    let marks: Vec<Vec<f64>> = (0..4).map(|m| numbers(&scene["board"]["marks_in_board_m"][m])).collect();
    let (x, y) =
        (marks.iter().map(|m| m[0]).sum::<f64>() / 4.0, marks.iter().map(|m| m[1]).sum::<f64>() / 4.0);
    nalgebra::Vector3::from_fn(|r, _| rows[r][0] * x + rows[r][1] * y + rows[r][3])
}

/// The sign (0.002 × 0.10 × 0.06 m, upright, facing the camera) is named in view, and the midpoint of each of
/// its front face's upright edges, as a pinhole of the configured intrinsics (500 px, centre 256) sees the edge's
/// ends from the camera's pose the features report, is on its wireframe's colour (within 2 px).
fn assert_the_sign_is_drawn_where_its_corners_image(
    picture: &image::RgbImage,
    summary: &Value,
    features: &Value,
    centre: &nalgebra::Vector3<f64>,
) {
    assert_eq!(summary["obstacles"], serde_json::json!([{"name": "sign", "in_view": true}]), "{summary}");
    let rows = numbers(&features["base_from_camera"]);
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_fn(|r, c| rows[4 * r + c]));
    let base_from_camera =
        nalgebra::IsometryMatrix3::from_parts(Translation3::new(rows[3], rows[7], rows[11]), rotation);
    let pixel = |corner: [f64; 3]| {
        let p = base_from_camera.inverse()
            * Point3::new(centre.x + corner[0], centre.y + corner[1], centre.z + corner[2]);
        (256.0 + 500.0 * p.x / p.z, 256.0 + 500.0 * p.y / p.z)
    };
    for y in [-0.05, 0.05] {
        let (top, bottom) = (pixel([-0.001, y, 0.03]), pixel([-0.001, y, -0.03]));
        let (u, v) = (0.5 * (top.0 + bottom.0), 0.5 * (top.1 + bottom.1));
        let near = (-2..=2)
            .flat_map(|du| (-2..=2).map(move |dv| (du, dv)))
            .any(|(du, dv)| colour_at(picture, u + f64::from(du), v + f64::from(dv)) == [0, 200, 255]);
        assert!(near, "the sign's edge at y {y:+} m: no wireframe near ({u:.1}, {v:.1})");
    }
}
