//! The ROS 2 bridge (`vservo-ros2`, started by vservod with config/vservo-ros2.toml) against a real DDS: a
//! Cyclone DDS participant that follows ROS 2's conventions on the wire (tests/python/check_ros2_graph.py,
//! clients/python/ros2_types.py) hears every topic with ROS 2's type names and vservo's content, and its
//! calls are answered: `safe_stop` always; `resume` and the targets (`vservo_msgs/SetTargetFeatures`,
//! `SetTargetPose`) only where the configuration lets the ROS graph move the arm, checked by the daemon.
//!
//! Each test runs its instance on a ROS domain of its own (the tests of one CI run share the network).

use std::process::Command;
use std::time::Duration;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion};
use serde_json::Value;
use vservo_system_tests::{
    Daemon, TwoHosts, config_from, echo_lines, exclusive, numbers, repository_root, running, status, unique,
    wait_until,
};

/// A ROS domain no other test of this run uses (the process id picks it; 0 is left to users).
fn domain(offset: u32) -> u32 {
    10 + (std::process::id() * 2 + offset) % 200
}

/// config/vservo-ros2.toml under its own instance and domain, `allow_motion` and the interface as given.
fn daemon(
    name: &str,
    domain_id: u32,
    allow_motion: bool,
    interface: &str,
) -> (String, vservo_system_tests::TempConfig, Daemon) {
    daemon_in(name, domain_id, allow_motion, interface, None)
}

/// [`daemon`], in a network namespace if given.
fn daemon_in(
    name: &str,
    domain_id: u32,
    allow_motion: bool,
    interface: &str,
    netns: Option<&str>,
) -> (String, vservo_system_tests::TempConfig, Daemon) {
    let instance = unique(name);
    let config = config_from(
        "config/vservo-ros2.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("domain_id = 0", &format!("domain_id = {domain_id}")),
            ("allow_motion = false", &format!("allow_motion = {allow_motion}")),
            ("interface = \"\"", &format!("interface = \"{interface}\"")),
        ],
    );
    let daemon = match netns {
        Some(netns) => Daemon::start_in(&config, netns),
        None => Daemon::start(&config),
    };
    assert!(
        wait_until(Duration::from_secs(15), || status(&instance).is_some_and(|s| running(&s))),
        "{}",
        daemon.log()
    );
    (instance, config, daemon)
}

/// A run of the Cyclone DDS peer: it sends malformed requests to the `malformed` services, calls the `before`
/// services (a safe stop holds the arm, so what it hears after is of an arm at rest), listens for 3 s, calls
/// the `after` services, and prints what it got. With `address`, Cyclone DDS uses that one interface only
/// (unicast discovery of this machine's participants when it is the loopback, which carries no multicast);
/// with `netns`, it runs in that network namespace.
#[derive(Default)]
struct Peer<'a> {
    before: &'a [&'a str],
    after: &'a [&'a str],
    malformed: &'a [&'a str],
    address: Option<&'a str>,
    netns: Option<&'a str>,
}

impl Peer<'_> {
    fn run(&self, domain_id: u32) -> Value {
        let Peer { before, after, malformed, address, netns } = *self;
        let interpreter = repository_root().join("target/python-venv/bin/python");
        let mut command = match netns {
            Some(netns) => {
                let mut command = Command::new("ip");
                command.args(["netns", "exec", netns]).arg(&interpreter);
                command
            }
            None => Command::new(&interpreter),
        };
        if let Some(address) = address {
            let multicast = if address.starts_with("127.") { "false" } else { "true" };
            command.env(
                "CYCLONEDDS_URI",
                format!(
                    "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface address=\"{address}\"/>\
                     </Interfaces><AllowMulticast>{multicast}</AllowMulticast></General><Discovery>\
                     <ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>\
                     <Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>"
                ),
            );
        }
        command.arg(repository_root().join("tests/python/check_ros2_graph.py")).args([
            "--domain",
            &domain_id.to_string(),
            "--seconds",
            "3",
        ]);
        for service in before {
            command.args(["--before", service]);
        }
        for service in after {
            command.args(["--after", service]);
        }
        for service in malformed {
            command.args(["--malformed", service]);
        }
        let out = command.output().expect("the Cyclone DDS peer runs (scripts/setup.sh installs cyclonedds)");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).expect("the peer prints one JSON object")
    }
}

