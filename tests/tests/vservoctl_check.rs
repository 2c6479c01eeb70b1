//! `vservoctl check`, the preflight before a first motion, on held cells of real processes: a UR5e in PyBullet
//! (clients/python/pybullet_driver.py with config/arms/ur5e.urdf, its hand camera rendered by PyBullet) and a
//! ros2_control arm over DDS (clients/python/ros2_control_arm.py). The right cell passes every check; each of a
//! wrong period, a wrong joint name, a board out of view and an unreachable desired pose fails with a line that
//! says so. `vservoctl teach` makes a cell whose board stands elsewhere pass, and the servo goes back to the view taught.

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::Value;
use vservo_system_tests::{
    Daemon, ScratchDir, TempConfig, config_from, echo_lines, exclusive, pybullet_driver, repository_root,
    ros2_control_arm, run, unique, vservoctl, wait_until,
};

/// `vservoctl check --json` on `instance`: its exit code and its object.
fn check(instance: &str) -> (Option<i32>, Value) {
    let (code, out) = vservoctl(&["check", "--instance", instance, "--json", "--duration-s", "1.5"]);
    let object = out.lines().find_map(|line| serde_json::from_str::<Value>(line).ok());
    (code, object.unwrap_or_else(|| panic!("no JSON from vservoctl check: {out}")))
}

