//! Protocol versions a driver can live with: the daemon says in its instance's directory which schema it speaks,
//! and a driver of another schema — the Python reference drivers' module, a Rust driver (`vservo-franka`) — says so
//! in one line naming both schema numbers before it opens anything, and ends.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use vservo_protocol::SCHEMA_VERSION;
use vservo_protocol::instance_dir::SCHEMA_FILE;
use vservo_system_tests::{binary, config_from, exclusive, repository_root, running_daemon, unique};

/// The lines of `text` that name both schemas, the instance's and the program's.
fn schema_lines(text: &str, instance: u32, program: u32) -> Vec<String> {
    text.lines()
        .filter(|line| {
            line.contains(&format!("speaks protocol schema {instance}"))
                && line.contains(&format!("this program schema {program}"))
        })
        .map(str::to_string)
        .collect()
}

#[test]
fn a_driver_of_another_schema_says_so_in_one_line_naming_both() {
    let _one = exclusive();
    let instance = unique("schema");
    let (_config, daemon) = running_daemon(&instance);
    let dir = vservo_protocol::InstanceDir::locate(&instance).expect("the instance's directory");
    let written = std::fs::read_to_string(dir.path.join(SCHEMA_FILE)).expect("the daemon wrote its schema");
    assert_eq!(written.trim(), SCHEMA_VERSION.to_string());

    // the Python drivers' module of the previous schema
    let previous = SCHEMA_VERSION - 1;
    let started = Instant::now();
    let out = Command::new(repository_root().join("target/python-venv/bin/python"))
        .args(["-c", &format!(
            "import sys; sys.path.insert(0, {:?}); import vservo_client; vservo_client.SCHEMA_VERSION = {previous}; \
             import vservo_driver; vservo_driver.make_node({instance:?}, 'an old driver')",
            repository_root().join("clients/python").display().to_string()
        )])
        .stdin(Stdio::null())
        .output()
        .expect("python runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(schema_lines(&stderr, SCHEMA_VERSION, previous).len(), 1, "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(started.elapsed() < Duration::from_secs(10));

    // a Rust driver against an instance of the next schema (its daemon's file says so)
    let next = SCHEMA_VERSION + 1;
    std::fs::write(dir.path.join(SCHEMA_FILE), format!("{next}\n")).expect("the schema file rewritten");
    let franka = config_from(
        "config/franka-sim.toml",
        &[("name = \"franka-sim\"", &format!("name = \"{instance}\""))],
    );
    let out = Command::new(binary("vservo-franka"))
        .args(["--config", &franka.arg()])
        .stdin(Stdio::null())
        .output()
        .expect("vservo-franka runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(schema_lines(&stderr, next, SCHEMA_VERSION).len(), 1, "{stderr}");
    assert!(!stderr.contains("Franka at"), "nothing opened before the schema was checked: {stderr}");
    std::fs::write(dir.path.join(SCHEMA_FILE), format!("{SCHEMA_VERSION}\n"))
        .expect("the schema file restored");
    daemon.stop();
}
