//! `[camera.truth]`: the simulated camera as it really is. Each key defaults to the believed value; bad values
//! are refused naming the key; a camera that is not simulated cannot have one.

use vservo_config::{Config, ConfigError};

const DEFAULT: &str = include_str!("../../../config/vservo.toml");

fn with(truth: &str) -> Result<Config, ConfigError> {
    Config::from_toml(&format!("{DEFAULT}\n[camera.truth]\n{truth}\n"), "truth.toml")
}

fn refused_key(result: Result<Config, ConfigError>) -> String {
    let error = result.expect_err("refused");
    format!("{} | {error}", error.key().unwrap_or(""))
}

#[test]
fn left_out_keys_are_the_believed_values_and_given_ones_are_taken() {
    let believed = Config::from_toml(DEFAULT, "vservo.toml").expect("the default");
    assert_eq!(believed.cell.camera_truth, None);
    assert_eq!(believed.cell.true_camera().intrinsics, believed.cell.camera);
    assert_eq!(believed.cell.true_camera().tool_from_camera, believed.cell.tool_from_camera);
    let config = with("fx_px = 1000.0\ntool_from_camera = { translation_m = [0.005, 0.0, 0.0], rotation_rpy_deg = [0.0, 0.0, 2.0] }")
        .expect("a truth");
    let truth = config.cell.true_camera();
    assert_eq!(truth.intrinsics.fx_px(), 1000.0);
    assert_eq!(truth.intrinsics.fy_px(), believed.cell.camera.fy_px());
    assert_eq!(config.cell.camera, believed.cell.camera, "what the cell believes is unchanged");
    assert_eq!(truth.tool_from_camera.translation.vector.x, 0.005);
    assert_eq!(config.cell.tool_from_camera, believed.cell.tool_from_camera);
}

#[test]
fn bad_values_and_a_camera_that_is_not_simulated_are_refused_by_key() {
    for (truth, key) in [
        ("fx_px = 0.0", "camera.truth.fx_px"),
        ("fy_px = nan", "camera.truth.fy_px"),
        ("principal_point_px = [-5.0, 10.0]", "camera.truth.principal_point_px"),
        ("distortion = [20.0, 0.0, 0.0, 0.0, 0.0]", "camera.truth.distortion"),
        (
            "tool_from_camera = { translation_m = [3.0, 0.0, 0.0], rotation_rpy_deg = [0.0, 0.0, 0.0] }",
            "camera.truth.tool_from_camera",
        ),
        ("focal_px = 800.0", ""),
    ] {
        let refusal = refused_key(with(truth));
        assert!(refusal.starts_with(key), "{truth}: {refusal}");
    }
    // recorded images were taken by a real camera; an external one may be a driver simulating the cell
    let recorded = DEFAULT.replacen("source = \"simulated\"", "source = \"directory\"", 1).replacen(
        "directory = \"\"",
        "directory = \"/tmp\"",
        1,
    );
    let refusal =
        refused_key(Config::from_toml(&format!("{recorded}\n[camera.truth]\nfx_px = 900.0\n"), "x.toml"));
    assert!(refusal.starts_with("camera.truth |") && refusal.contains("simulated"), "{refusal}");
    let external = DEFAULT.replacen("source = \"simulated\"", "source = \"external\"", 1);
    let simulating_driver =
        Config::from_toml(&format!("{external}\n[camera.truth]\nfx_px = 900.0\n"), "x.toml")
            .expect("an external camera may have a truth");
    assert_eq!(simulating_driver.cell.true_camera().intrinsics.fx_px(), 900.0);
}
