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
    for plot in ["trajectory.svg", "error.svg"] {
        let svg = std::fs::read_to_string(out.join(plot)).expect("a plot");
        assert!(svg.starts_with("<svg") && svg.contains("polyline"), "{plot}");
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
    let _ = std::fs::remove_dir_all(&out);

    // a bad argument is the user's to fix
    let output = run("vservoctl", &["basin", "--config", config.to_str().expect("utf-8"), "--starts", "0"]);
    assert_eq!(output.status.code(), Some(2), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(String::from_utf8_lossy(&output.stderr).contains("--starts 0"));
}

/// Arms from their URDF in the lockstep (config/arms/: PyBullet's xArm6, and a UR5e whose URDF was written
/// from its DH parameters; kinematic simulated arms): `vservoctl sim` converges, and `vservoctl basin` on 100
/// starts converges from every counted start. Nothing but their configuration files tells them apart.
#[test]
fn urdf_arms_converge_in_the_lockstep_from_every_counted_start() {
    for arm in ["xarm6", "ur5e"] {
        let config = repository_root().join(format!("config/arms/{arm}.toml"));
        let config = config.to_str().expect("utf-8");
        let out = std::env::temp_dir().join(format!("vservo-sim-{arm}-{}", std::process::id()));
        let output = run(
            "vservoctl",
            &["sim", "--config", config, "--duration", "8", "--out", out.to_str().expect("utf-8")],
        );
        assert!(output.status.success(), "{arm}: {}", String::from_utf8_lossy(&output.stderr));
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary.json"))
                .expect("JSON");
        let _ = std::fs::remove_dir_all(&out);
        assert_eq!(summary["plant"], "kinematic");
        assert!(summary["final_error_px"].as_f64().expect("number") < 0.1, "{arm}: {summary}");

        let output = run("vservoctl", &["basin", "--config", config, "--starts", "100", "--json"]);
        assert!(output.status.success(), "{arm}: {}", String::from_utf8_lossy(&output.stderr));
        let result: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
        let classes = result["classes"].as_array().expect("classes");
        assert_eq!(classes.iter().filter_map(|c| c["starts"].as_u64()).sum::<u64>(), 100);
        assert!(classes.iter().filter_map(|c| c["counted"].as_u64()).sum::<u64>() >= 50, "{arm}: {result}");
        for class in classes {
            assert_eq!(class["converged"], class["counted"], "{arm}: {class}");
        }
    }
}
