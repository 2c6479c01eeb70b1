//! The collision guard in the real-time cell (issue 47): the UR5e of config/arms/ur5e.toml, simulated, servoing
//! towards a target whose desired pose puts its camera 5 cm into a table. The rmrc slows the camera and stops it
//! short of the table; vservod latches the safe stop `collision`, the log and the status name the pair; after a
//! resume the servo's motion towards the table is refused again (another `collision` stop, the camera no nearer),
//! and a joint move away is taken. Real processes over iceoryx2.

use std::time::Duration;

use vservo_system_tests::{
    Daemon, clearance, config_from, exclusive, refused_towards_then_moved_away, safe_stopped_by, status,
    unique, vservoctl, wait_until,
};

/// The UR5e's stop distance (config/arms/ur5e.toml's guard: the default).
const STOP_M: f64 = 0.03;

/// A 30 cm table whose top is 5 cm above where the UR5e's desired joints put the camera: (−0.337, −0.133,
/// 0.531) m in the base frame (`vservoctl scene --config config/arms/ur5e.toml`: the flange at the desired joints,
/// 5 cm out along it), the camera starting 25 cm above the desired pose and coming down to it.
const TABLE: &str = "name = \"floor\"\nshape = \"plane\"\n\n[[scene.obstacles]]\nname = \"table\"\nshape = \"box\"\n\
    size_m = [0.3, 0.3, 0.05]\ntranslation_m = [-0.337, -0.133, 0.556]\n";

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

    // resumed: the servo still asks for the table, the guard refuses it; a joint move away is taken
    refused_towards_then_moved_away(&instance, &config, ("camera – table", stopped_m), || daemon.log());
    assert!(clearance(&instance).is_some_and(|(d, _)| d >= STOP_M));
    daemon.stop();
}
