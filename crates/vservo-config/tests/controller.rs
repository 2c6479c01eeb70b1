//! `[controller]`: the laws by name, and the options beyond the paper's law off by default and checked.

mod common;

use common::{refused, with};
use vservo_config::Config;

#[test]
fn the_law_beyond_the_paper_is_off_by_default_and_its_keys_are_checked() {
    let config =
        Config::from_toml(&with("feedforward = false", "feedforward = false"), "vservo.toml").expect("valid");
    assert_eq!(config.cell.controller.options, vservo_settings::control::LawOptions::default());
    let robust = Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-robust.toml"))
        .expect("config/vservo-robust.toml is valid");
    assert_eq!(robust.cell.controller.options.interaction, vservo_settings::control::Interaction::Mean);
    assert!(
        robust.cell.controller.options.feedforward && robust.cell.controller.options.border_margin_px == 20.0
    );

    let error = refused(&with("interaction = \"desired\"", "interaction = \"nearest\""));
    assert!(
        error.to_string().contains("controller.interaction") && error.to_string().contains("nearest"),
        "{error}"
    );
    let error = refused(&with("border_margin_px = 0.0", "border_margin_px = -3.0"));
    assert!(error.to_string().contains("controller.border_margin_px"), "{error}");
    // ξ_d has a mark at y = 70 px: a margin of 80 px would keep the servo from its goal
    let error = refused(&with("border_margin_px = 0.0", "border_margin_px = 80.0"));
    assert!(
        error.to_string().contains("desired mark") && error.to_string().contains("inside the margin"),
        "{error}"
    );
    // the target may be at fault as well as the margin: both ways out are named
    assert!(
        error.to_string().contains("place the target further in")
            && error.to_string().contains("lower the margin"),
        "{error}"
    );
}

#[test]
fn the_pose_based_laws_are_named_and_their_gain_and_caps_checked() {
    use vservo_settings::control::ControlLaw;
    // unwritten, the caps are the robot's camera limits where those are lower
    let slow = with("max_camera_rotation_rad_s = 6.0", "max_camera_rotation_rad_s = 1.5");
    let config = Config::from_toml(&slow, "vservo.toml").expect("valid");
    assert_eq!(config.cell.controller.options.pose_max_rotation_rad_s, 1.5);
    assert_eq!(config.cell.controller.options.pose_max_speed_m_s, 0.5);
    for law in ControlLaw::ALL {
        let text = with("law = \"paper\"", &format!("law = \"{}\"", law.name()));
        let config = Config::from_toml(&text, "vservo.toml").expect("valid");
        assert_eq!(config.cell.controller.law, law);
    }
    let config =
        Config::from_toml(&with("# pose_gain_per_s = 6.0", "pose_gain_per_s = 11.7"), "v.toml").expect("ok");
    assert_eq!(config.cell.controller.options.pose_gain_per_s, 11.7);
    // λT ≤ 1 at the 85 ms period: 11.76 1/s at most
    for bad in ["0.0", "-1.0", "12.0", "nan"] {
        let error = refused(&with("# pose_gain_per_s = 6.0", &format!("pose_gain_per_s = {bad}")));
        assert!(
            error.to_string().contains("controller.pose_gain_per_s")
                && error.to_string().contains("vision period"),
            "{error}"
        );
    }
    for (old, bad) in [
        ("# pose_max_speed_m_s = 0.5", "pose_max_speed_m_s = 0.0"),
        ("# pose_max_rotation_rad_s = 2.0", "pose_max_rotation_rad_s = -1.0"),
        ("# pose_max_speed_m_s = 0.5", "pose_max_speed_m_s = 1e9"),
        // above the robot's camera limits (2 m/s, 6 rad/s), which the rmrc refuses a twist beyond
        ("# pose_max_speed_m_s = 0.5", "pose_max_speed_m_s = 2.5"),
        ("# pose_max_rotation_rad_s = 2.0", "pose_max_rotation_rad_s = 7.0"),
    ] {
        let error = refused(&with(old, bad));
        let key = bad.split(' ').next().expect("a key");
        assert!(error.to_string().contains(&format!("controller.{key}")), "{error}");
    }
}
