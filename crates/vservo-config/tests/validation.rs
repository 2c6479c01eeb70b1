//! The default configuration loads; each kind of bad value is refused with its key and value.

mod common;

use common::{DEFAULT, refused, with};
use vservo_config::{Config, ConfigError};

#[test]
fn default_config_gives_the_papers_desired_features_and_camera_direction() {
    let config = Config::from_toml(DEFAULT, "vservo.toml").expect("valid");
    let expected = [151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0];
    for (f, e) in config.cell.desired.features.iter().zip(expected) {
        assert!((f - e).abs() < 1e-9, "{}", config.cell.desired.features);
    }
    assert_eq!(config.cell.timing.control_ticks_per_frame, 85);
    assert_eq!(config.instance, "default");
    // at q_d the camera looks along world +x with image y down (docs/REPRODUCTION.md)
    let arm = vservo_arm::puma560::puma560();
    let base_from_camera = arm.base_from_tool(&config.cell.desired.joints) * config.cell.tool_from_camera;
    let rotation = base_from_camera.rotation.matrix();
    assert!(
        (rotation.column(2) - nalgebra::Vector3::x()).norm() < 1e-12,
        "optical axis {}",
        rotation.column(2)
    );
    assert!((rotation.column(1) + nalgebra::Vector3::z()).norm() < 1e-12, "image y {}", rotation.column(1));
    // the board is 0.5 m in front of the camera
    let board = config.cell.base_from_board(&arm);
    let offset = board.translation.vector - base_from_camera.translation.vector;
    assert!((offset - nalgebra::Vector3::new(0.5, 0.0, 0.0)).norm() < 1e-12);
}

#[test]
fn unknown_keys_and_wrong_types_are_refused_with_the_file_and_line() {
    let error = refused(&with("[timing]", "[timing]\nspeed = 3"));
    let message = error.to_string();
    assert!(message.starts_with("test.toml:") && message.contains("speed"), "{message}");
    let error = refused(&with("focal_px = 500.0", "focal_px = \"long\""));
    assert!(error.to_string().contains("focal_px"), "{error}");
    assert!(refused("not toml [").to_string().starts_with("test.toml:"));
}

