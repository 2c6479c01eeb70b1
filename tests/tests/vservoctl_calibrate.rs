//! `vservoctl calibrate` on the simulated cell of config/calibration-demo.toml, whose camera really is
//! another than the configuration believes (`[camera.truth]`: the mount 5 mm and 2° off, the focal lengths 2 %
//! longer, the lens and principal point off), with image noise σ = 2 grey levels and 12 poses: the recovered
//! calibration against that truth (the bars) in lockstep and through a running vservod (with a safe
//! stop and a resume on the way), the file it writes read back as `camera.calibration_file`, the detected
//! corners against the true projections, and the refusals before anything moves. The eye-to-hand cell
//! (config/eye-to-hand-calibration.toml, the camera fixed 5 mm and 2° from the belief) in lockstep and through
//! vservod.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde_json::Value;
use vservo_system_tests::{
    Daemon, Killed, assert_calibration_within_the_bars, binary, config_from, echo_lines, exclusive,
    fastest_joint_rad_s, repository_root, run, running, running_daemon_of, safe_stopped_by, status, unique,
    vservoctl, wait_until,
};

const DEMO: &str = "config/calibration-demo.toml";

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vservo-calibrate-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    dir
}

fn python() -> String {
    repository_root().join("target/python-venv/bin/python").display().to_string()
}

/// `vservoctl calibrate --lockstep` as docs/CALIBRATION.md writes it: without `--python`, the solver's Python found
/// by vservoctl itself (the project's environment beside it).
fn calibrate(config: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    let out = out.display().to_string();
    let mut args = vec!["calibrate", "--config", config, "--lockstep", "--json", "--out", &out];
    args.extend_from_slice(extra);
    run("vservoctl", &args)
}

/// The cell runs again and servoes below 1 px within 10 s.
fn servoes_below_one_pixel(instance: &str) -> bool {
    wait_until(Duration::from_secs(10), || {
        status(instance)
            .is_some_and(|s| running(&s) && s["feature_error_px"].as_f64().is_some_and(|e| e < 1.0))
    })
}

fn last_line_json(stdout: &[u8]) -> Value {
    let text = String::from_utf8_lossy(stdout);
    serde_json::from_str(text.lines().last().expect("a line")).expect("the last line is JSON")
}

fn number(value: &Value, path: &[&str]) -> f64 {
    path.iter().fold(value, |v, key| &v[*key]).as_f64().unwrap_or_else(|| panic!("{path:?} in {value}"))
}

