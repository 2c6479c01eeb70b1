//! `vservoctl record --ros2`: a recording of the running cell with ROS 2's message schemas and CDR, read by
//! the Python `rosbags` library (tests/python/check_ros2_recording.py) both with the types the file defines
//! and with rosbags' own ROS 2 Jazzy types: every topic of the bridge, the joint states the cell's own, the
//! camera's images whole, the collision guard's obstacle as markers.

use std::process::Command;
use std::time::Duration;

use serde_json::Value;
use vservo_system_tests::{
    echo_lines, exclusive, numbers, repository_root, run, running_daemon_with, safe_stopped_by, unique,
    wait_until,
};

/// The default cell with a table in its scene (the built-in PUMA has no collision shapes: the guard never acts).
const TABLE: &str = "[collision]\n\n[[scene.obstacles]]\nname = \"table\"\nshape = \"box\"\n\
                     size_m = [0.6, 0.6, 0.04]\ntranslation_m = [0.8, 0.0, 0.2]\n\n[ros2]\n";

#[test]
fn rosbags_reads_the_joint_states_and_images_of_a_ros2_recording() {
    let _one = exclusive();
    let instance = unique("record-ros2");
    let (_config, daemon) = running_daemon_with("config/vservo.toml", &instance, &[("[ros2]\n", TABLE)]);
    // held at rest, the arm's joints are known: what vservo's own joint state says
    let out = run("vservoctl", &["safe-stop", "--instance", &instance]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(wait_until(Duration::from_secs(3), || safe_stopped_by(&instance, "requested")));
    std::thread::sleep(Duration::from_secs(1));
    let directory = std::env::temp_dir().join(format!("vservo-record-ros2-{}", std::process::id()));
    std::fs::create_dir_all(&directory).expect("a temporary directory");
    let file = directory.join("cell.mcap");
    let out = run(
        "vservoctl",
        &[
            "record",
            "--ros2",
            "--instance",
            &instance,
            "--out",
            &file.display().to_string(),
            "--duration-s",
            "2",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let held = numbers(&echo_lines(&instance, "joint_state", "0.3").pop().expect("a joint state")["q_rad"]);
    daemon.stop();

    let check = Command::new(repository_root().join("target/python-venv/bin/python"))
        .arg(repository_root().join("tests/python/check_ros2_recording.py"))
        .arg(&file)
        .output()
        .expect("python runs");
    let _ = std::fs::remove_dir_all(&directory);
    assert!(check.status.success(), "{}", String::from_utf8_lossy(&check.stderr));
    let read: Value = serde_json::from_slice(&check.stdout).expect("one JSON object");

    assert_eq!(read["readings_agree"], true, "the file's own types and rosbags' Jazzy types differ: {read}");
    let topics = &read["topics"];
    for (topic, message_type) in [
        ("/joint_states", "sensor_msgs/msg/JointState"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/camera/image_raw", "sensor_msgs/msg/Image"),
        ("/camera/camera_info", "sensor_msgs/msg/CameraInfo"),
        ("/vservo/features", "std_msgs/msg/Float64MultiArray"),
        ("/vservo/camera_twist", "geometry_msgs/msg/TwistStamped"),
        ("/vservo/obstacles", "visualization_msgs/msg/MarkerArray"),
    ] {
        assert_eq!(topics[topic]["type"], message_type, "{topics}");
        assert!(topics[topic]["count"].as_u64().unwrap_or(0) > 0, "nothing on {topic}: {topics}");
    }
    // 2 s at [ros2] joint_state_rate_hz = 100 (the recorder looks every 2 ms: some are taken together)
    let joints = &read["joint_states"];
    assert!(joints["count"].as_u64().unwrap_or(0) >= 100, "{joints}");
    assert_eq!(joints["stamps_increase"], true);
    let last = &joints["last"];
    assert_eq!(last["name"], serde_json::json!(["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]));
    let recorded = numbers(&last["position"]);
    assert!(
        recorded.iter().zip(&held).all(|(r, h)| (r - h).abs() < 1e-6) && recorded.len() == 6,
        "recorded {recorded:?}, held at {held:?}"
    );
    // stamped with the measurement on the system clock: at most a moment before the recorder logged it
    let lag_s = last["log_s"].as_f64().expect("log") - last["stamp_s"].as_f64().expect("stamp");
    assert!((0.0..1.0).contains(&lag_s), "logged {lag_s} s after its stamp");
    let image = &read["image"];
    assert_eq!(image["width"], 512);
    assert_eq!(image["height"], 512);
    assert_eq!(image["encoding"], "mono8");
    assert_eq!(image["bytes"], 512 * 512);
    assert!(image["distinct_values"].as_u64().unwrap_or(0) > 16, "{image}");
    // the table, once: cleared first, then its box and its name
    let markers = &read["obstacles"];
    assert_eq!(
        markers,
        &serde_json::json!([
            {"ns": "", "type": 0, "action": 3, "scale": [0.0, 0.0, 0.0]},
            {"ns": "table", "type": 1, "action": 0, "scale": [0.6, 0.6, 0.04]},
            {"ns": "table", "type": 9, "action": 0, "scale": [0.0, 0.0, 0.05]},
        ]),
        "{read}"
    );
}
