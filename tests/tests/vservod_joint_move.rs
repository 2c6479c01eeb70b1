//! A joint move at full speed on the running dynamic PUMA (issue 37): planned within the drives' torque, so that
//! the simulated driver, which refuses a command beyond 1.5 times a joint's torque limit, refuses none; the arm
//! arrives at its goal. Real processes over iceoryx2.

use std::time::Duration;

use serde_json::Value;
use vservo_system_tests::{
    echo_lines, exclusive, fastest_joint_rad_s, numbers, running_daemon, status, unique, vservoctl,
    wait_until,
};

fn plant_counter(instance: &str, counter: &str) -> i64 {
    status(instance).and_then(|s| s["nodes"]["plant"][counter].as_i64()).expect("the plant's counter")
}

#[test]
fn a_far_joint_move_at_full_speed_asks_no_torque_the_plant_refuses() {
    let _one = exclusive();
    let instance = unique("full-speed-move");
    let (_config, daemon) = running_daemon(&instance);
    let refused_before = plant_counter(&instance, "rejected_messages");
    let goal = [2.6, -0.6, 0.6, -1.8, -1.6, 4.5];
    let text: Vec<String> = goal.iter().map(f64::to_string).collect();
    let (code, out) = vservoctl(&[
        "move-joints",
        "--instance",
        &instance,
        "--q",
        &text.join(","),
        "--speed-fraction",
        "1.0",
    ]);
    assert_eq!(code, Some(0), "{out}");
    let arrived = |s: &Value| s["state"] == "moving";
    assert!(
        wait_until(Duration::from_secs(20), || status(&instance).is_some_and(|s| arrived(&s))
            && fastest_joint_rad_s(&instance, "0.3") < 0.01),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    let states = echo_lines(&instance, "joint_state", "0.1");
    let q = numbers(&states.last().expect("a joint state")["q_rad"]);
    let refused = plant_counter(&instance, "rejected_messages") - refused_before;
    println!("full-speed move: the plant refused {refused} commands; at {:?}", &q[..6]);
    for j in 0..6 {
        assert!((q[j] - goal[j]).abs() < 1e-3, "joint {}: {} against the goal {}", j + 1, q[j], goal[j]);
    }
    assert_eq!(refused, 0, "commands beyond what the drives take\n{}", daemon.log());
    let now = status(&instance).expect("status");
    assert_eq!(now["safe_stops"], 0, "no safe stop on the way: {now}");
    daemon.stop();
}

/// `servo` right after a joint move at full speed, while it still runs (issue 46 reported 283–305 of the rmrc's
/// commands refused by the simulated driver, joint 1 at its torque limit): the reference goes on from the move's
/// state under its jerk limits, the simulated driver refuses none of the rmrc's commands, and the cell converges.
#[test]
fn servo_right_after_a_joint_move_asks_no_torque_the_plant_refuses() {
    let _one = exclusive();
    let instance = unique("servo-after-move");
    let (config, daemon) = running_daemon(&instance);
    let (code, scene) = vservoctl(&["scene", "--config", &config.arg()]);
    assert_eq!(code, Some(0), "{scene}");
    let scene: Value = serde_json::from_str(&scene).expect("the scene");
    let desired = numbers(&scene["desired_joints_rad"]);
    let goal: Vec<String> =
        desired.iter().enumerate().map(|(j, q)| (q + if j < 3 { 0.04 } else { -0.03 }).to_string()).collect();
    let refused_before = plant_counter(&instance, "rejected_messages");
    let (code, out) = vservoctl(&[
        "move-joints",
        "--instance",
        &instance,
        "--q",
        &goal.join(","),
        "--speed-fraction",
        "1.0",
    ]);
    assert_eq!(code, Some(0), "{out}");
    // while the move still runs
    std::thread::sleep(Duration::from_millis(100));
    let (code, out) = vservoctl(&["servo", "--instance", &instance]);
    assert_eq!(code, Some(0), "{out}");
    let converged = wait_until(Duration::from_secs(20), || {
        status(&instance).is_some_and(|s| s["feature_error_px"].as_f64().is_some_and(|e| e < 1.0))
    });
    let refused = plant_counter(&instance, "rejected_messages") - refused_before;
    println!("servo after a joint move: the plant refused {refused} commands");
    assert!(converged, "{:?}\n{}", status(&instance), daemon.log());
    assert_eq!(refused, 0, "commands beyond what the drives take\n{}", daemon.log());
    daemon.stop();
}
