//! The dynamics override on real processes (`[robot] speed_scale`, `vservoctl speed`), on the FR3's cell
//! (config/arms/fr3.toml: it starts held). Its simulated arm follows the velocity through its drives' lag, and the
//! rmrc keeps the FR3's speed, acceleration and jerk limits for it as for a real arm: at a quarter the commands
//! keep a quarter of each, measured as its controller would (scripts/command_limits.py), and use it; a raise is
//! refused while the cell moves and taken while it is held, after which the transient uses more than a quarter,
//! never more than the whole; a lowering is taken at once.

use std::path::Path;
use std::process::{Child, Command, Stdio};

use serde_json::Value;
use vservo_system_tests::{
    Daemon, ScratchDir, TempConfig, binary, exclusive, repository_root, run, status, unique, vservoctl,
    wait_until,
};

/// `vservoctl echo joint_command` for `seconds`, into `file`: it waits for the instance.
fn record(instance: &str, file: &Path, seconds: &str) -> Child {
    Command::new(binary("vservoctl"))
        .args(["echo", "joint_command", "--instance", instance, "--duration-s", seconds])
        .stdout(std::fs::File::create(file).expect("the recording"))
        .stderr(Stdio::null())
        .spawn()
        .expect("vservoctl echo starts")
}

/// What the FR3's controller would see of the recorded commands, as shares of its limits.
fn limits_used(commands: &Path, scene: &Path) -> Value {
    let root = repository_root();
    let out = Command::new(root.join("target/python-venv/bin/python"))
        .arg(root.join("scripts/command_limits.py"))
        .args([commands, scene])
        .output()
        .expect("command_limits.py runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON")
}

/// How far past a share of a limit rounding may put a measured value (relative): a speed cut to the limit.
const ROUNDING: f64 = 1e-9;

fn share(summary: &Value, key: &str) -> f64 {
    summary[key].as_f64().unwrap_or_else(|| panic!("{key} in {summary}"))
}

/// The shares of the arm's limits a recording is measured by.
const LIMITS: [&str; 3] = ["max_velocity_ratio", "max_acceleration_ratio", "max_jerk_ratio"];

/// The largest share of any limit a recording used.
fn largest_share(summary: &Value) -> f64 {
    LIMITS.iter().map(|key| share(summary, key)).fold(0.0, f64::max)
}

/// Resumes the held cell while `seconds` of its commands are recorded into `name`: what they used of the limits.
fn resumed_and_measured(instance: &str, dir: &ScratchDir, name: &str, seconds: &str) -> Value {
    let recorder = record(instance, &dir.0.join(name), seconds);
    std::thread::sleep(std::time::Duration::from_millis(300));
    let (code, text) = vservoctl(&["resume", "--instance", instance]);
    assert_eq!(code, Some(0), "{text}");
    measured(recorder, dir, name)
}

/// Waits for the recorder, then measures what it heard.
fn measured(recorder: Child, dir: &ScratchDir, name: &str) -> Value {
    let recorded = recorder.wait_with_output().expect("the recording ends");
    assert!(recorded.status.success(), "the recording of {name}");
    let summary = limits_used(&dir.0.join(name), &dir.0.join("scene.json"));
    println!("{name}: {summary}");
    assert!(share(&summary, "consecutive_triples") > 1000.0, "{summary}");
    summary
}

fn speed_scale_in_force(instance: &str) -> Option<f64> {
    status(instance).and_then(|s| s["speed_scale"].as_f64())
}

#[test]
fn a_quarter_speed_keeps_a_quarter_of_the_limits_and_is_raised_only_while_held() {
    let _one = exclusive();
    let instance = unique("speed");
    let dir = ScratchDir::new(&instance);
    let config = TempConfig::written(&format!(
        "extends = \"{}\"\n[instance]\nname = \"{instance}\"\n[robot]\nspeed_scale = 0.25\n",
        repository_root().join("config/arms/fr3.toml").display()
    ));
    let scene = run("vservoctl", &["scene", "--config", &config.arg()]);
    assert!(scene.status.success(), "{}", String::from_utf8_lossy(&scene.stderr));
    dir.write("scene.json", &String::from_utf8_lossy(&scene.stdout));
    let daemon = Daemon::start(&config);
    assert!(
        wait_until(std::time::Duration::from_secs(10), || speed_scale_in_force(&instance) == Some(0.25)),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );

    // held at its start; resumed at a quarter: the whole transient within a quarter of the FR3's limits
    let quarter = resumed_and_measured(&instance, &dir, "quarter.jsonl", "4");
    for key in LIMITS {
        assert!(share(&quarter, key) <= 0.25 * (1.0 + ROUNDING), "{key} over a quarter: {quarter}");
    }
    assert!(largest_share(&quarter) > 0.2, "it moved at the quarter's limits: {quarter}");

    // a raise while the cell moves is refused, naming how; while held it is taken
    let (code, text) = vservoctl(&["speed", "1.0", "--instance", &instance]);
    assert_ne!(code, Some(0), "{text}");
    assert!(text.contains("while the cell moves") && text.contains("--while-moving"), "{text}");
    assert_eq!(speed_scale_in_force(&instance), Some(0.25));
    let (code, text) = vservoctl(&["safe-stop", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    let (code, text) = vservoctl(&["speed", "1.0", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("speed scale 1 (was 0.25)"), "{text}");
    assert_eq!(speed_scale_in_force(&instance), Some(1.0));

    // the board jumps while the cell is held; resumed at the whole: more than a quarter, never over the limits
    let (code, text) = vservoctl(&["object", "step", "--by-m", "0.03,-0.02,0.0", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    let whole = resumed_and_measured(&instance, &dir, "whole.jsonl", "3");
    for key in LIMITS {
        assert!(share(&whole, key) <= 1.0 + ROUNDING, "{key} over the limits: {whole}");
    }
    assert!(largest_share(&whole) > 0.3, "the whole is more than a quarter: {whole}");

    // lowering is always taken, and out of range is refused naming the range
    let (code, text) = vservoctl(&["speed", "0.1", "--instance", &instance]);
    assert_eq!(code, Some(0), "{text}");
    assert_eq!(speed_scale_in_force(&instance), Some(0.1));
    let (code, text) = vservoctl(&["speed", "0", "--instance", &instance]);
    assert_ne!(code, Some(0), "{text}");
    assert!(text.contains("from 0.001 to 1"), "{text}");
    daemon.stop();
}
