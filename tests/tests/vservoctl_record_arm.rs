//! The arm drawn is the arm configured: a recording of a cell with a custom DH arm (a UR5's published table,
//! driven by an external velocity driver of the test's own) shows that arm's links, checked with numpy
//! against the DH table's forward kinematics; and of a cell with an arm from its URDF (PyBullet's xArm6),
//! checked against PyBullet's.

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use vservo_protocol::{CommandMode, JointStateMsg, Topic};
use vservo_system_tests::{
    Daemon, LoopThread, binary, config_from, exclusive, repository_root, status, unique, wait_until,
};

/// A UR5's standard-DH table: [a (m), α (rad), d (m), θ offset (rad)] per joint.
const UR5_DH: [[f64; 4]; 6] = [
    [0.0, std::f64::consts::FRAC_PI_2, 0.089159, 0.0],
    [-0.425, 0.0, 0.0, 0.0],
    [-0.39225, 0.0, 0.0, 0.0],
    [0.0, std::f64::consts::FRAC_PI_2, 0.10915, 0.0],
    [0.0, -std::f64::consts::FRAC_PI_2, 0.09465, 0.0],
    [0.0, 0.0, 0.0823, 0.0],
];
const START_RAD: [f64; 6] = [0.0, -1.2, 1.5, -0.3, 1.57, 0.0];

/// A robot driver of `start.len()` joints that ignores commands and sweeps the joints slowly around `start`
/// (1 kHz), until dropped.
fn sweeping_driver(instance: &str, start: &[f64]) -> LoopThread {
    let instance = instance.to_string();
    let start = start.to_vec();
    LoopThread::spawn(move |stop| {
        let dir = vservo_protocol::InstanceDir::locate_waiting(&instance, Duration::from_secs(10))
            .expect("the instance");
        let node = vservo_protocol::create_node_in(&dir, "sweeping-driver").expect("a node");
        let states = vservo_protocol::publisher::<JointStateMsg>(&node, &instance, Topic::JointState)
            .expect("joint_state");
        let notifier = vservo_protocol::notifier(&node, &instance, Topic::JointState).expect("event");
        let started = Instant::now();
        let mut tick = 0u64;
        while !stop.load(Ordering::Relaxed) {
            tick += 1;
            std::thread::sleep(
                (started + Duration::from_millis(tick)).saturating_duration_since(Instant::now()),
            );
            let t = started.elapsed().as_secs_f64();
            // the arm's joints; the slots past them zero
            let q_rad = std::array::from_fn(|j| start.get(j).map_or(0.0, |q| q + 0.2 * (t + j as f64).sin()));
            let _ = states.send_copy(JointStateMsg {
                tick,
                stamp_ns: vservo_time::monotonic_ns(),
                driver_epoch: u64::from(std::process::id()),
                period_ns: 1_000_000,
                command_mode: CommandMode::Velocity.into(),
                joint_count: start.len() as u32,
                q_rad,
                torque_nm: [f64::NAN; vservo_protocol::MAX_JOINTS],
                ..JointStateMsg::default()
            });
            let _ = notifier.notify();
        }
    })
}

#[test]
fn a_recording_of_a_custom_dh_arm_draws_that_arm() {
    let _one = exclusive();
    let instance = unique("record-arm");
    let dh = serde_json::to_string(&UR5_DH).expect("JSON");
    let custom_arm = format!(
        "preset = \"custom\"\ndh = {dh}\n\
         joint_limits_rad = [[-6.28, 6.28], [-6.28, 6.28], [-3.1, 3.1], [-6.28, 6.28], [-6.28, 6.28], [-6.28, 6.28]]\n\
         velocity_limits_rad_s = [3.0, 3.0, 3.0, 3.0, 3.0, 3.2]\n\
         acceleration_limits_rad_s2 = [5.0, 5.0, 5.0, 5.0, 5.0, 5.0]"
    );
    let start = format!("joints_rad = {}", serde_json::to_string(&START_RAD).expect("JSON"));
    let config = config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("source = \"simulated\"", "source = \"external\""),
            ("driver = \"simulated\"", "driver = \"external\"\ncommand = \"velocity\"\nspeed_scale = 1.0"),
            ("preset = \"puma560\"", &custom_arm),
            (
                "joints_rad = [0.0, 0.7853981633974483, -3.141592653589793, 0.0, 0.7853981633974483, 0.0]",
                &start,
            ),
        ],
    );
    let file = record_swept_arm(&config, &instance, &START_RAD);
    let check = |arm: &str| check_drawing(&file, &instance, arm);
    let checked = check(&dh);
    // the check tells arms apart: the same recording is not a UR5 whose shoulder sits 1 cm higher
    let mut other = UR5_DH;
    other[0][2] += 0.01;
    let refused = check(&serde_json::to_string(&other).expect("JSON"));
    let _ = std::fs::remove_file(&file);
    assert!(checked.status.success(), "{}", String::from_utf8_lossy(&checked.stderr));
    assert!(!refused.status.success(), "another arm's table passed the check");
    let figures: serde_json::Value = serde_json::from_slice(&checked.stdout).expect("JSON figures");
    eprintln!("arm drawing: {figures}");
    assert!(figures["transforms_checked"].as_u64() >= Some(20), "{figures}");
    assert_eq!(figures["camera_on"], serde_json::json!(["link6"]), "{figures}");
}