#[test]
fn bad_values_name_their_key_and_value() {
    let cases = [
        (with("vision_period_s = 0.085", "vision_period_s = 0.0855"), "timing.vision_period_s", "0.0855"),
        (with("vision_period_s = 0.085", "vision_period_s = -1.0"), "timing.vision_period_s", "-1"),
        (with("pipeline_delay_frames = 1", "pipeline_delay_frames = 9"), "timing.pipeline_delay_frames", "9"),
        (with("focal_px = 500.0", "focal_px = 0.0"), "camera.focal_px", "0"),
        (with("width_px = 512", "width_px = -4"), "camera.width_px", "-4"),
        (with("q = 300.0", "q = -1.0"), "controller.q", "-1.0"),
        (with("q = 300.0", "q = [1.0, 2.0]"), "controller.q", "[1.0, 2.0]"),
        (
            with("r = [1.0, 1.0, 1.0, 6.0, 6.0, 6.0]", "r = [1.0, 1.0, 1.0, 6.0, 6.0, 0.0]"),
            "controller.r",
            "0.0",
        ),
        (with("r = [1.0, 1.0, 1.0, 6.0, 6.0, 6.0]", "r = nan"), "controller.r", "nan"),
        (with("name = \"default\"", "name = \"a/b\""), "instance.name", "a/b"),
        (
            with("translation_m = [0.0, 0.0, 0.5]", "translation_m = [0.0, 0.0, -0.5]"),
            "desired.camera_from_board",
            "behind",
        ),
        (
            with("translation_m = [0.0, 0.0, 0.5]", "translation_m = [0.5, 0.0, 0.5]"),
            "desired.camera_from_board",
            "outside",
        ),
        (with("-3.141592653589793, 0.0, 0.785", "1.0, 0.0, 0.785"), "desired.joints_rad", "joint 3"),
        (with("[[-0.105, -0.088], ", "[[0.062, -0.079], "), "object.marks_in_board_m", "marks 1 and 2"),
        (
            with("[[-0.16, -0.24], [0.14, -0.03]]", "[[-0.16, -0.24], [0.07, -0.03]]"),
            "object.board_extent_m",
            "every mark",
        ),
        (with("source = \"simulated\"", "source = \"directory\""), "camera.directory", "must name"),
        (
            with("driver = \"simulated\"", "driver = \"external\"\ncommand = \"velocity\""),
            "camera.source",
            "simulated camera",
        ),
        (
            with("source = \"simulated\"", "source = \"external\"")
                .replace("driver = \"simulated\"", "driver = \"external\""),
            "robot.command",
            "must declare",
        ),
        (
            with("driver = \"simulated\"", "driver = \"simulated\"\ncommand = \"velocity\""),
            "robot.command",
            "leave robot.command out",
        ),
        (with("state_timeout_periods = 50", "state_timeout_periods = 1"), "robot.state_timeout_periods", "1"),
        (
            with("source = \"simulated\"", "source = \"external\"").replace(
                "driver = \"simulated\"",
                "driver = \"external\"\ncommand = \"velocity\"\nperiod_s = 5.0",
            ),
            "robot.period_s",
            "5",
        ),
        (with("threshold = \"otsu\"", "threshold = 300"), "vision.threshold", "300"),
        (with("max_mark_area_px = 6000", "max_mark_area_px = 5"), "vision.max_mark_area_px", "5"),
        (with("noise_sigma_gray = 1.0", "noise_sigma_gray = -1.0"), "vision.render.noise_sigma_gray", "-1"),
        (with("mark_gray = 20", "mark_gray = 225"), "vision.render.mark_gray", "225"),
        (with("supersampling = 8", "supersampling = 0"), "vision.render.supersampling", "0"),
        (with("stop_ramp_s = 0.2", "stop_ramp_s = 0.0"), "interpolator.stop_ramp_s", "0"),
        (with("# speed_scale = 1.0", "speed_scale = 0.0"), "robot.speed_scale", "0"),
        (with("# speed_scale = 1.0", "speed_scale = 1.5"), "robot.speed_scale", "1.5"),
        (with("kp = [3600.0, 3600.0", "kp = [-1.0, 3600.0"), "joint_servo.kp", "-1.0"),
        (with("duration_s = 30.0", "duration_s = 0.0"), "scenario.duration_s", "0"),
    ];
    for (text, key, fragment) in cases {
        let error = refused(&text);
        assert_eq!(error.key(), Some(key), "{error}");
        let message = error.to_string();
        assert!(message.starts_with("test.toml: "), "{message}");
        assert!(message.contains(fragment), "{message:?} should show {fragment:?}");
    }
}

#[test]
fn weights_can_be_full_symmetric_matrices() {
    let full_r = "r = [[1.0, 0.1, 0.0, 0.0, 0.0, 0.0], [0.1, 1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0, 0.0, 0.0], \
                  [0.0, 0.0, 0.0, 6.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 6.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 6.0]]";
    let config = Config::from_toml(&with("r = [1.0, 1.0, 1.0, 6.0, 6.0, 6.0]", full_r), "t").expect("valid");
    assert_eq!(config.cell.controller.r.as_written()[(0, 1)], 0.1);
    let asymmetric = full_r.replacen("[0.1, 1.0", "[0.2, 1.0", 1);
    let error = refused(&with("r = [1.0, 1.0, 1.0, 6.0, 6.0, 6.0]", &asymmetric));
    assert!(error.to_string().contains("not symmetric"), "{error}");
}

#[test]
fn a_missing_file_is_named() {
    let error = Config::load("/nonexistent/vservo.toml").expect_err("missing");
    assert!(error.to_string().starts_with("/nonexistent/vservo.toml: cannot read"), "{error}");
}

#[test]
fn the_mujoco_cell_declares_an_external_velocity_driver_and_camera() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/mujoco.toml");
    let config = Config::load(path).expect("config/mujoco.toml is valid");
    assert_eq!(config.cell.robot.driver, vservo_config::RobotDriver::External);
    assert_eq!(config.cell.command_interface(), vservo_config::CommandInterface::Velocity);
    assert_eq!(config.cell.vision.source, vservo_config::VisionSource::External);
    assert!((config.cell.robot.state_timeout_s() - 0.05).abs() < 1e-12);
    // the default cell: the simulated driver takes torques, or positions with the kinematic plant
    let mut default = Config::from_toml(DEFAULT, "default").expect("valid");
    assert_eq!(default.cell.command_interface(), vservo_config::CommandInterface::Torque);
    default.cell.plant.mode = vservo_settings::simulation::PlantMode::Kinematic;
    assert_eq!(default.cell.command_interface(), vservo_config::CommandInterface::Position);
}