fn pose(translation: &[f64], rotation_xyzw: &[f64]) -> Isometry3<f64> {
    let q = nalgebra::Quaternion::new(rotation_xyzw[3], rotation_xyzw[0], rotation_xyzw[1], rotation_xyzw[2]);
    Isometry3::from_parts(
        Translation3::new(translation[0], translation[1], translation[2]),
        UnitQuaternion::from_quaternion(q),
    )
}

/// The 3 × 4 row-major top of a transform, as vservo's messages carry it.
fn pose_of_rows(m: &[f64]) -> Isometry3<f64> {
    let rotation = Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
    Isometry3::from_parts(
        Translation3::new(m[3], m[7], m[11]),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&rotation)),
    )
}

fn tf_pose(tf: &Value, parent: &str, child: &str) -> Isometry3<f64> {
    let t = &tf[format!("{parent}->{child}")];
    assert!(t.is_object(), "tf has no {parent} -> {child}: {tf}");
    pose(&numbers(&t["translation"]), &numbers(&t["rotation_xyzw"]))
}

/// The pose of the last of `frames` in the first, composed along `tf`.
fn chained(tf: &Value, frames: &[&str]) -> Isometry3<f64> {
    frames.windows(2).fold(Isometry3::identity(), |pose, pair| pose * tf_pose(tf, pair[0], pair[1]))
}

fn close(a: &[f64], b: &[f64], tolerance: f64) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tolerance)
}

