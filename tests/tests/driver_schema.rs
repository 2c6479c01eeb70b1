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

/// A robot driver of another schema whose joint states still open the service (the same layout, another number:
/// one written for an older schema) is named by vservod within 5 s, in one ERROR line with its pid and both
/// schemas, instead of "no robot driver has appeared" alone (issue 46).
#[test]
fn vservod_names_a_robot_driver_of_another_schema_with_its_pid_and_both_numbers() {
    let _one = exclusive();
    let instance = unique("old-driver");
    // the MuJoCo cell's configuration: an external robot driver and camera
    let config =
        config_from("config/mujoco.toml", &[("name = \"mujoco\"", &format!("name = \"{instance}\""))]);
    let daemon = vservo_system_tests::Daemon::start(&config);
    let older = SCHEMA_VERSION - 1;
    let script = format!(
        "import os, sys, time; sys.path.insert(0, {clients:?}); import vservo_driver as d\n\
         node = d.make_node({instance:?}, 'an old driver')\n\
         publisher = d.open_topic(node, {instance:?}, 'joint_state', d.JointState, 1, 64).publisher_builder().create()\n\
         state = d.JointState(schema={older}, period_ns=1000000, command_mode=d.VELOCITY, joint_count=6)\n\
         print(os.getpid(), flush=True)\n\
         for tick in range(600):\n    state.tick, state.stamp_ns = tick, time.monotonic_ns()\n    \
         publisher.send_copy(state)\n    time.sleep(0.01)\n",
        clients = repository_root().join("clients/python").display().to_string(),
    );
    let mut driver = Command::new(repository_root().join("target/python-venv/bin/python"))
        .args(["-c", &script])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python runs");
    let stdout = driver.stdout.take().expect("stdout");
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        use std::io::BufRead;
        let mut line = String::new();
        let _ = std::io::BufReader::new(stdout).read_line(&mut line);
        let _ = sender.send(line);
    });
    let Ok(pid) = receiver.recv_timeout(Duration::from_secs(20)) else {
        let _ = driver.kill();
        let out = driver.wait_with_output().expect("python ends");
        panic!("the old driver did not start: {}\n{}", String::from_utf8_lossy(&out.stderr), daemon.log());
    };
    let started = Instant::now();
    let wanted = format!(
        "the robot driver (pid {}) speaks schema {older}; this vservod speaks {SCHEMA_VERSION}",
        pid.trim()
    );
    let named = vservo_system_tests::wait_until(Duration::from_secs(5), || daemon.log().contains(&wanted));
    let after = started.elapsed();
    let _ = driver.kill();
    let _ = driver.wait();
    assert!(named, "named within 5 s ({after:?}): {}", daemon.log());
    let lines = daemon.log().lines().filter(|l| l.contains(&wanted)).count();
    assert_eq!(lines, 1, "said once: {}", daemon.log());
    println!("named after {:.2} s", after.as_secs_f64());
    daemon.stop();
}
