//! The Python example client (clients/python/vservo_client.py, PyPI iceoryx2 0.10) against a running
//! daemon: a target it sends moves the servo's target; a NaN target is refused with a reason.

use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use vservo_system_tests::{binary, config_with, repository_root, run};

fn python(args: &[&str]) -> Output {
    let interpreter = repository_root().join("target/python-venv/bin/python");
    assert!(
        interpreter.exists(),
        "{} is missing: scripts/setup.sh installs the iceoryx2 bindings there",
        interpreter.display()
    );
    Command::new(interpreter)
        .arg(repository_root().join("clients/python/vservo_client.py"))
        .args(args)
        .output()
        .expect("python runs")
}

#[test]
fn the_python_client_sets_a_target_and_hears_a_refusal() {
    let instance = format!("py-{}", std::process::id());
    let config = config_with("name = \"default\"", &format!("name = \"{instance}\""));
    let mut daemon = Command::new(binary("vservod"))
        .args(["--config", &config.arg(), "--status-every-s", "0"])
        .stderr(Stdio::null())
        .spawn()
        .expect("vservod starts");
    let until = Instant::now() + Duration::from_secs(10);
    while !python(&["--instance", &instance, "status"]).status.success() {
        assert!(Instant::now() < until, "the daemon never answered the Python client");
        std::thread::sleep(Duration::from_millis(200));
    }
    let out = python(&["--instance", &instance, "target", "161,168,328,178,349,75,182,70"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("accepted"),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // the servo runs it: vservoctl sees the gains of version 2 carrying the Python client's target
    let gains =
        run("vservoctl", &["echo", "gains", "--instance", &instance, "--count", "1", "--duration-s", "2"]);
    let message: serde_json::Value = serde_json::from_slice(&gains.stdout).expect("one gains message");
    assert_eq!(message["version"], 2);
    assert_eq!(
        message["desired_features_px"],
        serde_json::json!([161.0, 168.0, 328.0, 178.0, 349.0, 75.0, 182.0, 70.0])
    );

    let out = python(&["--instance", &instance, "target", "nan,168,328,178,349,75,182,70"]);
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not finite"));
    let out = python(&["--instance", &instance, "status"]);
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("gains version 2"),
        "the loop runs on with the good target"
    );

    kill(Pid::from_raw(daemon.id() as i32), Signal::SIGTERM).expect("SIGTERM");
    assert_eq!(daemon.wait().expect("exit").code(), Some(0));
}
