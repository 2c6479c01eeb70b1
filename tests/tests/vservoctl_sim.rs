//! `vservoctl sim` as a user runs it: it writes the summary, the data and the plots.

use std::process::Command;
use std::time::Duration;

use vservo_system_tests::{binary, repository_root, run, wait_until};

#[test]
fn sim_writes_summary_csvs_and_plots() {
    let out = std::env::temp_dir().join(format!("vservo-sim-{}", std::process::id()));
    let config = repository_root().join("config/scenarios/translation-step.toml");
    let output = run(
        "vservoctl",
        &[
            "sim",
            "--config",
            config.to_str().expect("utf-8"),
            "--duration",
            "3",
            "--controller",
            "delay-aware",
            "--plant",
            "kinematic",
            "--out",
            out.to_str().expect("utf-8"),
        ],
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary.json"))
            .expect("JSON");
    assert_eq!(summary["law"], "delay-aware");
    assert_eq!(summary["plant"], "kinematic");
    for key in ["settling_time_s", "overshoot_percent", "final_error_px"] {
        assert!(summary[key].as_f64().is_some(), "{key}: {summary}");
    }
    assert!(summary["final_error_px"].as_f64().expect("number") < 0.5);
    let features = std::fs::read_to_string(out.join("features.csv")).expect("features.csv");
    let header = features.lines().next().expect("a header");
    assert!(header.starts_with("t,x1,y1,x2,y2,x3,y3,x4,y4,true_x1,true_y1,"), "{header}");
    assert_eq!(header.split(',').count(), 17);
    // one row per 85 ms frame over 3 s
    assert_eq!(features.lines().count(), 1 + 36);
    let joints = std::fs::read_to_string(out.join("joints.csv")).expect("joints.csv");
    assert_eq!(joints.lines().count(), 1 + 300, "every 10 ms");
    // each plot with its axes' units, a legend of what it draws, and the law in its title
    let plots = [
        ("trajectory.svg", "[px]", "point 1"),
        ("error.svg", "[px]", "point 4"),
        ("joints.svg", "[rad]", "joint 6"),
        ("twist.svg", "[m/s]", "ωz"),
    ];
    for (plot, units, legend) in plots {
        let svg = std::fs::read_to_string(out.join(plot)).expect("a plot");
        assert!(svg.starts_with("<svg") && svg.contains("polyline"), "{plot}");
        assert!(svg.contains(units) && svg.contains(legend), "{plot}: units and legend");
        assert!(svg.contains("law delay-aware, Q = "), "{plot}: the law and its weights in the title");
    }
    let _ = std::fs::remove_dir_all(out);
    // overrides are checked
    let output = run("vservoctl", &["sim", "--config", config.to_str().expect("utf-8"), "--duration", "-1"]);
    assert_eq!(output.status.code(), Some(2));
}

/// A progress bar (indicatif) on a terminal only: in a tmux pane the bar shows while the scenario runs; with
/// stderr in a pipe (a script, a log) there is none.
#[test]
fn sim_shows_progress_on_a_terminal_only() {
    let config = repository_root().join("config/scenarios/translation-step.toml");
    let out = std::env::temp_dir().join(format!("vservo-sim-progress-{}", std::process::id()));
    let args = |seconds: &str| {
        format!(
            "sim --config {} --duration {seconds} --plant kinematic --out {}",
            config.display(),
            out.display()
        )
    };
    let piped = run("vservoctl", &args("3").split(' ').collect::<Vec<_>>());
    assert!(piped.status.success());
    let stderr = String::from_utf8_lossy(&piped.stderr);
    assert!(!stderr.contains("simulating"), "no bar in a pipe: {stderr}");

    let session = vservo_system_tests::TmuxSession(format!("sim-progress-{}", std::process::id()));
    let command = format!("{} {}; echo sim-exit=$?; sleep 60", binary("vservoctl").display(), args("120"));
    let started = Command::new("tmux")
        .args(["new-session", "-d", "-s", &session.0, "-x", "150", "-y", "10", &command])
        .status()
        .expect("tmux runs");
    assert!(started.success());
    let mut seen_bar = false;
    let done = wait_until(Duration::from_secs(120), || {
        let screen = session.capture();
        seen_bar |= screen.contains("simulating") && screen.contains("of 120.0 s");
        screen.contains("sim-exit=")
    });
    let screen = session.capture();
    assert!(done && screen.contains("sim-exit=0"), "{screen}");
    assert!(seen_bar, "a progress bar while it ran: {screen}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn basin_reports_each_class_as_json_and_draws_the_starts() {
    let out = std::env::temp_dir().join(format!("vservo-basin-{}", std::process::id()));
    let config = repository_root().join("config/vservo-robust.toml");
    let output = run(
        "vservoctl",
        &[
            "basin",
            "--config",
            config.to_str().expect("utf-8"),
            "--starts",
            "8",
            "--seed",
            "3",
            "--json",
            "--out",
            out.to_str().expect("utf-8"),
        ],
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let result: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
    let classes = result["classes"].as_array().expect("classes");
    let names: Vec<&str> = classes.iter().filter_map(|c| c["class"].as_str()).collect();
    assert_eq!(names, ["small", "medium", "large", "roll"]);
    assert_eq!(classes.iter().filter_map(|c| c["starts"].as_u64()).sum::<u64>(), 8);
    // the robust controller: every counted start converges, none lets a mark leave the image
    for class in classes {
        assert_eq!(class["converged"], class["counted"], "{class}");
        assert_eq!(class["marks_left_image"], 0, "{class}");
    }
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("basin.json")).expect("basin.json"))
            .expect("JSON");
    assert_eq!(written["runs"].as_array().expect("runs").len(), 8);
    let svg = std::fs::read_to_string(out.join("basin.svg")).expect("basin.svg");
    assert!(
        svg.starts_with("<svg") && svg.matches("<circle").count() >= 8,
        "{} circles",
        svg.matches("<circle").count()
    );
    // the legend says what each colour is, with the count of each outcome
    assert!(svg.contains("converged (") && svg.contains("translation [cm]"), "basin.svg: legend and units");
    let _ = std::fs::remove_dir_all(&out);

    // a bad argument is the user's to fix
    let output = run("vservoctl", &["basin", "--config", config.to_str().expect("utf-8"), "--starts", "0"]);
    assert_eq!(output.status.code(), Some(2), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(String::from_utf8_lossy(&output.stderr).contains("--starts 0"));
}

/// Arms from their URDF in the lockstep (config/arms/: PyBullet's xArm6, Panda and KUKA iiwa, the last two of
/// seven joints, and a UR5e whose URDF was written from its DH parameters; kinematic simulated arms, each at its
/// own period): `vservoctl sim` converges, and `vservoctl basin` on 100
/// starts converges from every counted start. Nothing but their configuration files tells them apart.
#[test]
fn urdf_arms_converge_in_the_lockstep_from_every_counted_start() {
    for arm in ["xarm6", "ur5e", "panda", "iiwa"] {
        let config = repository_root().join(format!("config/arms/{arm}.toml"));
        let config = config.to_str().expect("utf-8");
        let (summary, joints) = sim_for_8_s(config);
        assert_eq!(summary["plant"], "kinematic");
        assert!(summary["final_error_px"].as_f64().expect("number") < 0.1, "{arm}: {summary}");
        // a column per joint of the arm
        let seven = arm == "panda" || arm == "iiwa";
        assert_eq!(joints.lines().next().is_some_and(|header| header.contains(",q7,")), seven, "{arm}");

        let output = run("vservoctl", &["basin", "--config", config, "--starts", "100", "--json"]);
        assert!(output.status.success(), "{arm}: {}", String::from_utf8_lossy(&output.stderr));
        let result: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
        let classes = result["classes"].as_array().expect("classes");
        assert_eq!(classes.iter().filter_map(|c| c["starts"].as_u64()).sum::<u64>(), 100);
        assert!(classes.iter().filter_map(|c| c["counted"].as_u64()).sum::<u64>() >= 50, "{arm}: {result}");
        for class in classes {
            assert_eq!(class["converged"], class["counted"], "{arm}: {class}");
        }
        // only the PUMA 560 has a dynamics model: asking for it is refused, naming the configuration
        let output = run("vservoctl", &["sim", "--config", config, "--plant", "dynamic", "--duration", "1"]);
        assert_eq!(output.status.code(), Some(2), "{arm}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains("--plant dynamic") && stderr.contains(config), "{arm}: {stderr}");
    }
}

/// The case in the whole lockstep: the Panda (seven joints) with its desired pose 0.047 rad inside
/// panda_joint1's upper limit, so that it starts within 0.1 rad of it. The camera converges, and the null-space
/// task turns the joint away from the limit (farther by more than 0.1 rad at the end, never closer than at
/// the start); with the task off (limit_gain = 0) the joint stays near the limit, which shows the task did it.
#[test]
fn a_seven_joint_arm_started_near_a_joint_limit_converges_while_the_null_space_moves_the_joint_away() {
    let scratch = std::env::temp_dir().join(format!("vservo-panda-limit-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).expect("a scratch directory");
    let panda = repository_root().join("config/arms/panda.toml");
    let run_with = |name: &str, limit_gain: f64| -> (serde_json::Value, Vec<f64>) {
        let config = scratch.join(format!("{name}.toml"));
        std::fs::write(
            &config,
            format!(
                "extends = {:?}\n[desired]\njoints_rad = [2.85, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\n\
                 [interpolator.null_space]\nlimit_gain = {limit_gain:?}\n",
                panda.display()
            ),
        )
        .expect("written");
        let (summary, joints) = sim_for_8_s(config.to_str().expect("utf-8"));
        let q1: Vec<f64> = joints
            .lines()
            .skip(1)
            .map(|line| line.split(',').nth(1).and_then(|v| v.parse().ok()).expect("q1"))
            .collect();
        (summary, q1)
    };
    // the limit as vservo has it for the Panda (config/arms/panda.toml: Franka's documented range)
    let model = run(
        "vservoctl",
        &[
            "model",
            "--config",
            panda.to_str().expect("utf-8"),
            "--q",
            "0,-0.785,0,-2.356,0,1.571,0.785",
            "--json",
        ],
    );
    assert!(model.status.success(), "{}", String::from_utf8_lossy(&model.stderr));
    let model: serde_json::Value = serde_json::from_slice(&model.stdout).expect("JSON");
    assert_eq!(model["joints"][0]["name"], "panda_joint1");
    let upper = model["joints"][0]["range_rad"][1].as_f64().expect("the upper limit");

    let (summary, q1) = run_with("with-task", 2.0);
    let (summary_off, q1_off) = run_with("without-task", 0.0);
    let _ = std::fs::remove_dir_all(&scratch);
    let margin = |q: f64| upper - q;
    let start = margin(q1[0]);
    assert!(
        start > 0.0 && start < 0.1,
        "the premise: joint 1 starts within 0.1 rad of its limit ({start} rad)"
    );
    assert!(summary["final_error_px"].as_f64().expect("number") < 0.1, "the camera converges: {summary}");
    assert_eq!(summary["faults"]["position_limit"], 0, "{summary}");
    let end = margin(*q1.last().expect("samples"));
    let closest = q1.iter().map(|&q| margin(q)).fold(f64::INFINITY, f64::min);
    assert!(end > start + 0.1, "joint 1 turned away from its limit: {start} → {end} rad");
    assert!(closest >= start - 1e-3, "joint 1 never came closer than it started: {closest} rad");
    // the contrast: without the task the camera converges too, and the joint stays by its limit
    assert!(summary_off["final_error_px"].as_f64().expect("number") < 0.1, "{summary_off}");
    let end_off = margin(*q1_off.last().expect("samples"));
    eprintln!(
        "joint 1's margin to its limit: start {start:.4} rad, closest {closest:.4}, end {end:.4} (without the task \
         {end_off:.4}); final error {} px",
        summary["final_error_px"]
    );
    assert!(
        end_off < start + 0.05,
        "without the null-space task joint 1 stays near its limit: {end_off} rad"
    );
}

/// `vservoctl sim --config CONFIG --duration 8`: its summary.json and joints.csv (the output directory removed).
fn sim_for_8_s(config: &str) -> (serde_json::Value, String) {
    let out = std::env::temp_dir().join(format!(
        "vservo-sim-{}-{}",
        std::process::id(),
        std::path::Path::new(config).file_stem().and_then(|s| s.to_str()).unwrap_or("config")
    ));
    let output = run(
        "vservoctl",
        &["sim", "--config", config, "--duration", "8", "--out", out.to_str().expect("utf-8")],
    );
    assert!(output.status.success(), "{config}: {}", String::from_utf8_lossy(&output.stderr));
    let summary = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    let joints = std::fs::read_to_string(out.join("joints.csv")).expect("joints.csv");
    let _ = std::fs::remove_dir_all(&out);
    (serde_json::from_str(&summary).expect("JSON"), joints)
}