/// config/vservo-ros2-cell.toml: the arm and the camera from ROS 2, through the ROS 2 driver vservod starts (a
/// driver behind the contract to the rest of vservo); velocity by default, position taken, torques refused (a
/// forward controller takes none).
#[test]
fn the_ros2_cell_takes_its_arm_and_camera_from_ros2() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-ros2-cell.toml");
    let config = Config::load(path).expect("config/vservo-ros2-cell.toml is valid");
    assert_eq!(config.cell.robot.driver, vservo_config::RobotDriver::Ros2);
    assert_eq!(config.cell.vision.source, vservo_config::VisionSource::Ros2);
    assert!(config.cell.vision.source.from_camera_driver() && !config.cell.robot.driver.is_simulated());
    assert_eq!(config.cell.command_interface(), vservo_config::CommandInterface::Velocity);
    let driver = &config.ros2.driver;
    assert!(config.runs_ros2_driver() && !config.ros2.enabled);
    assert_eq!(driver.command_topic, "/forward_velocity_controller/commands");
    assert!((config.cell.robot.period_s - 0.002).abs() < 1e-15);

    let ros2_arm = DEFAULT.replacen("driver = \"simulated\"", "driver = \"ros2\"", 1).replacen(
        "source = \"simulated\"",
        "source = \"ros2\"",
        1,
    );
    let config = Config::from_toml(&ros2_arm, "t").expect("velocity by default");
    assert_eq!(config.cell.command_interface(), vservo_config::CommandInterface::Velocity);
    let position = ros2_arm.replacen("# command = \"velocity\"", "command = \"position\"", 1);
    let config = Config::from_toml(&position, "t").expect("position");
    assert_eq!(config.cell.command_interface(), vservo_config::CommandInterface::Position);
    let torque = ros2_arm.replacen("# command = \"velocity\"", "command = \"torque\"", 1);
    let error = refused(&torque).to_string();
    assert!(error.contains("robot.command") && error.contains("forward controller"), "{error}");
    // the bridge on as well, publishing the arm's own joint_states back onto the topic the driver reads
    let clash = ros2_arm.replacen("enabled = false\n# ROS_DOMAIN_ID", "enabled = true\n# ROS_DOMAIN_ID", 1);
    let error = refused(&clash).to_string();
    assert!(error.contains("ros2.publish") && error.contains("/joint_states"), "{error}");
}