#[test]
fn a_ros2_node_hears_the_cell_and_its_safe_stop_is_taken() {
    let _one = exclusive();
    let domain_id = domain(0);
    let (instance, _config, daemon) = daemon("ros2", domain_id, false, "");
    // the peer on the machine's outside interface, as another host's node would be (the loopback test's
    // control: unbound, the bridge is heard there)
    let outside = outside_address().expect("this machine has a network interface besides the loopback");
    let target = "vservo/set_target_features=160.5,167.5,327.5,177.5,348.5,74.5,181.5,69.5";
    let heard = Peer {
        before: &["vservo/safe_stop"],
        after: &["vservo/resume", target],
        address: Some(&outside),
        ..Peer::default()
    }
    .run(domain_id);

    // the services: a safe stop always, a resume refused (allow_motion = false), each with its reason
    let calls = heard["calls"].as_array().expect("calls");
    assert_eq!(calls[0]["answered"], true, "{heard}");
    assert_eq!(calls[0]["success"], true, "{}", calls[0]);
    assert_eq!(calls[1]["answered"], true, "{heard}");
    assert_eq!(calls[1]["success"], false, "{}", calls[1]);
    assert!(calls[1]["message"].as_str().is_some_and(|m| m.contains("allow_motion")), "{}", calls[1]);
    assert_eq!((&calls[2]["answered"], &calls[2]["success"]), (&Value::Bool(true), &Value::Bool(false)));
    assert!(calls[2]["message"].as_str().is_some_and(|m| m.contains("allow_motion")), "{}", calls[2]);
    let now = status(&instance).expect("status");
    assert_eq!(now["state"], "safe-stop", "{now}");
    assert_eq!(now["fault"]["name"], "requested", "{now}");

    // every topic, under ROS 2's type names (a reader of another type name hears nothing)
    let counts = &heard["counts"];
    for topic in ["joint_states", "tf", "camera/image_raw", "camera/camera_info", "vservo/features"] {
        assert!(counts[topic].as_u64().unwrap_or(0) > 0, "nothing on {topic}: {heard}");
    }
    for topic in ["vservo/camera_twist", "diagnostics"] {
        assert!(counts[topic].as_u64().unwrap_or(0) > 0, "nothing on {topic}: {counts}");
    }
    // and a subscriber of ROS's default profile (reliable) hears every topic as well
    let reliable = &heard["reliable_counts"];
    for topic in
        ["joint_states", "tf", "camera/image_raw", "camera/camera_info", "vservo/features", "diagnostics"]
    {
        assert!(
            reliable[topic].as_u64().unwrap_or(0) > 0,
            "a reliable reader heard nothing on {topic}: {reliable}"
        );
    }
    // the bridge is a ROS 2 node of the graph (`ros2 node list`: ros_discovery_info)
    assert!(
        heard["ros_nodes"].as_array().is_some_and(|n| n.contains(&Value::from("/vservo"))),
        "{}",
        heard["ros_nodes"]
    );
    // joint_states at the configured 100 Hz over 3 s (best effort: allow a loaded machine to lose some)
    assert!(counts["joint_states"].as_u64().unwrap_or(0) >= 150, "{counts}");

    // the joints: the arm held at rest, as vservo's own joint state says
    let newest = &heard["newest"];
    let joints = &newest["joint_states"];
    let names: Vec<&str> =
        joints["name"].as_array().expect("names").iter().filter_map(Value::as_str).collect();
    assert_eq!(names, ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]);
    let state = echo_lines(&instance, "joint_state", "0.3").pop().expect("a joint state");
    let q = &numbers(&state["q_rad"])[..6];
    assert!(close(&numbers(&joints["position"]), q, 1e-6), "ROS {joints} vs vservo {q:?}");
    let wall_s = heard["wall_s"].as_f64().expect("wall");
    let stamp_s = joints["stamp_s"].as_f64().expect("stamp");
    assert!(
        (wall_s - 5.0..=wall_s).contains(&stamp_s),
        "joint_states stamped {stamp_s}, peer's clock {wall_s}"
    );

    // tf: the chain base → link1 … link6 (the DH arm's names) and, on /tf_static, the camera's optical frame on
    // the tool is the camera's pose vservo's vision node reports, and the target seen from the camera is the
    // simulated board, both from vservo's own messages
    let tf = &heard["tf"];
    let frames = ["base", "link1", "link2", "link3", "link4", "link5", "link6"];
    let base_from_camera =
        chained(tf, &frames) * tf_pose(&heard["tf_static"], "link6", "camera_optical_frame");
    let features = echo_lines(&instance, "features", "0.3").pop().expect("features");
    let reported = pose_of_rows(&numbers(&features["base_from_camera"]));
    assert!((base_from_camera.translation.vector - reported.translation.vector).norm() < 1e-6);
    assert!(base_from_camera.rotation.angle_to(&reported.rotation) < 1e-6);
    let world = echo_lines(&instance, "sim_world", "0.3").pop().expect("sim_world");
    let camera_from_board = reported.inverse() * pose_of_rows(&numbers(&world["base_from_board"]));
    let seen = tf_pose(tf, "camera_optical_frame", "target");
    let error_m = (seen.translation.vector - camera_from_board.translation.vector).norm();
    assert!(error_m < 0.005, "the target seen {seen} vs the board {camera_from_board}: {error_m} m");

    // the camera: its images and their camera info (OpenCV's pixel centres: the principal point ½ px less)
    let image = &newest["camera/image_raw"];
    assert_eq!((image["width"].as_u64(), image["height"].as_u64()), (Some(512), Some(512)), "{image}");
    assert_eq!((image["encoding"].as_str(), image["step"].as_u64()), (Some("mono8"), Some(512)));
    assert_eq!(image["bytes"].as_u64(), Some(512 * 512));
    assert!(image["distinct_values"].as_u64().unwrap_or(0) > 16, "a blank image: {image}");
    assert_eq!(image["frame_id"], "camera_optical_frame");
    let info = &newest["camera/camera_info"];
    assert_eq!(info["distortion_model"], "plumb_bob");
    assert_eq!(numbers(&info["k"]), [500.0, 0.0, 255.5, 0.0, 500.0, 255.5, 0.0, 0.0, 1.0]);
    assert_eq!(numbers(&info["d"]), [0.0; 5]);

    // the twist of a held cell is zero; the features are the four marks', in OpenCV's pixels
    let twist = &newest["vservo/camera_twist"];
    assert_eq!(twist["frame_id"], "camera_optical_frame");
    assert!(
        numbers(&twist["linear"]).iter().chain(&numbers(&twist["angular"])).all(|v| *v == 0.0),
        "{twist}"
    );
    let features_ros = numbers(&newest["vservo/features"]["data"]);
    let features_vservo = numbers(&features["features_px"]);
    let in_opencv_px: Vec<f64> = features_vservo.iter().map(|v| v - 0.5).collect();
    assert!(close(&features_ros, &in_opencv_px, 0.05), "{features_ros:?} vs {features_vservo:?}");

    // diagnostics: the cell in a safe stop (an error), each node, and the bridge's count of the refusal
    let diagnostics = newest["diagnostics"]["status"].as_array().expect("diagnostics");
    let named = |suffix: &str| {
        diagnostics
            .iter()
            .find(|s| s["name"].as_str().is_some_and(|n| n == format!("vservo/{instance}: {suffix}")))
            .unwrap_or_else(|| panic!("no diagnostics of {suffix}: {diagnostics:?}"))
    };
    let cell = named("cell");
    assert_eq!(cell["level"], 2, "{cell}");
    assert_eq!(cell["values"]["fault"], "requested", "{cell}");
    for node in ["plant", "vision", "servo", "rmrc"] {
        assert_eq!(named(node)["values"]["state"], "running");
    }
    assert_eq!(named("ros2 bridge")["values"]["allow_motion"], "false");
    daemon.stop();
}