/// The scene of `config` (`vservoctl scene`), edited by `edit`, written into `dir`.
fn scene(config: &TempConfig, dir: &Path, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let out = run("vservoctl", &["scene", "--config", &config.arg()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut scene: Value = serde_json::from_slice(&out.stdout).expect("the scene is JSON");
    edit(&mut scene);
    let path = dir.join("scene.json");
    std::fs::write(&path, scene.to_string()).expect("the scene is written");
    path
}

/// Joint states come from the instance's driver.
fn states_arrive(instance: &str) -> bool {
    wait_until(Duration::from_secs(20), || {
        vservoctl(&["echo", "joint_state", "--instance", instance, "--count", "3", "--duration-s", "1"])
            .1
            .lines()
            .count()
            >= 3
    })
}

/// The UR5e cell held in PyBullet, the driver given the scene as `edit` leaves it (what the robot really is),
/// vservod the configuration (what the user believes): the check's exit code and object, after the first frames.
fn check_the_ur5e_cell(name: &str, edit: impl FnOnce(&mut Value)) -> (Option<i32>, Value) {
    check_a_ur5e_cell("config/arms/ur5e.toml", name, edit)
}

/// As [`check_the_ur5e_cell`], the UR5e's cell of `file`.
fn check_a_ur5e_cell(file: &str, name: &str, edit: impl FnOnce(&mut Value)) -> (Option<i32>, Value) {
    let instance = unique(name);
    let root = repository_root();
    let config = TempConfig::written(&format!(
        "extends = \"{}\"\n[instance]\nname = \"{instance}\"\n[timing]\npipeline_delay_frames = 0\n[camera]\n\
         source = \"external\"\n[robot]\ndriver = \"external\"\ncommand = \"velocity\"\nperiod_s = 0.002\n\
         start = \"held\"\n",
        root.join(file).display()
    ));
    let dir = ScratchDir::new(&instance);
    let scene = scene(&config, &dir.0, edit);
    let daemon = Daemon::start(&config);
    let _driver = pybullet_driver(&scene, &root.join("config/arms/ur5e.urdf"), &instance);
    assert!(states_arrive(&instance), "{}", daemon.log());
    // the first frames (a vision period is 84 ms)
    std::thread::sleep(Duration::from_secs(1));
    let result = check(&instance);
    println!("{name}: {}", result.1);
    result
}

fn verdict<'a>(check: &'a Value, name: &str) -> (&'a Value, String) {
    let entry = &check["checks"][name];
    assert!(entry["pass"].is_boolean(), "{name} in {check}");
    (entry, entry["text"].as_str().unwrap_or_default().to_string())
}

/// The right cell: every check passes, with the values it measured, and the exit code says so.
#[test]
fn the_ur5e_cell_as_configured_passes_every_check() {
    let _one = exclusive();
    let (code, check) = check_the_ur5e_cell("check-pass", |_| {});
    assert_eq!(code, Some(0), "{check}");
    assert_eq!(check["passed"], true, "{check}");
    for name in ["held", "joint_states", "joints", "kinematics", "camera", "desired_pose", "first_twist"] {
        assert_eq!(verdict(&check, name).0["pass"], true, "{name}: {check}");
    }
    let (states, _) = verdict(&check, "joint_states");
    assert!((states["median_period_ms"].as_f64().unwrap_or(0.0) - 2.0).abs() < 0.1, "{check}");
    let (kinematics, _) = verdict(&check, "kinematics");
    assert!(kinematics["board_offset_mm"].as_f64().unwrap_or(f64::INFINITY) < 5.0, "{check}");
    let (first, _) = verdict(&check, "first_twist");
    assert!(first["jerk_ratio"].as_f64().is_some_and(|r| r > 0.0 && r <= 1.0), "{check}");
}

/// The UR5e with the camera fixed under the table and the board on its flange (config/arms/ur5e-eye-to-hand.toml):
/// the right cell passes every check, the board found on the tool where [desired] puts it; the board 40 mm
/// farther out on the flange than configured fails the kinematics check, naming the mount among the causes.
#[test]
fn an_eye_to_hand_cell_passes_every_check_and_a_board_elsewhere_on_the_tool_fails_the_kinematics() {
    let _one = exclusive();
    let file = "config/arms/ur5e-eye-to-hand.toml";
    let (code, check) = check_a_ur5e_cell(file, "check-fixed", |_| {});
    assert_eq!(code, Some(0), "{check}");
    for name in ["held", "joint_states", "joints", "kinematics", "camera", "desired_pose", "first_twist"] {
        assert_eq!(verdict(&check, name).0["pass"], true, "{name}: {check}");
    }
    let (kinematics, _) = verdict(&check, "kinematics");
    assert!(kinematics["board_offset_mm"].as_f64().unwrap_or(f64::INFINITY) < 5.0, "{check}");
    assert!(kinematics["measured_tool_from_board_m"].is_array(), "{check}");
    let (code, check) = check_a_ur5e_cell(file, "check-fixed-board", |scene| {
        let z = scene["tool_from_board"][2][3].as_f64().expect("the board's offset on the tool");
        scene["tool_from_board"][2][3] = (z + 0.04).into();
    });
    assert_eq!(code, Some(1), "{check}");
    let (kinematics, text) = verdict(&check, "kinematics");
    assert_eq!(kinematics["pass"], false, "{check}");
    let offset_mm = kinematics["board_offset_mm"].as_f64().unwrap_or(0.0);
    assert!((offset_mm - 40.0).abs() < 5.0, "{check}");
    assert!(text.contains("base_from_camera"), "{text}");
}

/// The driver runs at 250 Hz where the configuration says 500 Hz.
#[test]
fn a_driver_at_another_period_fails_the_joint_state_check() {
    let _one = exclusive();
    let (code, check) =
        check_the_ur5e_cell("check-period", |scene| scene["robot"]["period_s"] = 0.004.into());
    assert_eq!(code, Some(1), "{check}");
    let (states, text) = verdict(&check, "joint_states");
    assert_eq!(states["pass"], false, "{check}");
    assert_eq!(states["declared_period_ms"].as_f64(), Some(4.0), "{check}");
    assert!(text.contains("another period than configured"), "{text}");
}

/// The board stands 3 m to the side of where it should: the camera sees no mark.
#[test]
fn a_board_out_of_view_fails_the_camera_check() {
    let _one = exclusive();
    let (code, check) = check_the_ur5e_cell("check-board", |scene| {
        let x = scene["base_from_board"][0][3].as_f64().expect("the board's x");
        scene["base_from_board"][0][3] = (x + 3.0).into();
    });
    assert_eq!(code, Some(1), "{check}");
    let (camera, text) = verdict(&check, "camera");
    assert_eq!(camera["pass"], false, "{check}");
    assert!(camera["marks_found"].as_u64().is_some_and(|n| n < 4), "{check}");
    assert!(text.contains("not (all) in view"), "{text}");
}

/// The board stands 1.5 m farther along the camera's axis (below the table) than the configuration has it: in view, but the
/// desired pose before it is out of the UR5e's reach.
#[test]
fn a_desired_pose_out_of_reach_fails_the_desired_pose_check() {
    let _one = exclusive();
    let (code, check) = check_the_ur5e_cell("check-reach", |scene| {
        // the board's own z axis points away from the camera that looks at it
        for row in 0..3 {
            let axis = scene["base_from_board"][row][2].as_f64().expect("rotation");
            let t = scene["base_from_board"][row][3].as_f64().expect("translation");
            scene["base_from_board"][row][3] = (t + 1.5 * axis).into();
        }
    });
    assert_eq!(code, Some(1), "{check}");
    assert_eq!(verdict(&check, "camera").0["pass"], true, "the board is in view: {check}");
    let (desired, text) = verdict(&check, "desired_pose");
    assert_eq!(desired["pass"], false, "{check}");
    assert_eq!(desired["reachable"], false, "{check}");
    assert!(text.starts_with("unreachable"), "{text}");
    // and the kinematics check says the board is not where it was configured
    assert_eq!(verdict(&check, "kinematics").0["pass"], false, "{check}");
}

/// `[ros2] joint_names` names a joint the ROS 2 arm does not have: the driver finds no state of the arm's, and
/// the check names the joint and the names the arm publishes.
#[test]
fn a_wrong_joint_name_fails_the_joints_check() {
    let _one = exclusive();
    let instance = unique("check-names");
    let domain = 10 + (std::process::id() * 2 + 1) % 200;
    let names = r#"joint_names = ["joint1", "joint2", "joint3", "joint4", "joint5", "wrist_3_joint"]"#;
    let config = config_from(
        "config/vservo-ros2-cell.toml",
        &[
            ("name = \"ros2-cell\"", &format!("name = \"{instance}\"")),
            ("domain_id = 0", &format!("domain_id = {domain}")),
            ("joint_names = []", names),
            ("start = \"servoing\"", "start = \"held\""),
        ],
    );
    let dir = ScratchDir::new(&instance);
    let scene = scene(&config, &dir.0, |_| {});
    let daemon = Daemon::start(&config);
    let _arm = ros2_control_arm(&scene, domain, &dir.0.join("arm.json"), &[]);
    // the arm's images come through: the cell runs, only its joint states are not the configured arm's
    assert!(
        wait_until(Duration::from_secs(20), || {
            vservoctl(&["echo", "features", "--instance", &instance, "--count", "2", "--duration-s", "1"])
                .1
                .lines()
                .count()
                >= 2
        }),
        "{}",
        daemon.log()
    );
    let (code, check) = check(&instance);
    println!("{check}");
    assert_eq!(code, Some(1), "{check}");
    let (joints, text) = verdict(&check, "joints");
    assert_eq!(joints["pass"], false, "{check}");
    assert!(text.contains("no joint \"wrist_3_joint\" (ros2.joint_names[6])"), "{text}");
    assert!(text.contains("joint6"), "the names the arm publishes: {text}");
    assert_eq!(verdict(&check, "joint_states").0["pass"], false, "{check}");
}

/// `vservoctl teach` on the held UR5e cell whose board really stands 60 mm and 10° away from where the
/// configuration says (the driver's scene moved so): the check fails its kinematics; taught with the arm still,
/// the configuration file holds the taught `[desired]` with its comments kept and the check passes 8 of 8; moved
/// away out of the hold and held again, `resume` servos back below 1 px of the taught view.
#[test]
fn a_board_elsewhere_is_taught_and_the_cell_servos_back_to_the_taught_view() {
    let _one = exclusive();
    let instance = unique("teach");
    let root = repository_root();
    let config = TempConfig::written(&format!(
        "# the user's UR5e cell: keep this comment\nextends = \"{}\"\n[instance]\nname = \"{instance}\"\n[timing]\n\
         pipeline_delay_frames = 0\n[camera]\nsource = \"external\"\n[robot]\ndriver = \"external\"\n\
         command = \"velocity\"\nperiod_s = 0.002\nstart = \"held\"  # held: teach first\n",
        root.join("config/arms/ur5e.toml").display()
    ));
    let dir = ScratchDir::new(&instance);
    let scene = scene(&config, &dir.0, |scene| {
        // 60 mm along the board's x, and turned 10° about its normal
        let (c, s) = (10f64.to_radians().cos(), 10f64.to_radians().sin());
        let at = |scene: &Value, row: usize, column: usize| {
            scene["base_from_board"][row][column].as_f64().expect("a pose")
        };
        for row in 0..3 {
            let (x, y, t) = (at(scene, row, 0), at(scene, row, 1), at(scene, row, 3));
            scene["base_from_board"][row][0] = (c * x + s * y).into();
            scene["base_from_board"][row][1] = (-s * x + c * y).into();
            scene["base_from_board"][row][3] = (t + 0.06 * x).into();
        }
    });
    let daemon = Daemon::start(&config);
    let _driver = pybullet_driver(&scene, &root.join("config/arms/ur5e.urdf"), &instance);
    assert!(states_arrive(&instance), "{}", daemon.log());
    std::thread::sleep(Duration::from_secs(1));
    let (code, before) = check(&instance);
    assert_eq!(code, Some(1), "{before}");
    let (kinematics, _) = verdict(&before, "kinematics");
    assert!(kinematics["board_offset_mm"].as_f64().is_some_and(|mm| mm > 50.0), "{before}");

    let (code, out) = vservoctl(&["teach", "--config", &config.arg(), "--json"]);
    assert_eq!(code, Some(0), "{out}\n{}", daemon.log());
    let taught: Value = out.lines().find_map(|l| serde_json::from_str(l).ok()).expect("teach's JSON");
    println!("taught: {taught}");
    assert_eq!(taught["reload"]["accepted"], true, "{taught}");
    assert!(taught["fit_px"].as_f64().is_some_and(|px| px < 1.0), "{taught}");
    // the running goal is the taught view
    let in_force = taught["reload"]["target_features_px"].as_array().expect("the goal in force");
    let taught_view = taught["target_features_px"].as_array().expect("ξ_d");
    for (a, b) in in_force.iter().zip(taught_view) {
        assert!((a.as_f64().unwrap_or(f64::NAN) - b.as_f64().unwrap_or(f64::NAN)).abs() < 1e-3, "{taught}");
    }
    let text = std::fs::read_to_string(&config.path).expect("the configuration");
    assert!(
        text.contains("# the user's UR5e cell: keep this comment") && text.contains("# held: teach first"),
        "{text}"
    );
    let written = vservo_config::Config::load(&config.path).expect("the taught file loads");
    let joints: Vec<f64> =
        taught["joints_rad"].as_array().expect("joints").iter().filter_map(Value::as_f64).collect();
    for (file, now) in written.cell.desired.joints.iter().zip(&joints) {
        assert!(
            (file - now).abs() < 1e-8,
            "the file's desired joints {:?}, taught {joints:?}",
            written.cell.desired.joints
        );
    }
    let (code, after) = check(&instance);
    assert_eq!(code, Some(0), "{after}");
    for name in ["held", "joint_states", "joints", "kinematics", "camera", "desired_pose", "first_twist"] {
        assert_eq!(verdict(&after, name).0["pass"], true, "{name}: {after}");
    }

    // away from the taught pose, out of the hold; held again; resumed
    let away: Vec<String> =
        joints.iter().zip([0.02, -0.02, 0.02, 0.03, 0.02, 0.04]).map(|(q, d)| format!("{}", q + d)).collect();
    let (code, out) =
        vservoctl(&["move-joints", "--instance", &instance, "--out-of-hold", "--q", &away.join(",")]);
    assert_eq!(code, Some(0), "{out}");
    let arrived = wait_until(Duration::from_secs(30), || {
        let state = echo_lines(&instance, "joint_state", "0.2").pop().unwrap_or_default();
        let q: Vec<f64> = state["q_rad"]
            .as_array()
            .map(|a| a.iter().filter_map(Value::as_f64).collect())
            .unwrap_or_default();
        q.len() >= 6
            && away.iter().zip(&q).all(|(goal, q)| (goal.parse::<f64>().unwrap_or(f64::NAN) - q).abs() < 2e-3)
    });
    assert!(arrived, "the arm never reached the pose away\n{}", daemon.log());
    let error_now = || {
        echo_lines(&instance, "camera_twist", "0.5").iter().rev().find_map(|t| t["feature_error_px"].as_f64())
    };
    let start_error = error_now().unwrap_or(f64::NAN);
    for command in ["safe-stop", "servo", "resume"] {
        let (code, out) = vservoctl(&[command, "--instance", &instance]);
        println!("{command}: {out} ({:?} px)", error_now());
        assert_eq!(code, Some(0), "{command}: {out}\n{}", daemon.log());
    }
    let converged = wait_until(Duration::from_secs(30), || error_now().is_some_and(|px| px < 1.0));
    println!("resumed {start_error:.1} px from the taught view; converged: {converged}");
    assert!(start_error > 5.0, "the premise: moved away from the taught view ({start_error} px)");
    assert!(converged, "not below 1 px of the taught view\n{}", daemon.log());
    daemon.stop();
}
