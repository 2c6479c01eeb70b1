//! The robust controller (config/vservo-robust.toml) as four real-time processes: the gains with Q, R, Z_d
//! and the options cross the wire, the servo takes the camera's pose from each feature message, goes on
//! with three marks when one is covered, steers back while two are, and converges again; a pose-based law
//! acquires a target out of view; an eye-to-hand cell (the camera fixed, the board on the tool) converges.

use serde_json::Value;
use vservo_protocol::{Verdict, law_flag};
use vservo_system_tests::{echo_lines, exclusive, running, running_daemon_with, status, unique};

#[test]
fn covered_marks_do_not_stop_the_robust_servo_in_real_time() {
    let _one = exclusive();
    let instance = unique("robust");
    let (_config, daemon) = running_daemon_with(
        "config/vservo-robust.toml",
        &instance,
        &[(
            "occlusions = []",
            "occlusions = [{ mark = 2, from_s = 0.0, until_s = 4.0 }, { mark = 1, from_s = 5.0, until_s = 5.5 }, \
                 { mark = 3, from_s = 5.0, until_s = 5.5 }]",
        )],
    );
    let twists = echo_lines(&instance, "camera_twist", "8");
    let verdicts: Vec<(u64, u64)> = twists
        .iter()
        .map(|t| (t["verdict"].as_u64().unwrap_or(99), t["missing_mask"].as_u64().unwrap_or(99)))
        .collect();
    let seen = |v: Verdict, mask: u64| verdicts.contains(&(u64::from(v.code()), mask));
    assert!(seen(Verdict::ServoingOnThree, 0b0010), "mark 2 covered: {verdicts:?}\n{}", daemon.log());
    // the translation step is taken on three marks: the rmrc follows those twists, the three converge
    let on_three: Vec<f64> = twists
        .iter()
        .filter(|t| t["verdict"].as_u64() == Some(u64::from(Verdict::ServoingOnThree.code())))
        .filter_map(|t| t["feature_error_px"].as_f64())
        .collect();
    let settled_on_three = on_three.last().copied().unwrap_or(f64::NAN);
    assert!(settled_on_three < 1.0, "error on the three seen marks at the end of the cover: {on_three:?}");
    assert!(seen(Verdict::Reacquiring, 0b0101), "marks 1 and 3 covered: {verdicts:?}");
    assert!(!verdicts.iter().any(|(v, _)| *v == u64::from(Verdict::MarksMissing.code())), "{verdicts:?}");
    // converged again by the end, and never stopped for a lost target (0.5 s < target_lost_s)
    let last = twists.last().expect("twists");
    assert_eq!(last["verdict"].as_u64(), Some(u64::from(Verdict::Servoing.code())), "{last}");
    let error = last["feature_error_px"].as_f64().unwrap_or(f64::NAN);
    assert!(error < 1.0, "feature error at the end {error} px");
    // the twists say what the law did: the target's motion (none here) fed forward once its estimate
    // settled; the reacquiring twists are not the law's
    let flags = |t: &Value| t["law_flags"].as_u64().unwrap_or(u64::MAX);
    assert_ne!(flags(last) & u64::from(law_flag::FEEDFORWARD), 0, "{last}");
    assert!(
        twists
            .iter()
            .filter(|t| t["verdict"].as_u64() == Some(u64::from(Verdict::Reacquiring.code())))
            .all(|t| flags(t) == 0),
        "{twists:?}"
    );
    let state = status(&instance).expect("status");
    assert!(running(&state), "{state}");
    // one line per change, saying which marks and why
    let log = daemon.log();
    assert!(log.contains("servoing on three marks: mark 2 (not found) missing"), "{log}");
    assert!(log.contains("reacquiring: mark 1 (not found), mark 3 (not found) missing"), "{log}");
    assert!(log.contains("servoing on all four marks again"), "{log}");
    daemon.stop();
}

/// A pose-based law as four real-time processes, from a start with no mark in view: the gains carry the law
/// and its λ and caps across the wire, the servo looks towards where the target is predicted, finds it, and
/// converges below 1 px with the 2½-D law; the target is never lost for `faults.target_lost_s`.
#[test]
fn a_pose_based_law_acquires_a_target_out_of_view_and_converges_in_real_time() {
    let _one = exclusive();
    let instance = unique("pose-law");
    let (_config, daemon) = running_daemon_with(
        "config/vservo-robust.toml",
        &instance,
        &[
            ("law = \"delay-aware\"", "law = \"2.5d\""),
            (
                "initial_camera_translation_m = [0.00596, -0.03023, 0.00113]",
                "initial_camera_translation_m = [0.09, 0.0, 0.0]",
            ),
            (
                "initial_camera_rotation_deg = [0.0, 0.0, 0.0]",
                "initial_camera_rotation_deg = [0.0, 14.0, 0.0]",
            ),
        ],
    );
    let twists = echo_lines(&instance, "camera_twist", "4");
    let verdicts: Vec<u64> = twists.iter().filter_map(|t| t["verdict"].as_u64()).collect();
    let last = twists.last().expect("twists");
    assert_eq!(
        last["verdict"].as_u64(),
        Some(u64::from(Verdict::Servoing.code())),
        "{verdicts:?}\n{}",
        daemon.log()
    );
    let error = last["feature_error_px"].as_f64().unwrap_or(f64::NAN);
    assert!(error < 1.0, "feature error at the end {error} px");
    let state = status(&instance).expect("status");
    assert!(running(&state), "never stopped: {state}");
    let log = daemon.log();
    assert!(log.contains("reacquiring"), "it looked first: {log}");
    assert!(!log.contains("target_lost"), "{log}");
    daemon.stop();
}

/// An eye-to-hand cell (config/eye-to-hand.toml: the camera fixed in the world, the board on the PUMA's tool) as
/// four real-time processes: the rmrc moves the board with the opposite of the law's twist, and the cell
/// converges below 1 px from a start 10 cm and 20° off.
#[test]
fn an_eye_to_hand_cell_converges_in_real_time() {
    let _one = exclusive();
    let instance = unique("eye-to-hand");
    let (config, daemon) = running_daemon_with(
        "config/eye-to-hand.toml",
        &instance,
        &[
            (
                "initial_camera_translation_m = [0.00596, -0.03023, 0.00113]",
                "initial_camera_translation_m = [0.05, -0.04, 0.06]",
            ),
            (
                "initial_camera_rotation_deg = [0.0, 0.0, 0.0]",
                "initial_camera_rotation_deg = [6.0, -5.0, 20.0]",
            ),
        ],
    );
    let text = std::fs::read_to_string(config.arg()).expect("the configuration written");
    assert!(text.contains("mount = \"world\"") && !text.contains("tool_from_camera"), "{text}");
    let twists = echo_lines(&instance, "camera_twist", "4");
    let first = twists.first().expect("twists")["feature_error_px"].as_f64().unwrap_or(f64::NAN);
    let last = twists.last().expect("twists");
    let error = last["feature_error_px"].as_f64().unwrap_or(f64::NAN);
    assert_eq!(last["verdict"].as_u64(), Some(u64::from(Verdict::Servoing.code())), "{}", daemon.log());
    assert!(error < 1.0, "feature error at the end {error} px (at the first twist heard {first} px)");
    let state = status(&instance).expect("status");
    assert!(running(&state), "never stopped: {state}");
    daemon.stop();
}