#[test]
fn resume_over_ros2_only_where_the_configuration_allows_it() {
    let _one = exclusive();
    let domain_id = domain(1);
    let (instance, _config, daemon) = daemon("ros2-resume", domain_id, true, "");
    let after = [
        "vservo/resume",
        // ξ_d in ROS's pixels (vservo's less ½): taken, checked and acknowledged by the daemon
        "vservo/set_target_features=160.5,167.5,327.5,177.5,348.5,74.5,181.5,69.5",
        "vservo/set_target_features=nan,167.5,327.5,177.5,348.5,74.5,181.5,69.5",
        // a pose: 0.45 m in front, turned 0.1 rad about the optical axis (qz = sin 0.05, qw = cos 0.05)
        "vservo/set_target_pose=0,0,0.45,0,0,0.04997916927067833,0.9987502603949663",
        "vservo/set_target_pose=0,0,0.45,0,0,0,0",
    ];
    let heard = Peer { before: &["vservo/safe_stop"], after: &after, ..Peer::default() }.run(domain_id);
    let calls = heard["calls"].as_array().expect("calls");
    assert!(calls.iter().all(|c| c["answered"] == true), "{heard}");
    assert!(calls[..3].iter().all(|c| c["success"] == true), "{heard}");
    assert_eq!(calls[2]["gains_version"], 2, "{}", calls[2]);
    assert_eq!(
        numbers(&calls[2]["target_features_px"]),
        [160.5, 167.5, 327.5, 177.5, 348.5, 74.5, 181.5, 69.5],
        "{}",
        calls[2]
    );
    assert_eq!(calls[3]["success"], false, "{}", calls[3]);
    assert!(calls[3]["message"].as_str().is_some_and(|m| m.contains("finite")), "{}", calls[3]);
    assert_eq!((&calls[4]["success"], &calls[4]["gains_version"]), (&Value::Bool(true), &Value::from(3)));
    assert_eq!(calls[5]["success"], false, "{}", calls[5]);
    assert!(calls[5]["message"].as_str().is_some_and(|m| m.contains("unit quaternion")), "{}", calls[5]);
    assert!(
        wait_until(Duration::from_secs(3), || status(&instance).is_some_and(|s| running(&s))),
        "{:?}",
        status(&instance)
    );
    // the servo runs the pose's target: ξ_d of a board 0.45 m away, turned about the axis, in vservo's pixels
    let gains = echo_lines(&instance, "gains", "0.5").pop().expect("gains");
    assert_eq!(gains["version"], 3, "{gains}");
    let pose_features = numbers(&gains["desired_features_px"]);
    let replied: Vec<f64> = numbers(&calls[4]["target_features_px"]).iter().map(|v| v + 0.5).collect();
    assert!(close(&pose_features, &replied, 1e-9), "{pose_features:?} vs the reply's {replied:?}");
    // the paper's camera and board (config/vservo.toml), the board at 0.45 m turned 0.1 rad about the axis
    let camera = vservo_scene::CameraIntrinsics::paper();
    let camera_from_board = nalgebra::IsometryMatrix3::from_parts(
        Translation3::new(0.0, 0.0, 0.45),
        Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), 0.1),
    );
    let expected: Vec<f64> = vservo_scene::Board::paper()
        .marks_in_board
        .iter()
        .flat_map(|mark| {
            let p = camera.project(&(camera_from_board * mark)).expect("in front");
            [p.x, p.y]
        })
        .collect();
    assert!(close(&pose_features, &expected, 1e-6), "{pose_features:?} vs {expected:?}");
    daemon.stop();
}

