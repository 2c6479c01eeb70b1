//! The collision guard in the real-time cell (issue 47): the UR5e of config/arms/ur5e.toml, simulated, servoing
//! towards a target whose desired pose puts its camera 5 cm into a table. The rmrc slows the camera and stops it
//! short of the table; vservod latches the safe stop `collision`, the log and the status name the pair; after a
//! resume the servo's motion towards the table is refused again (another `collision` stop, the camera no nearer),
//! and a joint move away is taken. Real processes over iceoryx2.

use std::time::Duration;

use serde_json::Value;
use vservo_system_tests::{
    Daemon, config_from, exclusive, safe_stopped_by, status, unique, vservoctl, wait_until,
};

/// The UR5e's stop distance (config/arms/ur5e.toml's guard: the default).
const STOP_M: f64 = 0.03;

/// A 30 cm table whose top is 5 cm above where the UR5e's desired joints put the camera: (−0.337, −0.133,
/// 0.531) m in the base frame (`vservoctl scene --config config/arms/ur5e.toml`: the flange at the desired joints,
/// 5 cm out along it), the camera starting 25 cm above the desired pose and coming down to it.
const TABLE: &str = "name = \"floor\"\nshape = \"plane\"\n\n[[scene.obstacles]]\nname = \"table\"\nshape = \"box\"\n\
    size_m = [0.3, 0.3, 0.05]\ntranslation_m = [-0.337, -0.133, 0.556]\n";

fn clearance(instance: &str) -> Option<(f64, String)> {
    let now = status(instance)?;
    let clearance = &now["clearance"];
    Some((clearance["distance_m"].as_f64()?, clearance["between"].as_str()?.to_string()))
}

fn start_joints(config: &str) -> String {
    let (code, out) = vservoctl(&["scene", "--config", config]);
    assert_eq!(code, Some(0), "{out}");
    let scene: Value = serde_json::from_str(&out).expect("the scene is JSON");
    let q: Vec<String> =
        scene["start_joints_rad"].as_array().expect("start joints").iter().map(|v| v.to_string()).collect();
    q.join(",")
}

#[test]
fn the_ur5e_stops_short_of_a_table_and_after_a_resume_moves_away_but_not_towards_it() {
    let _one = exclusive();
    let instance = unique("collision");
    let name = format!("name = \"{instance}\"");
    let config = config_from(
        "config/arms/ur5e.toml",
        &[
            ("name = \"ur5e\"", &name),
            ("start = \"held\"", "start = \"servoing\""),
            (
                "initial_camera_translation_m = [0.00596, -0.03023, 0.00113]",
                "initial_camera_translation_m = [0.0, 0.0, -0.25]",
            ),
            ("name = \"floor\"\nshape = \"plane\"\n", TABLE),
        ],
    );
    let daemon = Daemon::start(&config);
    assert!(
        wait_until(Duration::from_secs(20), || safe_stopped_by(&instance, "collision")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    let log = daemon.log();
    assert!(
        log.lines().any(|l| l.contains("collision guard stopped the arm: camera – table")),
        "the log names the pair\n{log}"
    );
    // at rest, named, no nearer than the stop distance
    std::thread::sleep(Duration::from_millis(500));
    let (stopped_m, between) = clearance(&instance).expect("the status's clearance");
    println!("collision stop: {between} at {stopped_m:.4} m");
    assert_eq!(between, "camera – table");
    assert!(stopped_m >= STOP_M, "the camera stopped {stopped_m} m from the table");
    let (code, text) = vservoctl(&["status", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("collision") && text.contains("camera – table"), "{text}");

    // resumed: the servo still asks for the table, the guard refuses it: a new stop, no nearer
    let (code, out) = vservoctl(&["resume", "--instance", &instance]);
    assert_eq!(code, Some(0), "a collision stop resumes at once: {out}");
    assert!(
        wait_until(Duration::from_secs(5), || status(&instance)
            .is_some_and(|s| s["safe_stops"].as_u64() == Some(2))),
        "a move towards the table is refused: {:?}\n{}",
        status(&instance),
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(300));
    let (refused_m, _) = clearance(&instance).expect("the status's clearance");
    println!("after the resume, towards: {refused_m:.4} m");
    assert!(refused_m >= STOP_M && refused_m > stopped_m - 0.002, "{refused_m} m after {stopped_m} m");

    // a joint move away, out of the stop: taken
    let (code, out) = vservoctl(&[
        "move-joints",
        "--instance",
        &instance,
        "--out-of-hold",
        "--q",
        &start_joints(&config.arg()),
        "--speed-fraction",
        "0.3",
    ]);
    assert_eq!(code, Some(0), "{out}");
    assert!(
        // the camera rises from the table: the nearest pair is another (the forearm over the table at the start
        // joints) or the camera well clear
        wait_until(Duration::from_secs(15), || clearance(&instance)
            .is_some_and(|(d, between)| between != "camera – table" || d > 0.09)),
        "the move away was taken: {:?}\n{}",
        status(&instance),
        daemon.log()
    );
    let now = status(&instance).expect("status");
    assert_eq!(now["state"], "moving", "{now}");
    assert_eq!(now["safe_stops"], 2, "no stop on the way out: {now}");
    daemon.stop();
}
