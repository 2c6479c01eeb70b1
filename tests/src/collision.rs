//! The collision guard's tests' shared steps (issue 47): the status's clearance, and the resume and move away
//! after a collision stop.

use std::time::Duration;

use serde_json::Value;

use crate::{TempConfig, run, status, vservoctl, wait_until};

/// The collision guard's nearest distance as the status shows it: (m, "first – second").
pub fn clearance(instance: &str) -> Option<(f64, String)> {
    let now = status(instance)?;
    Some((now["clearance"]["distance_m"].as_f64()?, now["clearance"]["between"].as_str()?.to_string()))
}

/// After the collision guard stopped the arm for `pair` ("camera – table"): `vservoctl resume` is taken and the
/// servo's motion towards it is stopped again (a second safe stop, no nearer than `stopped_m` less 2 mm); a joint
/// move out of that stop to `config`'s start joints is taken (`pair` no longer the nearest, or 9 cm apart) with no
/// stop on the way. `log` is the daemon's log, for the messages.
pub fn refused_towards_then_moved_away(
    instance: &str,
    config: &TempConfig,
    (pair, stopped_m): (&str, f64),
    log: impl Fn() -> String,
) {
    let (code, out) = vservoctl(&["resume", "--instance", instance]);
    assert_eq!(code, Some(0), "a collision stop resumes at once: {out}");
    assert!(
        wait_until(Duration::from_secs(10), || status(instance)
            .is_some_and(|s| s["safe_stops"].as_u64() == Some(2))),
        "a move towards {pair} is refused: {:?}\n{}",
        status(instance),
        log()
    );
    std::thread::sleep(Duration::from_millis(300));
    let (refused_m, _) = clearance(instance).expect("the status's clearance");
    println!("after the resume, towards: {refused_m:.4} m");
    assert!(refused_m > stopped_m - 0.002, "{refused_m} m after {stopped_m} m");
    let scene = run("vservoctl", &["scene", "--config", &config.arg()]);
    let scene: Value = serde_json::from_slice(&scene.stdout).expect("the scene is JSON");
    let start: Vec<String> =
        scene["start_joints_rad"].as_array().expect("start joints").iter().map(Value::to_string).collect();
    let q = start.join(",");
    let (code, out) = vservoctl(&[
        "move-joints",
        "--instance",
        instance,
        "--out-of-hold",
        "--q",
        &q,
        "--speed-fraction",
        "0.3",
    ]);
    assert_eq!(code, Some(0), "{out}");
    assert!(
        wait_until(Duration::from_secs(20), || clearance(instance)
            .is_some_and(|(d, between)| between != pair || d > 0.09)),
        "the move away was taken: {:?}\n{}",
        status(instance),
        log()
    );
    let now = status(instance).expect("status");
    assert_eq!(now["state"], "moving", "{now}");
    assert_eq!(now["safe_stops"], 2, "no stop on the way out: {now}");
}