/// This machine's first IPv4 address that is not the loopback's (`ip -j -4 addr`).
fn outside_address() -> Option<String> {
    let out = Command::new("ip").args(["-j", "-4", "addr"]).output().ok()?;
    let interfaces: Value = serde_json::from_slice(&out.stdout).ok()?;
    interfaces
        .as_array()?
        .iter()
        .flat_map(|i| i["addr_info"].as_array().cloned().unwrap_or_default())
        .find_map(|a| a["local"].as_str().filter(|ip| !ip.starts_with("127.")).map(str::to_string))
}

#[test]
fn bound_to_the_loopback_the_bridge_is_heard_on_this_machine_only() {
    let _one = exclusive();
    let domain_id = domain(2);
    let outside = outside_address().expect("this machine has a network interface besides the loopback");
    let (instance, _config, daemon) = daemon("ros2-lo", domain_id, false, "127.0.0.1");
    // malformed requests are refused and counted, and change nothing
    let refused = Peer { malformed: &["vservo/safe_stop"], address: Some("127.0.0.1"), ..Peer::default() }
        .run(domain_id);
    assert_eq!(refused["calls"][0]["matched"], true, "{refused}");
    let diagnostics = refused["newest"]["diagnostics"]["status"].as_array().cloned().unwrap_or_default();
    let bridge = diagnostics
        .iter()
        .find(|s| s["name"].as_str().is_some_and(|n| n.ends_with("ros2 bridge")))
        .unwrap_or_else(|| panic!("no bridge diagnostics: {refused}"));
    let bad: u64 = bridge["values"]["requests_bad"].as_str().and_then(|v| v.parse().ok()).unwrap_or(0);
    assert!((1..=3).contains(&bad), "three malformed requests sent: {bridge}");
    assert_eq!(bridge["level"], 1, "a refused request is a warning: {bridge}");
    assert!(status(&instance).is_some_and(|s| running(&s)), "a malformed request changed the cell");
    // on the loopback: the cell is heard and a safe stop taken
    let here =
        Peer { after: &["vservo/safe_stop"], address: Some("127.0.0.1"), ..Peer::default() }.run(domain_id);
    assert!(here["counts"]["joint_states"].as_u64().unwrap_or(0) > 0, "{here}");
    assert_eq!(here["calls"][0]["success"], true, "{here}");
    // on the machine's other interface, where another host would be: nothing, and no request reaches it
    let there =
        Peer { after: &["vservo/safe_stop"], address: Some(&outside), ..Peer::default() }.run(domain_id);
    let heard: u64 = there["counts"].as_object().expect("counts").values().filter_map(Value::as_u64).sum();
    assert_eq!(heard, 0, "heard on {outside}: {there}");
    assert_eq!(there["calls"][0]["answered"], false, "{there}");
    daemon.stop();
}