/// A custom arm (a UR5's published standard-DH table) with an external velocity driver: kinematics from
/// the file, reach by the numerical solution; the simulated driver takes it kinematically only.
#[test]
fn a_custom_arm_is_taken_from_its_dh_table() {
    let custom = "preset = \"custom\"\n\
        dh = [[0.0, 1.5707963267948966, 0.089159, 0.0], [-0.425, 0.0, 0.0, 0.0], [-0.39225, 0.0, 0.0, 0.0], \
              [0.0, 1.5707963267948966, 0.10915, 0.0], [0.0, -1.5707963267948966, 0.09465, 0.0], [0.0, 0.0, 0.0823, 0.0]]\n\
        joint_limits_rad = [[-6.28, 6.28], [-6.28, 6.28], [-3.1, 3.1], [-6.28, 6.28], [-6.28, 6.28], [-6.28, 6.28]]\n\
        velocity_limits_rad_s = [3.0, 3.0, 3.0, 3.0, 3.0, 3.2]\n\
        acceleration_limits_rad_s2 = [5.0, 5.0, 5.0, 5.0, 5.0, 5.0]";
    let external = with("preset = \"puma560\"", custom)
        .replacen("source = \"simulated\"", "source = \"external\"", 1)
        .replacen("driver = \"simulated\"", "driver = \"external\"\ncommand = \"velocity\"", 1)
        .replacen(
            "joints_rad = [0.0, 0.7853981633974483, -3.141592653589793, 0.0, 0.7853981633974483, 0.0]",
            "joints_rad = [0.0, -1.2, 1.5, -0.3, 1.57, 0.0]",
            1,
        );
    let config = Config::from_toml(&external, "test.toml").expect("a custom arm with an external driver");
    assert_eq!(config.cell.arm.name, "custom arm");
    assert_eq!(config.cell.arm.links[1].dh.a(), -0.425);
    assert_eq!(config.cell.arm.links[5].limits.velocity_max, 3.2);
    let q = config.cell.desired.joints + vservo_arm::JointVector::from_element(0.05);
    let reached = config
        .cell
        .arm
        .reach(&config.cell.arm.base_from_tool(&q), &config.cell.desired.joints)
        .expect("reached");
    assert!(
        (config.cell.arm.base_from_tool(&reached).translation.vector
            - config.cell.arm.base_from_tool(&q).translation.vector)
            .norm()
            < 1e-9
    );
    let simulated = with("preset = \"puma560\"", custom).replacen(
        "joints_rad = [0.0, 0.7853981633974483, -3.141592653589793, 0.0, 0.7853981633974483, 0.0]",
        "joints_rad = [0.0, -1.2, 1.5, -0.3, 1.57, 0.0]",
        1,
    );
    let error = refused(&simulated);
    assert_eq!(error.key(), Some("plant.mode"), "{error}");
    let kinematic = simulated.replacen("mode = \"dynamic\"", "mode = \"kinematic\"", 1);
    Config::from_toml(&kinematic, "test.toml")
        .expect("the simulated driver moves a custom arm kinematically");
}