#[test]
fn the_demo_cell_is_calibrated_within_the_bars_and_its_file_reads_back() {
    let dir = scratch("demo");
    let out = dir.join("calibration.yaml");
    let demo = repository_root().join(DEMO).display().to_string();
    let output = calibrate(&demo, &out, &[]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report = last_line_json(&output.stdout);
    eprintln!("{report}");
    assert_calibration_within_the_bars(&report);

    // the detected corners are where the true camera images the board's corners, in vservo's pixels: OpenCV's
    // projection of the truth moved by half a pixel (a mix-up of the conventions is a 0.5 px mean offset)
    let report_file = dir.join("report.json");
    std::fs::write(&report_file, report.to_string()).expect("written");
    let checked = std::process::Command::new(python())
        .arg(repository_root().join("tests/python/check_calibration_corners.py"))
        .args([dir.join("calibration-views"), report_file])
        .output()
        .expect("python runs");
    assert!(checked.status.success(), "{}", String::from_utf8_lossy(&checked.stderr));
    eprintln!("corners against the truth: {}", String::from_utf8_lossy(&checked.stdout));

    // the file, read as a calibration file, gives what was solved (the principal point through OpenCV's
    // pixels and back)
    let extended = dir.join("calibrated.toml");
    std::fs::write(
        &extended,
        format!("extends = {demo:?}\n[camera]\ncalibration_file = {:?}\n", out.display().to_string()),
    )
    .expect("written");
    let config = vservo_config::Config::load(&extended).expect("the calibrated configuration loads");
    let close = |a: f64, b: f64| (a - b).abs() < 1e-6 * b.abs().max(1.0);
    assert!(close(config.cell.camera.fx_px(), number(&report, &["fx"])), "{}", config.cell.camera.fx_px());
    assert!(close(config.cell.camera.fy_px(), number(&report, &["fy"])));
    assert!(close(config.cell.camera.principal_point_px().x, number(&report, &["cx"])));
    assert!(close(config.cell.camera.principal_point_px().y, number(&report, &["cy"])));
    assert!(close(config.cell.camera.distortion().coefficients()[0], number(&report, &["k1"])));
    let translation = config.cell.tool_from_camera.translation.vector;
    for (axis, value) in translation.iter().enumerate() {
        let solved = report["tool_from_camera"]["translation_m"][axis].as_f64().expect("a number");
        assert!((value - solved).abs() < 1e-9, "axis {axis}: {value} against {solved}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An eye-to-hand cell (config/eye-to-hand-calibration.toml: the demo's camera fixed in the world, 5 mm and 2° from
/// where the configuration believes it, the board on the tool): the fixed camera's pose in the base is recovered
/// within the hand camera's bars (1 mm, 0.2°; the lens as closely), and the file, read as the configuration's
/// calibration file, puts the camera where it was solved.
#[test]
fn an_eye_to_hand_cell_is_calibrated_within_the_bars_and_its_file_reads_back() {
    let dir = scratch("eye-to-hand");
    let out = dir.join("calibration.yaml");
    let cell = repository_root().join("config/eye-to-hand-calibration.toml").display().to_string();
    let output = calibrate(&cell, &out, &[]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report = last_line_json(&output.stdout);
    eprintln!("{report}");
    assert_eq!(report["changes"]["mount"], "base_from_camera", "{report}");
    assert_calibration_within_the_bars(&report);
    assert!(report["tool_from_camera"].is_null() && report["tool_from_board"].is_object(), "{report}");
    let text = std::fs::read_to_string(&out).expect("the calibration file");
    assert!(
        text.contains("base_from_camera: !!opencv-matrix") && !text.contains("tool_from_camera"),
        "{text}"
    );

    let extended = dir.join("calibrated.toml");
    std::fs::write(
        &extended,
        format!("extends = {cell:?}\n[camera]\ncalibration_file = {:?}\n", out.display().to_string()),
    )
    .expect("written");
    let config = vservo_config::Config::load(&extended).expect("the calibrated configuration loads");
    let fixed = config.cell.fixed_camera.expect("a fixed camera");
    for (axis, value) in fixed.base_from_camera.translation.vector.iter().enumerate() {
        let solved = report["base_from_camera"]["translation_m"][axis].as_f64().expect("a number");
        assert!((value - solved).abs() < 1e-9, "axis {axis}: {value} against {solved}");
    }
    // a hand camera's configuration refuses the fixed camera's file, naming it
    let hand = dir.join("hand.toml");
    let demo = repository_root().join(DEMO).display().to_string();
    std::fs::write(
        &hand,
        format!("extends = {demo:?}\n[camera]\ncalibration_file = {:?}\n", out.display().to_string()),
    )
    .expect("written");
    let refused = vservo_config::Config::load(&hand).expect_err("a hand camera with a fixed camera's file");
    assert!(refused.to_string().contains("base_from_camera"), "{refused}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--apply` in lockstep: the configuration file reads the calibration file (its lens keys replaced, the file as
/// it was kept beside it), loads with the solved camera, and a second calibration from it starts from a camera
/// within the bars of the truth (the first started 5 mm and 2° off).
#[test]
fn apply_makes_the_configuration_read_the_calibration() {
    let dir = scratch("apply");
    let out = dir.join("calibration.yaml");
    let config = config_from(DEMO, &[]);
    let before = std::fs::read_to_string(&config.path).expect("the configuration");
    let output = calibrate(&config.arg(), &out, &["--apply"]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report = last_line_json(&output.stdout);
    assert_eq!(report["applied"]["config"].as_str(), Some(config.arg().as_str()), "{report}");
    let kept = PathBuf::from(report["applied"]["kept"].as_str().expect("where the old file is"));
    assert_eq!(std::fs::read_to_string(&kept).expect("kept"), before);
    // the report says what changed: the configuration's focal length before, the solution's after
    assert_eq!(number(&report, &["changes", "fx_px", "before"]), 600.0, "{report}");
    assert_eq!(number(&report, &["changes", "fx_px", "after"]), number(&report, &["fx"]));
    assert!(number(&report, &["changes", "tool_from_camera", "moved_mm"]) > 4.0, "{report}");

    let applied = vservo_config::Config::load(&config.path).expect("the applied configuration loads");
    let close = |a: f64, b: f64| (a - b).abs() < 1e-6 * b.abs().max(1.0);
    assert!(close(applied.cell.camera.fx_px(), number(&report, &["fx"])), "{}", applied.cell.camera.fx_px());
    assert!(close(applied.cell.camera.principal_point_px().y, number(&report, &["cy"])));

    let again = calibrate(&config.arg(), &dir.join("again.yaml"), &[]);
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    let again = last_line_json(&again.stdout);
    let believed = |key: &str| number(&again, &["configured_error_against_truth", key]);
    eprintln!(
        "after --apply the configuration is off the truth by {}",
        again["configured_error_against_truth"]
    );
    assert!(believed("tool_from_camera_translation_mm") < 1.0, "{again}");
    assert!(believed("tool_from_camera_rotation_deg") < 0.2, "{again}");
    assert!(believed("fx_percent").abs() < 0.3 && believed("fy_percent").abs() < 0.3, "{again}");
    let _ = std::fs::remove_file(&kept);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_plan_out_of_reach_and_poses_about_one_axis_are_refused_before_anything_moves() {
    let dir = scratch("refused");
    let out = dir.join("calibration.yaml");
    let views = dir.join("calibration-views");

    let far = config_from(DEMO, &[("distance_m = 0.3", "distance_m = 1.5")]);
    let output = calibrate(&far.arg(), &out, &[]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("refused before anything moves") && stderr.contains("out of the arm's reach"),
        "{stderr}"
    );
    assert!(!views.exists() && !out.exists(), "nothing taken, nothing written");

    // the plan's first pose, then the tool turned about its own z axis only (the camera rolls)
    let demo = repository_root().join(DEMO).display().to_string();
    let planned = run("vservoctl", &["calibrate", "--config", &demo, "--lockstep", "--dry-run", "--json"]);
    assert!(planned.status.success(), "{}", String::from_utf8_lossy(&planned.stderr));
    let planned = last_line_json(&planned.stdout);
    assert_eq!(planned["poses"].as_array().map(Vec::len), Some(12), "{planned}");
    assert_eq!(planned["moved"], Value::Bool(false));
    let first: Vec<f64> =
        planned["poses"][0]["q_rad"].as_array().expect("joints").iter().filter_map(Value::as_f64).collect();
    let about_one_axis: Vec<Vec<f64>> = (0..12)
        .map(|k| {
            let mut q = first.clone();
            q[5] += (f64::from(k) - 5.5) * 4f64.to_radians();
            q
        })
        .collect();
    let poses = dir.join("poses.json");
    std::fs::write(&poses, serde_json::to_string(&about_one_axis).expect("JSON")).expect("written");
    let output = calibrate(&demo, &out, &["--poses", poses.to_str().expect("utf-8")]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("rotation axes are too parallel"), "{stderr}");
    assert!(!views.exists() && !out.exists(), "nothing taken, nothing written");

    // a pose outside the limits is refused naming it
    let mut outside = about_one_axis.clone();
    outside[3][1] = 10.0;
    std::fs::write(&poses, serde_json::to_string(&outside).expect("JSON")).expect("written");
    let output = calibrate(&demo, &out, &["--poses", poses.to_str().expect("utf-8")]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("pose 4 is outside joint 2's limits"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Through a running vservod, as on a real cell: the arm is held where it is, the board located in its view,
/// the poses taken by joint moves; a safe stop while the arm moves holds it (and the calibration waits),
/// `resume` takes the move on; the result meets the bars; with `--apply` (and no `--python`, as documented) the
/// running instance takes the calibrated camera and is left servoing with it.
#[test]
fn a_running_cell_is_calibrated_through_vservod_within_the_bars_and_a_safe_stop_holds_it_on_the_way() {
    let _one = exclusive();
    let instance = unique("calibrate");
    let config = config_from(DEMO, &[("name = \"default\"", &format!("name = \"{instance}\""))]);
    let daemon = Daemon::start(&config);
    assert!(
        wait_until(Duration::from_secs(10), || status(&instance).is_some_and(|s| running(&s))),
        "{}",
        daemon.log()
    );
    // a joint move outside the limits is refused, naming the joint
    let (code, out) = vservoctl(&["move-joints", "--instance", &instance, "--q", "0,0.8,-9,0,0.8,0"]);
    assert_eq!(code, Some(3), "{out}");
    assert!(out.contains("joint 3: the goal -9.0000 rad is outside its limits"), "{out}");

    let dir = scratch("running");
    let out = dir.join("calibration.yaml");
    // as docs/CALIBRATION.md writes it: no --python (vservoctl finds the project's environment)
    let out_arg = out.display().to_string();
    // a plan out of reach is refused after the hold, before the first pose: the cell servos again
    let far = config_from(
        DEMO,
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("distance_m = 0.3", "distance_m = 1.5"),
        ],
    );
    let refused = run("vservoctl", &["calibrate", "--config", &far.arg(), "--out", &out_arg]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("out of the arm's reach") && stderr.contains("the cell servos again"),
        "{stderr}"
    );
    assert!(
        wait_until(Duration::from_secs(5), || status(&instance).is_some_and(|s| running(&s))),
        "{:?}",
        status(&instance)
    );
    let (stdout_file, stderr_file) = (dir.join("stdout"), dir.join("stderr"));
    let file = |path: &Path| std::fs::File::create(path).expect("a log file");
    let started = Instant::now();
    let mut calibrating = Killed(
        std::process::Command::new(binary("vservoctl"))
            .args(["calibrate", "--config", &config.arg(), "--json", "--out", &out_arg, "--apply"])
            .stdout(file(&stdout_file))
            .stderr(file(&stderr_file))
            .spawn()
            .expect("vservoctl calibrate starts"),
    );
    // while a move carries the arm to a pose (after the hold and the board's location, not while settling): a
    // safe stop holds it
    let located = || std::fs::read_to_string(&stderr_file).is_ok_and(|text| text.contains("the board:"));
    assert!(
        wait_until(Duration::from_secs(30), || {
            located()
                && status(&instance).is_some_and(|s| s["state"] == "moving")
                && fastest_joint_rad_s(&instance, "0.2") > 0.05
        }),
        "{}",
        daemon.log()
    );
    let (code, text) = vservoctl(&["safe-stop", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    std::thread::sleep(Duration::from_secs(1));
    assert!(fastest_joint_rad_s(&instance, "1.5") < 0.01, "held at rest during the safe stop");
    assert!(safe_stopped_by(&instance, "requested"), "{:?}", status(&instance));
    let (code, text) = vservoctl(&["resume", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("the joint move goes on to its goal"), "{text}");

    let ended = calibrating.0.wait().expect("vservoctl calibrate ends");
    let seconds = started.elapsed().as_secs_f64();
    let stderr = std::fs::read_to_string(&stderr_file).unwrap_or_default();
    assert!(ended.success(), "{stderr}\n{}", daemon.log());
    assert!(stderr.contains("the cell is in a safe stop (requested); waiting"), "{stderr}");
    let report = last_line_json(&std::fs::read(&stdout_file).expect("its output"));
    eprintln!("calibrated through vservod in {seconds:.1} s (a safe stop on the way): {report}");
    assert_calibration_within_the_bars(&report);
    // left as found: servoing again
    assert!(
        wait_until(Duration::from_secs(5), || status(&instance).is_some_and(|s| running(&s))),
        "{:?}",
        status(&instance)
    );
    // --apply: the configuration reads the calibration, and the running instance took it (held, its camera's nodes
    // restarted, resumed): its target is where the calibrated camera images the board
    let applied = &report["applied"];
    assert_eq!(applied["reloaded"], Value::Bool(true), "{report}\n{}", daemon.log());
    assert!(applied["reply"].as_str().is_some_and(|r| r.contains("servos again")), "{report}");
    let kept = PathBuf::from(applied["kept"].as_str().expect("where the old file is"));
    let desired = |path: &Path| vservo_config::Config::load(path).expect("loads").cell.desired.features;
    let (before, after) = (desired(&kept), desired(&config.path));
    let moved = (0..8).map(|i| (after[i] - before[i]).abs()).fold(0.0, f64::max);
    assert!(moved > 1.0, "the calibration moves ξ_d by {moved} px");
    let gains = echo_lines(&instance, "gains", "1");
    let in_force = gains.last().expect("the gains in force")["desired_features_px"].clone();
    let in_force: Vec<f64> = in_force.as_array().expect("ξ_d").iter().filter_map(Value::as_f64).collect();
    for i in 0..8 {
        assert!(
            (in_force[i] - after[i]).abs() < 1e-6,
            "ξ_d[{i}]: {} in force, {} calibrated",
            in_force[i],
            after[i]
        );
    }
    let restarted = status(&instance).expect("a status");
    for node in ["vision", "servo", "rmrc"] {
        assert_eq!(restarted["nodes"][node]["restarts"], 1, "{node} restarted once: {restarted}");
    }
    assert_eq!(restarted["nodes"]["plant"]["restarts"], 0, "{restarted}");
    // and it servos again, with the calibrated camera, below 1 px
    assert!(servoes_below_one_pixel(&instance), "{:?}\n{}", status(&instance), daemon.log());
    daemon.stop();
    let _ = std::fs::remove_file(&kept);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A held cell (`robot.start = "held"`, as a real arm's on its first day) is calibrated: the calibration's planned,
/// slow moves are its first motion. With `--apply` the configuration reads the calibration, and the cell ends held
/// again at its start, at rest, within the bars; resumed, it servoes below 1 px.
#[test]
fn a_held_cell_is_calibrated_first_and_held_again() {
    let _one = exclusive();
    let instance = unique("calibrate-held");
    let held = "driver = \"simulated\"\nstart = \"held\"";
    let config = config_from(
        DEMO,
        &[("name = \"default\"", &format!("name = \"{instance}\"")), ("driver = \"simulated\"", held)],
    );
    let daemon = Daemon::start(&config);
    assert!(
        wait_until(Duration::from_secs(10), || safe_stopped_by(&instance, "start_held")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    let dir = scratch("held");
    let out = dir.join("calibration.yaml").display().to_string();
    let output =
        run("vservoctl", &["calibrate", "--config", &config.arg(), "--json", "--out", &out, "--apply"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}\n{}", daemon.log());
    assert!(stderr.contains("the cell is held: its first motion is the calibration's"), "{stderr}");
    let report = last_line_json(&output.stdout);
    eprintln!("a held cell, calibrated: {report}");
    assert_calibration_within_the_bars(&report);
    let applied = &report["applied"];
    assert!(applied["reply"].as_str().is_some_and(|r| r.contains("the cell stays held")), "{report}");
    let text = std::fs::read_to_string(&config.path).expect("the configuration");
    assert!(text.contains("calibration_file"), "the configuration reads the calibration: {text}");
    assert!(safe_stopped_by(&instance, "requested"), "held again: {:?}", status(&instance));
    assert!(fastest_joint_rad_s(&instance, "0.5") < 0.01, "at rest while held");
    let (code, text) = vservoctl(&["resume", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    assert!(servoes_below_one_pixel(&instance), "{:?}\n{}", status(&instance), daemon.log());
    daemon.stop();
    if let Some(kept) = applied["kept"].as_str() {
        let _ = std::fs::remove_file(kept);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The eye-to-hand cell calibrated through a running vservod: the board located on the tool from where the arm
/// is, the poses planned relative to it and taken by moving the arm, the fixed camera's pose recovered within the
/// bars (1 mm, 0.2°), and the cell servoing again below 1 px afterwards.
#[test]
fn a_running_eye_to_hand_cell_is_calibrated_through_vservod_within_the_bars() {
    let _one = exclusive();
    let instance = unique("calibrate-fixed");
    let (config, daemon) = running_daemon_of("config/eye-to-hand-calibration.toml", &instance);
    let dir = scratch("running-fixed");
    let out = dir.join("calibration.yaml").display().to_string();
    let output = run("vservoctl", &["calibrate", "--config", &config.arg(), "--json", "--out", &out]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}\n{}", daemon.log());
    assert!(stderr.contains("the board:"), "located first: {stderr}");
    let report = last_line_json(&output.stdout);
    eprintln!("eye to hand, calibrated through vservod: {report}");
    assert_eq!(report["changes"]["mount"], "base_from_camera", "{report}");
    assert_calibration_within_the_bars(&report);
    assert!(servoes_below_one_pixel(&instance), "{:?}\n{}", status(&instance), daemon.log());
    daemon.stop();
    let _ = std::fs::remove_dir_all(&dir);
}