#[test]
fn across_two_hosts_the_cell_is_heard_and_stopped_on_the_cells_network() {
    let _one = exclusive();
    // vservod on one host, a ROS 2 node on the other, joined by their own network (two network namespaces)
    let hosts =
        TwoHosts::new().expect("two network namespaces joined by a veth pair (the tests run as root)");
    let domain_id = domain(3);
    let (instance, _config, daemon) =
        daemon_in("ros2-hosts", domain_id, false, &hosts.addresses[0], Some(&hosts.names[0]));
    let heard = Peer {
        before: &["vservo/safe_stop"],
        address: Some(&hosts.addresses[1]),
        netns: Some(&hosts.names[1]),
        ..Peer::default()
    }
    .run(domain_id);
    let counts = &heard["counts"];
    for topic in ["joint_states", "tf", "camera/image_raw", "camera/camera_info", "diagnostics"] {
        assert!(counts[topic].as_u64().unwrap_or(0) > 0, "nothing on {topic} from the other host: {heard}");
    }
    assert_eq!(heard["calls"][0]["success"], true, "{heard}");
    let now = status(&instance).expect("status");
    assert_eq!(now["fault"]["name"], "requested", "{now}");
    daemon.stop();
}

/// The bridge only observes: the ROS 2 driver, which owns the arm, is another program (`vservo-ros2-driver`), and
/// the bridge's old `--driver` is refused with where the driver went (exit 2), before it opens anything.
#[test]
fn the_bridge_is_not_the_driver_and_says_where_the_driver_is() {
    let out = vservo_system_tests::run("vservo-ros2", &["--driver", "--config", "/nonexistent.toml"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("vservo-ros2-driver --config FILE"), "{stderr}");
    assert!(!stderr.contains("nonexistent"), "refused before the configuration is read: {stderr}");
    let help = vservo_system_tests::run("vservo-ros2-driver", &["--help"]);
    assert!(help.status.success() && String::from_utf8_lossy(&help.stdout).contains("driver"));
}

/// A URDF arm (the Panda of config/arms/panda.toml) in ROS's own names: `joint_states` under the URDF's joint names
/// and `tf` the URDF's links (panda_link0 → … → panda_link7), `/tf_static` the flange on the last link and the
/// camera's optical frame on the flange (read as tf2's static listener reads it, after it was sent); composed,
/// the camera's pose vservo reports. A reliable and a best-effort reader each hear the joint states, the image and
/// the camera info. The collision guard's floor is on `vservo/obstacles` (read after it was sent, as RViz reads a
/// latched marker topic): a thin square under the base link, with its name.
#[test]
fn a_urdf_arm_is_in_ros_under_its_urdfs_names() {
    let _one = exclusive();
    let domain_id = domain(1);
    let instance = unique("ros2-panda");
    let panda = repository_root().join("config/arms/panda.toml");
    let config = vservo_system_tests::TempConfig::written(&format!(
        "extends = \"{}\"\n\n[instance]\nname = \"{instance}\"\n\n[ros2]\nenabled = true\ndomain_id = {domain_id}\n",
        panda.display()
    ));
    let daemon = Daemon::start(&config);
    assert!(
        wait_until(Duration::from_secs(20), || status(&instance).is_some_and(|s| running(&s))),
        "{}",
        daemon.log()
    );
    // held (a safe stop), so that what the peer hears and what vservo reports after are of an arm at rest
    let heard = Peer { before: &["vservo/safe_stop"], ..Peer::default() }.run(domain_id);
    for topic in ["joint_states", "camera/image_raw", "camera/camera_info"] {
        assert!(
            heard["counts"][topic].as_u64().unwrap_or(0) > 0,
            "best effort heard nothing on {topic}: {heard}"
        );
        assert!(
            heard["reliable_counts"][topic].as_u64().unwrap_or(0) > 0,
            "reliable heard nothing on {topic}"
        );
    }
    let joints = &heard["newest"]["joint_states"];
    let names: Vec<&str> =
        joints["name"].as_array().expect("names").iter().filter_map(Value::as_str).collect();
    assert_eq!(names, (1..=7).map(|j| format!("panda_joint{j}")).collect::<Vec<_>>(), "{joints}");
    let links: Vec<String> = (0..=7).map(|l| format!("panda_link{l}")).collect();
    let links: Vec<&str> = links.iter().map(String::as_str).collect();
    let fixed = &heard["tf_static"];
    let base_from_camera = chained(&heard["tf"], &links)
        * chained(fixed, &["panda_link7", "panda_link8", "camera_optical_frame"]);
    let features = echo_lines(&instance, "features", "0.3").pop().expect("features");
    let reported = pose_of_rows(&numbers(&features["base_from_camera"]));
    assert!((base_from_camera.translation.vector - reported.translation.vector).norm() < 1e-6, "{heard}");
    assert!(base_from_camera.rotation.angle_to(&reported.rotation) < 1e-6);
    assert_eq!(heard["newest"]["camera/image_raw"]["frame_id"], "camera_optical_frame");
    assert_the_floor_is_a_marker(&heard["obstacles"]);
    daemon.stop();
}

/// config/arms/panda.toml's floor (a plane at z = 0) among the markers: cleared first, then a 3 m square 2 mm thick
/// whose top face is the plane, and its name, in the base link's frame.
fn assert_the_floor_is_a_marker(markers: &Value) {
    let markers = markers.as_array().unwrap_or_else(|| panic!("no markers heard: {markers}"));
    assert_eq!(
        markers.first().map(|m| m["action"].clone()),
        Some(Value::from(3)),
        "DELETEALL first: {markers:?}"
    );
    let floor: Vec<&Value> = markers.iter().filter(|m| m["ns"] == "floor").collect();
    assert_eq!(floor.len(), 2, "a square and a name: {markers:?}");
    let (square, name) = (floor[0], floor[1]);
    assert_eq!((square["type"].as_i64(), square["frame_id"].as_str()), (Some(1), Some("panda_link0")));
    assert_eq!(numbers(&square["scale"]), [3.0, 3.0, 0.002]);
    assert!((numbers(&square["position"])[2] + 0.001).abs() < 1e-12, "{square}");
    assert_eq!((name["type"].as_i64(), name["text"].as_str()), (Some(9), Some("floor")));
}

/// `[ros2.qos.<topic>]` is what the bridge offers: the image written best effort is heard by a best-effort reader
/// and not by a reliable one (DDS does not match a reliable reader with a best-effort writer), while the camera
/// info beside it keeps the default and is heard by both.
#[test]
fn a_topics_qos_as_written_is_what_readers_are_offered() {
    let _one = exclusive();
    let domain_id = domain(2);
    let instance = unique("ros2-qos");
    let config = vservo_system_tests::TempConfig::written(&format!(
        "extends = \"{}\"\n\n[instance]\nname = \"{instance}\"\n\n[ros2]\nenabled = true\ndomain_id = {domain_id}\n\n\
         [ros2.qos.image]\nreliability = \"best_effort\"\ndepth = 1\n",
        repository_root().join("config/vservo.toml").display()
    ));
    let daemon = Daemon::start(&config);
    assert!(
        wait_until(Duration::from_secs(20), || status(&instance).is_some_and(|s| running(&s))),
        "{}",
        daemon.log()
    );
    let heard = Peer::default().run(domain_id);
    let count = |reader: &str, topic: &str| heard[reader][topic].as_u64().unwrap_or(0);
    assert!(count("counts", "camera/image_raw") > 0, "best effort heard no image: {heard}");
    assert_eq!(
        count("reliable_counts", "camera/image_raw"),
        0,
        "a reliable reader matched a best-effort image"
    );
    assert!(count("counts", "camera/camera_info") > 0 && count("reliable_counts", "camera/camera_info") > 0);
    daemon.stop();
}
