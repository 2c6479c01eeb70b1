//! The drivers a configuration names, as one typed choice each, and the sections config/vservo.toml documents
//! commented out, valid as written there.

use vservo_config::Config;

const DEFAULT: &str = include_str!("../../../config/vservo.toml");

/// Who drives the arm and the camera is one typed choice: each name in the file is its own variant, and the
/// drivers vservod starts are told apart from the user's own.
#[test]
fn the_drivers_are_typed_choices_and_the_gstreamer_camera_needs_its_pipeline() {
    let with =
        |robot: &str, camera: &str, extra: &str| {
            let text = DEFAULT
                .replacen("driver = \"simulated\"", &format!("driver = \"{robot}\""), 1)
                .replacen("source = \"simulated\"", &format!("source = \"{camera}\""), 1);
            Config::from_toml(&format!("{text}{extra}"), "t.toml")
        };
    let pipeline = "\n[camera.gstreamer]\npipeline = \"v4l2src ! videoconvert ! video/x-raw,format=GRAY8\"\n";
    let ros2 = with("ros2", "gstreamer", pipeline).expect("a ROS 2 arm and a GStreamer camera");
    assert_eq!(ros2.cell.robot.driver, vservo_config::RobotDriver::Ros2);
    assert_eq!(ros2.cell.vision.source, vservo_config::VisionSource::Gstreamer);
    assert!(
        ros2.runs_ros2_driver()
            && ros2.cell.vision.source.from_camera_driver()
            && !ros2.cell.robot.driver.is_simulated()
    );
    let ros2_camera_only = with("ros2", "external", "").expect("the ROS 2 arm alone");
    assert!(ros2_camera_only.runs_ros2_driver() && ros2_camera_only.cell.vision.source.name() == "external");
    let error = with("ros2", "gstreamer", "").expect_err("no pipeline").to_string();
    assert!(error.contains("camera.source") && error.contains("[camera.gstreamer]"), "{error}");
    // a real arm's first motion at a quarter of its limits unless the file says otherwise; the simulated arm at
    // its full limits
    let speed = |config: &Config| config.cell.interpolator.speed_scale;
    assert_eq!(speed(&ros2), 0.25);
    assert_eq!(speed(&Config::from_toml(DEFAULT, "t.toml").expect("the default")), 1.0);
    let given = DEFAULT
        .replacen("driver = \"simulated\"", "driver = \"ros2\"", 1)
        .replacen("source = \"simulated\"", "source = \"external\"", 1)
        .replacen("# speed_scale = 1.0", "speed_scale = 0.6", 1);
    assert_eq!(speed(&Config::from_toml(&given, "t.toml").expect("a ROS 2 arm at 0.6")), 0.6);
}

/// The sections config/vservo.toml documents commented out ([camera.truth], [camera.gstreamer], [target],
/// [calibration], [ros2.qos.image], [collision], [[scene.obstacles]]) are valid as written there: uncommented (each `# key = value` after its `# [section]` line, up
/// to the next blank line), the file loads, with each section's values. ([franka] needs a Franka arm and driver:
/// config/franka-sim.toml is that section in use.)
#[test]
fn the_commented_sections_of_the_default_are_valid_as_documented() {
    const SECTIONS: [&str; 7] = [
        "[camera.truth]",
        "[camera.gstreamer]",
        "[target]",
        "[calibration]",
        "[ros2.qos.image]",
        "[collision]",
        "[[scene.obstacles]]",
    ];
    let is_key_line = |line: &str| {
        line.strip_prefix("# ").and_then(|rest| rest.split_once(" = ")).is_some_and(|(key, _)| {
            !key.is_empty() && key.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        })
    };
    let mut text = String::new();
    let mut in_section = false;
    let mut uncommented = 0;
    for line in DEFAULT.lines() {
        if SECTIONS.iter().any(|section| line == format!("# {section}")) {
            in_section = true;
            uncommented += 1;
            text.push_str(&line[2..]);
        } else if line.trim().is_empty() {
            in_section = false;
            text.push_str(line);
        } else if in_section && is_key_line(line) {
            text.push_str(&line[2..]);
        } else {
            text.push_str(line);
        }
        text.push('\n');
    }
    assert_eq!(uncommented, SECTIONS.len(), "each section is in the file, commented out");
    let config =
        Config::from_toml(&text, "uncommented vservo.toml").expect("the documented sections are valid");
    assert!(config.cell.board.apriltag().is_some_and(|tag| tag.id() == 3), "[target]");
    assert!(
        config.gstreamer.as_ref().is_some_and(|g| g.pipeline.starts_with("v4l2src")),
        "[camera.gstreamer]"
    );
    assert!(config.calibration.as_ref().is_some_and(|c| c.poses == 12), "[calibration]");
    assert!(config.cell.camera_truth.is_some(), "[camera.truth]");
    let image = config.ros2.qos_of(vservo_config::Ros2Topic::Image);
    assert_eq!(image.reliability, Some(vservo_config::QosReliability::BestEffort), "[ros2.qos.image]");
    let collision = config.cell.collision.as_ref().expect("[collision]");
    assert_eq!((collision.slowdown_distance_m, collision.stop_distance_m), (0.10, 0.03), "[collision]");
    assert!(collision.workspace.is_some() && collision.camera_box.is_some(), "[collision]");
    assert_eq!(collision.obstacles.len(), 1, "[[scene.obstacles]]");
    assert_eq!(collision.obstacles[0].name, "table", "[[scene.obstacles]]");
}