/// The xArm6 from its URDF (config/arms/xarm6.toml), swept by the test's driver: the links drawn are where
/// PyBullet puts them, and the check tells the tool link from the one before it.
#[test]
fn a_recording_of_an_arm_from_its_urdf_draws_that_arm() {
    let start = [0.0, -0.443, -1.048, 0.0, 1.491, 0.0];
    draws_the_urdf_arm("xarm6", &start, "xarm/xarm6_robot.urdf", ("link6", "link5"), "link6");
}

/// The seven-joint Panda from its URDF (config/arms/panda.toml), swept by the test's driver: seven links drawn
/// where PyBullet puts them, the camera on the seventh.
#[test]
fn a_recording_of_a_seven_joint_arm_draws_its_seven_links() {
    let start = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
    draws_the_urdf_arm("panda", &start, "franka_panda/panda.urdf", ("panda_link8", "panda_link7"), "link7");
}

/// Records config/arms/`arm`.toml's arm swept around `start` by the test's driver, and checks the drawing
/// against PyBullet's forward kinematics of `urdf` (in pybullet_data): right with the configured tip link, wrong
/// with the one before it; the camera drawn on `camera_link`.
fn draws_the_urdf_arm(
    arm: &str,
    start: &[f64],
    urdf: &str,
    (tip, before_tip): (&str, &str),
    camera_link: &str,
) {
    let _one = exclusive();
    let instance = unique(&format!("record-{arm}"));
    let config = config_from(
        &format!("config/arms/{arm}.toml"),
        &[
            (&format!("name = \"{arm}\""), &format!("name = \"{instance}\"")),
            ("source = \"simulated\"", "source = \"external\""),
            ("driver = \"simulated\"", "driver = \"external\"\ncommand = \"velocity\"\nspeed_scale = 1.0"),
        ],
    );
    let file = record_swept_arm(&config, &instance, start);
    let urdf = repository_root().join("target/pybullet_data").join(urdf);
    let check = |tip: &str| check_drawing(&file, &instance, &format!("urdf={}#{tip}", urdf.display()));
    let checked = check(tip);
    let refused = check(before_tip);
    let _ = std::fs::remove_file(&file);
    assert!(checked.status.success(), "{arm}: {}", String::from_utf8_lossy(&checked.stderr));
    assert!(!refused.status.success(), "{arm}: another tool link passed the check");
    let figures: serde_json::Value = serde_json::from_slice(&checked.stdout).expect("JSON figures");
    eprintln!("{arm} drawing: {figures}");
    assert!(figures["transforms_checked"].as_u64() >= Some(20), "{figures}");
    assert_eq!(figures["camera_on"], serde_json::json!([camera_link]), "{figures}");
}

/// Runs the daemon on `config` with the sweeping driver and records 1.5 s of it: the recording's path.
fn record_swept_arm(
    config: &vservo_system_tests::TempConfig,
    instance: &str,
    start: &[f64],
) -> std::path::PathBuf {
    let daemon = Daemon::start(config);
    let _driver = sweeping_driver(instance, start);
    assert!(
        wait_until(Duration::from_secs(10), || status(instance).is_some_and(|s| s["robot"] == "running")),
        "{:?}\n{}",
        status(instance),
        daemon.log()
    );
    // found by its name only: the recorder reads the arm from the configuration the daemon runs
    let file = config.path.with_extension("mcap");
    let recorded = std::process::Command::new(binary("vservoctl"))
        .args(["record", "--out", &file.display().to_string(), "--duration-s", "1.5", "--instance", instance])
        .output()
        .expect("vservoctl record runs");
    assert!(recorded.status.success(), "{}", String::from_utf8_lossy(&recorded.stderr));
    daemon.stop();
    file
}

/// tests/python/check_arm_drawing.py on a recording, for `arm` (a DH table as JSON, or `urdf=PATH#TIP`).
fn check_drawing(file: &std::path::Path, instance: &str, arm: &str) -> std::process::Output {
    std::process::Command::new(repository_root().join("target/python-venv/bin/python"))
        .arg(repository_root().join("tests/python/check_arm_drawing.py"))
        .arg(file)
        .arg(instance)
        .arg(arm)
        .output()
        .expect("python runs")
}
