//! `vservoctl vision render` then `vservoctl vision extract`, as a user checks a setup; bad images.

use serde_json::Value;
use vservo_system_tests::{default_config, run};

fn temp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("vservo-vision-{}-{name}", std::process::id()))
}

/// `vservoctl vision render` of the default configuration at `q` into `image`.
fn render(q: &str, image: &std::path::Path) {
    let config = default_config();
    let output = run(
        "vservoctl",
        &[
            "vision",
            "render",
            "--config",
            config.to_str().expect("utf-8"),
            "--q",
            q,
            "--out",
            image.to_str().expect("utf-8"),
        ],
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

fn extract_json(image: &std::path::Path) -> Value {
    let config = default_config();
    let output = run(
        "vservoctl",
        &[
            "vision",
            "extract",
            image.to_str().expect("utf-8"),
            "--config",
            config.to_str().expect("utf-8"),
            "--json",
        ],
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).expect("one JSON object")
}

#[test]
fn rendered_desired_view_extracts_to_the_desired_features() {
    for extension in ["png", "pgm"] {
        let image = temp(&format!("qn.{extension}"));
        render("qn", &image);
        let json = extract_json(&image);
        let expected = [151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0];
        let features: Vec<f64> =
            json["features"].as_array().expect("8").iter().map(|v| v.as_f64().expect("number")).collect();
        for (f, e) in features.iter().zip(expected) {
            // the default config adds noise (σ = 1) and a lighting gradient
            assert!((f - e).abs() < 0.2, "{features:?}");
        }
        assert_eq!(json["valid"], serde_json::json!([true, true, true, true]));
        assert_eq!(json["reasons"], serde_json::json!(["", "", "", ""]));
        let _ = std::fs::remove_file(image);
    }
}

#[test]
fn a_mark_out_of_view_is_null_with_its_reason() {
    let image = temp("turned.png");
    // turning the waist by 0.2 rad swings the view far to the side
    render("0.2,0.785,-3.1416,0,0.785,0", &image);
    let json = extract_json(&image);
    let valid: Vec<bool> =
        json["valid"].as_array().expect("4").iter().map(|v| v.as_bool().expect("bool")).collect();
    assert!(valid.iter().any(|v| !v), "some mark leaves the view: {json}");
    for (mark, v) in valid.iter().enumerate() {
        assert_eq!(json["features"][2 * mark].is_null(), !v);
        assert_eq!(json["reasons"][mark].as_str().expect("string").is_empty(), *v, "{json}");
    }
    let _ = std::fs::remove_file(image);
}

#[test]
fn wrong_size_and_blank_images_give_reasons_and_unreadable_files_exit_2() {
    let small = temp("small.pgm");
    image::GrayImage::from_pixel(64, 48, image::Luma([90])).save(&small).expect("write");
    let json = extract_json(&small);
    assert!(json["reasons"][0].as_str().expect("string").contains("64×48"), "{json}");
    assert!(json["features"].as_array().expect("8").iter().all(Value::is_null));
    let black = temp("black.png");
    image::GrayImage::new(512, 512).save(&black).expect("write");
    let json = extract_json(&black);
    assert!(json["reasons"][3].as_str().expect("string").contains("all black"), "{json}");
    let text = temp("not-an-image.png");
    std::fs::write(&text, "hello").expect("write");
    let output = run(
        "vservoctl",
        &[
            "vision",
            "extract",
            text.to_str().expect("utf-8"),
            "--config",
            default_config().to_str().expect("utf-8"),
        ],
    );
    assert_eq!(output.status.code(), Some(2), "{}", String::from_utf8_lossy(&output.stderr));
    for f in [small, black, text] {
        let _ = std::fs::remove_file(f);
    }
}

/// The AprilTag cell (config/vservo-apriltag.toml, through its lens): its desired view renders and extracts
/// to the tag's four corners; a configuration that looks for another id says, for each corner, that another
/// tag was found, and gives no features.
#[test]
fn an_apriltag_view_extracts_to_its_corners_and_another_id_says_so() {
    let config = vservo_system_tests::repository_root().join("config/vservo-apriltag.toml");
    let config_arg = config.to_str().expect("utf-8").to_string();
    let scene = run("vservoctl", &["scene", "--config", &config_arg]);
    assert!(scene.status.success(), "{}", String::from_utf8_lossy(&scene.stderr));
    let scene: Value = serde_json::from_slice(&scene.stdout).expect("one JSON object");
    let q: Vec<String> = scene["desired_joints_rad"]
        .as_array()
        .expect("six joints")
        .iter()
        .map(|v| v.as_f64().expect("number").to_string())
        .collect();
    let image = temp("apriltag.pgm");
    let rendered = run(
        "vservoctl",
        &[
            "vision",
            "render",
            "--config",
            &config_arg,
            &format!("--q={}", q.join(",")),
            "--out",
            image.to_str().expect("utf-8"),
        ],
    );
    assert!(rendered.status.success(), "{}", String::from_utf8_lossy(&rendered.stderr));
    let extract = |config: &str| -> Value {
        let output = run(
            "vservoctl",
            &["vision", "extract", image.to_str().expect("utf-8"), "--config", config, "--json"],
        );
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        serde_json::from_slice(&output.stdout).expect("one JSON object")
    };
    let found = extract(&config_arg);
    assert_eq!(found["valid"], serde_json::json!([true, true, true, true]), "{found}");
    // as observed through the lens, so near (not at) ξ_d's pinhole corners: within the lens's 2 px
    let desired = vservo_system_tests::numbers(&scene["desired_features_px"]);
    let features = vservo_system_tests::numbers(&found["features"]);
    for (f, d) in features.iter().zip(&desired) {
        assert!((f - d).abs() < 3.0, "{features:?} against {desired:?}");
    }
    let other = vservo_system_tests::config_from("config/vservo-apriltag.toml", &[("id = 3", "id = 5")]);
    let refused = extract(&other.arg());
    assert_eq!(refused["valid"], serde_json::json!([false, false, false, false]), "{refused}");
    assert_eq!(refused["features"], serde_json::json!([null, null, null, null, null, null, null, null]));
    for reason in refused["reasons"].as_array().expect("4") {
        assert_eq!(reason, "tag 5: another tag found (id 3)", "{refused}");
    }
    let _ = std::fs::remove_file(&image);
}