/// Every number in the default file, replaced by an absurd value (1e300, −1e300, NaN; the largest and the
/// most negative integer), is refused naming its own key. Only the render noise seed takes any integer.
#[test]
fn every_numeric_key_has_a_range() {
    fn numbers(value: &toml::Value, path: &str, out: &mut Vec<String>) {
        match value {
            toml::Value::Table(table) => {
                for (key, item) in table {
                    let child = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
                    numbers(item, &child, out);
                }
            }
            toml::Value::Integer(_) | toml::Value::Float(_) => out.push(path.to_string()),
            toml::Value::Array(items) if items.iter().any(|i| !matches!(i, toml::Value::String(_))) => {
                out.push(path.to_string())
            }
            _ => {}
        }
    }
    fn replace(value: &mut toml::Value, path: &[&str], with: &dyn Fn(&toml::Value) -> toml::Value) {
        let item = value.get_mut(path[0]).expect("the key");
        if path.len() == 1 {
            *item = with(item);
        } else {
            replace(item, &path[1..], with);
        }
    }
    /// The value with every number in it (nested arrays too) replaced.
    fn absurd(value: &toml::Value, float: f64, integer: i64) -> toml::Value {
        match value {
            toml::Value::Integer(_) => toml::Value::Integer(integer),
            toml::Value::Float(_) => toml::Value::Float(float),
            toml::Value::Array(items) => {
                toml::Value::Array(items.iter().map(|i| absurd(i, float, integer)).collect())
            }
            other => other.clone(),
        }
    }
    let default: toml::Value = toml::from_str(DEFAULT).expect("the default parses");
    let mut keys = Vec::new();
    numbers(&default, "", &mut keys);
    assert!(keys.len() > 50, "{keys:?}");
    let mut checked = 0;
    let mut wrong = Vec::new();
    for key in keys.iter().filter(|k| *k != "vision.render.noise_seed") {
        let path: Vec<&str> = key.split('.').collect();
        for (float, integer) in [(1e300, i64::MAX), (-1e300, i64::MIN), (f64::NAN, i64::MAX)] {
            let mut file = default.clone();
            replace(&mut file, &path, &|v| absurd(v, float, integer));
            let text = toml::to_string(&file).expect("serialises");
            match Config::from_toml(&text, "test.toml") {
                Ok(_) => wrong.push(format!("{key} = {float} (or {integer}) is taken")),
                Err(error) if error.key() != Some(key.as_str()) => wrong
                    .push(format!("{key} = {float}/{integer}: the error names {:?}: {error}", error.key())),
                Err(_) => {}
            }
            checked += 1;
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    println!("{checked} absurd values over {} numeric keys refused, each naming its key", keys.len());
}

#[test]
fn the_viewer_is_off_on_localhost_by_default_and_takes_ip_addresses_only() {
    let config =
        Config::from_toml(&with("enabled = false", "enabled = false"), "vservo.toml").expect("valid");
    assert!(!config.viewer.enabled);
    assert_eq!((config.viewer.address.as_str(), config.viewer.port), ("127.0.0.1", 8765));
    assert_eq!(config.viewer.max_clients, 4);
    let error = refused(&with("max_clients = 4", "max_clients = 0"));
    assert!(error.to_string().contains("viewer.max_clients"), "{error}");
    let error = refused(&with("address = \"127.0.0.1\"", "address = \"robot-pc\""));
    assert!(
        error.to_string().contains("viewer.address") && error.to_string().contains("robot-pc"),
        "{error}"
    );
    let error = refused(&with("port = 8765", "port = 0"));
    assert!(error.to_string().contains("viewer.port"), "{error}");
}

#[test]
fn occlusions_name_a_mark_and_a_time_span() {
    let config = Config::from_toml(
        &with("occlusions = []", "occlusions = [{ mark = 2, from_s = 3.0, until_s = 4.5 }]"),
        "vservo.toml",
    )
    .expect("valid");
    assert_eq!(config.cell.scenario.hidden_marks(2.9), 0);
    assert_eq!(config.cell.scenario.hidden_marks(3.0), 0b0010);
    assert_eq!(config.cell.scenario.hidden_marks(4.5), 0);
    let error = refused(&with("occlusions = []", "occlusions = [{ mark = 5, from_s = 3.0, until_s = 4.5 }]"));
    assert!(error.to_string().contains("scenario.occlusions[0].mark"), "{error}");
    let error = refused(&with("occlusions = []", "occlusions = [{ mark = 1, from_s = 3.0, until_s = 2.0 }]"));
    assert!(error.to_string().contains("scenario.occlusions[0].until_s"), "{error}");
}

#[test]
fn reacquiring_has_the_defaults_and_its_keys_are_checked_against_the_period_and_the_robot() {
    let config = Config::from_toml(DEFAULT, "test.toml").expect("the default loads");
    assert_eq!(config.cell.reacquire, vservo_config::Reacquire::default());
    let without: String = DEFAULT
        .lines()
        .filter(|l| !["gain_per_s", "max_speed_m_s", "max_rotation_rad_s"].iter().any(|k| l.starts_with(k)))
        .collect::<Vec<_>>()
        .join("\n");
    let config = Config::from_toml(&without, "test.toml").expect("the section is optional");
    assert_eq!(config.cell.reacquire, vservo_config::Reacquire::default());
    // left out under a robot slower than the defaults: the defaults are lowered to its limits
    let slow_robot = without.replace("max_camera_speed_m_s = 2.0", "max_camera_speed_m_s = 0.05");
    assert_eq!(
        Config::from_toml(&slow_robot, "test.toml").expect("loads").cell.reacquire.max_speed_m_s,
        0.05
    );
    let gentle = with("max_speed_m_s = 0.1", "max_speed_m_s = 0.02");
    assert_eq!(Config::from_toml(&gentle, "test.toml").expect("loads").cell.reacquire.max_speed_m_s, 0.02);
    for (text, key) in [
        // faster than 1 / vision period would overshoot within a frame
        (with("gain_per_s = 1.5", "gain_per_s = 12.0"), "reacquire.gain_per_s"),
        (with("max_speed_m_s = 0.1", "max_speed_m_s = 0.0"), "reacquire.max_speed_m_s"),
        // beyond what the robot lets the camera do
        (with("max_rotation_rad_s = 0.5", "max_rotation_rad_s = 9.0"), "reacquire.max_rotation_rad_s"),
    ] {
        let error = refused(&text);
        assert_eq!(error.key(), Some(key), "{error}");
    }
}

/// A name a key does not take is refused by the parser, naming the file, the dotted key, the value and the
/// names it takes.
#[test]
fn unknown_names_are_refused_listing_the_accepted_ones() {
    let cases = [
        (with("law = \"paper\"", "law = \"fast\""), "controller.law", "fast", &["paper", "delay-aware"][..]),
        (
            with("r_units = \"mm-mrad\"", "r_units = \"inch\""),
            "controller.r_units",
            "inch",
            &["mm-mrad", "si"],
        ),
        (
            with("interaction = \"desired\"", "interaction = \"nearest\""),
            "controller.interaction",
            "nearest",
            &["desired", "mean", "current"],
        ),
        (
            with("source = \"simulated\"", "source = \"webcam\""),
            "camera.source",
            "webcam",
            &["simulated", "external", "directory"],
        ),
        (
            with("driver = \"simulated\"", "driver = \"ros\""),
            "robot.driver",
            "ros",
            &["simulated", "external"],
        ),
        (
            with("driver = \"simulated\"", "driver = \"external\"\ncommand = \"speed\""),
            "robot.command",
            "speed",
            &["torque", "velocity", "position"],
        ),
        (with("preset = \"puma560\"", "preset = \"ur5\""), "robot.arm.preset", "ur5", &["puma560", "custom"]),
        (
            with("resume = \"command\"", "resume = \"never\""),
            "faults.resume",
            "never",
            &["command", "automatic"],
        ),
        (
            with("mode = \"dynamic\"", "mode = \"hydraulic\""),
            "plant.mode",
            "hydraulic",
            &["dynamic", "kinematic"],
        ),
        (
            with("twist_hold = \"zero-order\"", "twist_hold = \"cubic\""),
            "interpolator.twist_hold",
            "cubic",
            &["zero-order", "linear"],
        ),
        (
            with("law = \"computed-torque\"", "law = \"pid\""),
            "joint_servo.law",
            "pid",
            &["computed-torque", "pd-gravity"],
        ),
        (
            with("object_motion = \"hold\"", "object_motion = \"spin\""),
            "scenario.object_motion",
            "spin",
            &["hold", "step", "circle"],
        ),
    ];
    for (text, key, value, accepted) in cases {
        let error = refused(&text);
        assert!(matches!(error, ConfigError::Parse { .. }), "{error:?}");
        assert_eq!(error.key(), Some(key), "{error}");
        let message = error.to_string();
        assert!(message.starts_with("test.toml: ") && message.contains(key), "{message}");
        assert!(message.contains(&format!("`{value}`")), "{message:?} should show {value:?}");
        for name in accepted {
            assert!(message.contains(&format!("`{name}`")), "{message:?} should list {name:?}");
        }
    }
}

/// The supervision times and the fault times are durations, read from their keys in seconds.
#[test]
fn times_of_the_running_cell_are_durations() {
    use std::time::Duration;
    let config = Config::from_toml(
        &with("hang_timeout_s = 1.0", "hang_timeout_s = 1.25").replacen(
            "resume_after_s = 2.0",
            "resume_after_s = 0.5",
            1,
        ),
        "test.toml",
    )
    .expect("valid");
    assert_eq!(config.runtime.hang_timeout, Duration::from_millis(1250));
    assert_eq!(config.runtime.telemetry_period, Duration::from_millis(100));
    assert_eq!(config.runtime.restart_backoff_initial, Duration::from_millis(100));
    assert_eq!(config.runtime.restart_backoff_max, Duration::from_secs(5));
    assert_eq!(config.runtime.stop_timeout, Duration::from_secs(1));
    assert_eq!(config.faults.target_lost, Duration::from_secs(1));
    assert_eq!(config.faults.saturation, Duration::from_millis(500));
    assert_eq!(config.faults.resume_after, Duration::from_millis(500));
    // a hang shorter than three telemetry periods is still refused, naming its key
    let error = refused(&with("hang_timeout_s = 1.0", "hang_timeout_s = 0.2"));
    assert_eq!(error.key(), Some("runtime.hang_timeout_s"), "{error}");
}

#[test]
fn a_camera_whose_image_camera_image_cannot_carry_is_refused_naming_the_key() {
    let huge = with("width_px = 512\nheight_px = 512", "width_px = 16384\nheight_px = 16384");
    let error = refused(&huge);
    assert_eq!(error.key(), Some("camera.width_px"), "{error}");
    assert!(error.to_string().contains("1310720") && error.to_string().contains("16384"), "{error}");
    // within the bytes, whatever the shape, no size is refused (other checks may still refuse the cell)
    for fits in ["width_px = 2048\nheight_px = 640", "width_px = 1280\nheight_px = 1024"] {
        if let Err(error) = Config::from_toml(&with("width_px = 512\nheight_px = 512", fits), "test.toml") {
            let size_key = error.key().is_some_and(|k| k == "camera.width_px" || k == "camera.height_px");
            assert!(!size_key, "{fits}: {error}");
        }
    }
    // over the bytes with the width within 1280: the height is named
    let tall = with("width_px = 512\nheight_px = 512", "width_px = 1024\nheight_px = 1300");
    assert_eq!(refused(&tall).key(), Some("camera.height_px"), "{}", refused(&tall));
}

#[test]
fn the_camera_timeout_is_in_vision_periods_with_a_range() {
    let config = Config::from_toml(DEFAULT, "vservo.toml").expect("valid");
    assert_eq!(config.faults.camera_timeout_periods, 6);
    let timeout = config.faults.camera_timeout(config.cell.timing.vision_period_s);
    assert!((timeout.as_secs_f64() - 0.51).abs() < 1e-9, "{timeout:?}");
    for bad in ["1", "1001", "-3"] {
        let text = with("camera_timeout_periods = 6", &format!("camera_timeout_periods = {bad}"));
        assert_eq!(refused(&text).key(), Some("faults.camera_timeout_periods"), "{bad}");
    }
}

#[test]
fn only_regular_files_up_to_1_mib_together_are_read() {
    let dir = std::env::temp_dir().join(format!("vservo-config-files-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch");
    let refused_read = |path: &std::path::Path, why: &str| {
        let started = std::time::Instant::now();
        let error = Config::load(path).expect_err("refused");
        assert!(matches!(error, ConfigError::Read { .. }), "{error}");
        let message = error.to_string();
        assert!(message.contains(&path.display().to_string()) && message.contains(why), "{message}");
        assert!(started.elapsed() < std::time::Duration::from_secs(1), "at once");
    };
    refused_read(std::path::Path::new("/dev/zero"), "a character device");
    refused_read(&dir, "a directory");
    let fifo = dir.join("fifo.toml");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().expect("mkfifo").success());
    refused_read(&fifo, "a FIFO");
    let long = dir.join("long.toml");
    let mut text = DEFAULT.to_string();
    while text.len() as u64 <= vservo_config::MAX_CONFIG_FILE_BYTES {
        text.push_str("# padding padding padding padding padding padding padding padding\n");
    }
    std::fs::write(&long, &text).expect("written");
    refused_read(&long, "longer than 1 MiB");
    // a base that is not a regular file is refused, naming the overlay and the base
    let overlay = dir.join("overlay.toml");
    std::fs::write(&overlay, "extends = \"fifo.toml\"\n").expect("written");
    let error = Config::load(&overlay).expect_err("refused");
    assert!(matches!(error, ConfigError::Base { .. }) && error.to_string().contains("a FIFO"), "{error}");
    // a chain of files each within the bound, but over it together: refused naming the chain
    let padding = |mut text: String| {
        while (text.len() as u64) < vservo_config::MAX_CONFIG_FILE_BYTES * 6 / 10 {
            text.push_str("# padding padding padding padding padding padding padding padding\n");
        }
        text
    };
    std::fs::write(dir.join("half_base.toml"), padding(DEFAULT.to_string())).expect("written");
    let half_overlay = dir.join("half_overlay.toml");
    std::fs::write(&half_overlay, padding("extends = \"half_base.toml\"\n".to_string())).expect("written");
    let error = Config::load(&half_overlay).expect_err("refused");
    assert!(
        matches!(error, ConfigError::Read { .. })
            && error.to_string().contains("half_overlay.toml → ")
            && error.to_string().contains("together, more than the 1 MiB"),
        "{error}"
    );
    // within the bound, read as ever
    let fine = dir.join("fine.toml");
    std::fs::write(&fine, DEFAULT).expect("written");
    assert!(Config::load(&fine).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}
