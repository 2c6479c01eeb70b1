//! Faults the daemon must act on (issue 12, in part): a hung node is ended and restarted; however the
//! daemon ends, the nodes bring the arm to rest in order; a restarted node runs the configuration in force,
//! not an edited file; no command-line duration can panic. Real processes over iceoryx2, one test at a time.

use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use serde_json::Value;
use vservo_system_tests::{exclusive, run, running, running_daemon, status, unique, wait_until};

fn node(status: &Value, role: &str) -> Value {
    status["nodes"][role].clone()
}

fn pid_of(instance: &str, role: &str) -> i32 {
    status(instance).and_then(|s| node(&s, role)["pid"].as_i64()).expect("a pid") as i32
}

fn alive(pid: i32) -> bool {
    std::path::Path::new(&format!("/proc/{pid}")).exists()
        && std::fs::read_to_string(format!("/proc/{pid}/stat"))
            .is_ok_and(|stat| stat.split_whitespace().nth(2) != Some("Z"))
}

/// Kills what is left of these processes when the test ends, passed or not.
struct Reaper(Vec<i32>);

impl Drop for Reaper {
    fn drop(&mut self) {
        for &pid in &self.0 {
            let _ = kill(Pid::from_raw(pid), Signal::SIGCONT);
            let _ = kill(Pid::from_raw(pid), Signal::SIGKILL);
        }
    }
}

#[test]
fn a_stopped_node_is_found_hung_killed_and_restarted() {
    let _one = exclusive();
    let instance = unique("hang");
    let (_config, daemon) = running_daemon(&instance);
    for role in ["servo", "plant"] {
        let pid = pid_of(&instance, role);
        let _reaper = Reaper(vec![pid]);
        kill(Pid::from_raw(pid), Signal::SIGSTOP).expect("SIGSTOP");
        let stopped = Instant::now();
        assert!(
            wait_until(Duration::from_secs(10), || status(&instance).is_some_and(|s| {
                let n = node(&s, role);
                n["restarts"] == 1 && n["healthy"] == true && n["pid"].as_i64() != Some(i64::from(pid))
            })),
            "{role}: {:?}\n{}",
            status(&instance),
            daemon.log()
        );
        println!(
            "{role}: stopped, found hung, killed and healthy again after {:.1} s",
            stopped.elapsed().as_secs_f64()
        );
        assert!(!alive(pid), "the hung {role} process is gone");
        let log = daemon.log();
        let named = format!("node=\"{role}\"");
        assert!(log.lines().any(|l| l.contains("node hung") && l.contains(&named)), "{log}");
    }
    // the loop runs on: every node healthy, joint states at the plant's rate
    assert!(
        wait_until(Duration::from_secs(10), || status(&instance).is_some_and(|s| running(&s))),
        "{}",
        daemon.log()
    );
    daemon.stop();
}

#[test]
fn when_the_daemon_is_killed_the_nodes_bring_the_arm_to_rest_in_order() {
    let _one = exclusive();
    let instance = unique("orphan");
    let (_config, mut daemon) = running_daemon(&instance);
    let roles = ["servo", "vision", "rmrc", "plant"];
    let pids: Vec<i32> = roles.iter().map(|r| pid_of(&instance, r)).collect();
    let _reaper = Reaper(pids.clone());
    // the joint states from before the kill to the plant's exit, read as they come (a full pipe would stall
    // the echo and lose states)
    let mut echo = std::process::Command::new(vservo_system_tests::binary("vservoctl"))
        .args(["echo", "joint_state", "--instance", &instance, "--duration-s", "8"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("echo starts");
    let stdout = echo.stdout.take().expect("piped");
    let reader = std::thread::spawn(move || {
        use std::io::BufRead;
        std::io::BufReader::new(stdout).lines().map_while(Result::ok).collect::<Vec<String>>()
    });
    std::thread::sleep(Duration::from_millis(500));
    daemon.signal(Signal::SIGKILL);
    let killed = Instant::now();
    let _ = daemon.wait(Duration::from_secs(2));
    let mut exited: Vec<Option<Duration>> = vec![None; pids.len()];
    while killed.elapsed() < Duration::from_secs(8) && exited.iter().any(Option::is_none) {
        for (i, &pid) in pids.iter().enumerate() {
            if exited[i].is_none() && !alive(pid) {
                exited[i] = Some(killed.elapsed());
            }
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = kill(Pid::from_raw(echo.id() as i32), Signal::SIGTERM);
    let _ = echo.wait();
    let states: Vec<Value> =
        reader.join().expect("the reader ends").iter().filter_map(|l| serde_json::from_str(l).ok()).collect();
    let speed = |s: &Value| {
        s["qd_rad_s"]
            .as_array()
            .expect("qd")
            .iter()
            .map(|v| v.as_f64().unwrap_or(f64::NAN).abs())
            .fold(0.0, f64::max)
    };
    let exits: Vec<String> =
        roles.iter().zip(&exited).map(|(r, t)| format!("{r} {:?}", t.map(|t| t.as_millis()))).collect();
    println!("after SIGKILL of vservod, exits (ms): {}", exits.join(", "));
    assert!(exited.iter().all(Option::is_some), "every node exits by itself: {exits:?}");
    let last = states.last().expect("joint states were heard");
    let fastest = states.iter().map(speed).fold(0.0, f64::max);
    println!(
        "joint states heard {}, fastest joint {fastest:.4} rad/s, at the plant's exit {:.5} rad/s",
        states.len(),
        speed(last)
    );
    assert!(speed(last) < 0.01, "the arm is at rest before the plant exits: {last}\n{}", daemon.log());
    // in order: the rmrc brings the reference to rest (a zero twist of its own: no servo is trusted without
    // the daemon) and stops; the plant holds the arm and stops last
    let log = daemon.log();
    let line_of = |what: &str| log.lines().position(|l| l.contains(what));
    let (rmrc_done, plant_done) = (
        line_of("the arm is at rest; stopping (the daemon is gone)"),
        line_of("the arm is at rest and held; stopping (the daemon is gone)"),
    );
    assert!(rmrc_done.is_some() && plant_done.is_some() && rmrc_done < plant_done, "{log}");
}

#[test]
fn a_restarted_node_runs_the_configuration_in_force_not_an_edited_file() {
    let _one = exclusive();
    let instance = unique("in-force");
    let (config, daemon) = running_daemon(&instance);
    // an edit that was never reloaded, and that does not even parse
    std::fs::write(&config.path, "this is [not a configuration").expect("overwrite");
    let pid = pid_of(&instance, "vision");
    kill(Pid::from_raw(pid), Signal::SIGKILL).expect("SIGKILL");
    assert!(
        wait_until(Duration::from_secs(10), || status(&instance).is_some_and(|s| {
            let n = node(&s, "vision");
            n["restarts"] == 1 && n["healthy"] == true
        }) && status(&instance).is_some_and(|s| running(&s))),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    daemon.stop();
}

#[test]
fn no_duration_on_the_command_line_can_panic() {
    for args in [
        ["status", "--timeout-s", "inf"],
        ["echo", "--duration-s", "inf"],
        ["record", "--duration-s", "1e30"],
    ] {
        let mut full: Vec<&str> = args.to_vec();
        if args[0] == "echo" {
            full.insert(1, "status");
        }
        if args[0] == "record" {
            full.extend(["--out", "/tmp/never.mcap"]);
        }
        let out = run("vservoctl", &full);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{full:?}: {stderr}");
        assert!(!stderr.contains("panicked") && stderr.contains("must be from 0"), "{full:?}: {stderr}");
    }
}

#[test]
fn clients_with_no_daemon_say_so_and_create_nothing_that_stops_the_daemon() {
    let _one = exclusive();
    let instance = unique("no-daemon");
    for args in [
        vec!["status", "--instance", &instance, "--timeout-s", "0.5"],
        vec!["echo", "status", "--instance", &instance, "--duration-s", "0.2"],
        vec!["target", "teach", "--instance", &instance],
    ] {
        let out = run("vservoctl", &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains("vservod"), "{args:?} names the missing daemon: {stderr}");
    }
    let python = vservo_system_tests::repository_root().join("target/python-venv/bin/python");
    let out = std::process::Command::new(python)
        .arg(vservo_system_tests::repository_root().join("clients/python/vservo_client.py"))
        .args(["--instance", &instance, "status"])
        .output()
        .expect("python runs");
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    // the daemon then starts as if no client had been there
    let (_config, daemon) = running_daemon(&instance);
    daemon.stop();
}

/// A process of the daemon's user publishes absurd messages on the real services for ten seconds: torques
/// answering the plant's ticks (1e9 N·m, and, unsealed, 0.9 of each limit), twists of 1e9, features 40 px
/// off, gains × 1e6, an object circle of 5 m at 1000 rev/min, and cell modes that would hold or release the
/// cell. None is applied: the arm stays within its speed limits, the daemon's gains, object and mode stay in
/// force, and the nodes count what they refused.
#[test]
fn absurd_messages_from_a_rogue_publisher_are_refused_and_counted() {
    use vservo_protocol::{
        CameraTwistMsg, CellMode, CellModeMsg, CommandKind, CommandMode, FeaturesMsg, GainsMsg,
        JointCommandMsg, JointStateMsg, ObjectMsg, Topic, Verdict,
    };
    let _one = exclusive();
    let instance = unique("rogue");
    let (_config, daemon) = running_daemon(&instance);
    let rejected_before: i64 = ["plant", "rmrc", "servo"]
        .iter()
        .map(|r| status(&instance).map_or(0, |s| node(&s, r)["rejected_messages"].as_i64().unwrap_or(0)))
        .sum();

    let rogue = vservo_protocol::create_node(&instance, "rogue").expect("a node");
    let states =
        vservo_protocol::subscriber::<JointStateMsg>(&rogue, &instance, Topic::JointState).expect("sub");
    let torques =
        vservo_protocol::publisher::<JointCommandMsg>(&rogue, &instance, Topic::JointCommand).expect("pub");
    let twists =
        vservo_protocol::publisher::<CameraTwistMsg>(&rogue, &instance, Topic::CameraTwist).expect("pub");
    let features =
        vservo_protocol::publisher::<FeaturesMsg>(&rogue, &instance, Topic::Features).expect("pub");
    let gains = vservo_protocol::publisher::<GainsMsg>(&rogue, &instance, Topic::Gains).expect("pub");
    let objects = vservo_protocol::publisher::<ObjectMsg>(&rogue, &instance, Topic::Object).expect("pub");
    let modes = vservo_protocol::publisher::<CellModeMsg>(&rogue, &instance, Topic::CellMode).expect("pub");
    // inside every limit: only the seal refuses these
    let within_limits_nm = [87.8, 167.8, 80.5, 21.8, 18.1, 19.2];
    let mut fastest = 0.0f64;
    let started = Instant::now();
    let mut round = 0u64;
    while started.elapsed() < Duration::from_secs(10) {
        round += 1;
        while let Ok(Some(state)) = states.receive() {
            fastest = state.qd_rad_s.iter().fold(fastest, |m, v| m.max(v.abs()));
            let command = JointCommandMsg {
                mode: CommandMode::Torque.into(),
                answers_tick: state.tick,
                driver_epoch: state.driver_epoch,
                state_stamp_ns: state.stamp_ns,
                stamp_ns: state.stamp_ns,
                torque_nm: if state.tick % 2 == 0 { [1e9; 6] } else { within_limits_nm },
                q_ref_rad: state.q_rad,
                seal: round,
                ..JointCommandMsg::default()
            };
            let _ = torques.send_copy(command);
        }
        if round.is_multiple_of(10) {
            let _ = twists.send_copy(CameraTwistMsg {
                verdict: Verdict::Servoing.into(),
                frame: round,
                gains_version: 1,
                twist: [1e9; 6],
                feature_error_px: 0.0,
                ..CameraTwistMsg::default()
            });
            let _ = features.send_copy(FeaturesMsg {
                valid_mask: 0b1111,
                frame: round,
                features_px: [5000.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, -400.0],
                mark_status: [0; 4],
                // not a rigid motion: the servo must not steer by it
                base_from_camera: [3.0, 0.0, 0.0, 1e9, 0.0, 2.0, 0.0, -1e9, 0.0, 0.0, 1.0, 0.0],
                ..FeaturesMsg::default()
            });
            let _ = gains.send_copy(GainsMsg {
                version: 1000 + round,
                feature_gain: [1e6; 48],
                desired_features_px: [5000.0; 8],
                desired_depths_m: [-1.0; 4],
                q: [f64::NAN; 64],
                interaction: 7,
                feedforward: 3,
                border_margin_px: -5.0,
                seal: round,
                ..GainsMsg::default()
            });
            let mode = if round.is_multiple_of(20) { CellMode::SafeStop } else { CellMode::Servoing };
            let _ = modes.send_copy(CellModeMsg {
                mode: mode.into(),
                sequence: 1000 + round,
                fault: 7,
                seal: round,
                ..CellModeMsg::default()
            });
            let _ = objects.send_copy(ObjectMsg {
                kind: CommandKind::ObjectCircle.into(),
                sequence: 1000 + round,
                radius_m: 5.0,
                rev_per_min: 1000.0,
                seal: round,
                ..ObjectMsg::default()
            });
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let after = status(&instance).expect("status");
    let rejected_after: i64 = ["plant", "rmrc", "servo"]
        .iter()
        .map(|r| node(&after, r)["rejected_messages"].as_i64().unwrap_or(0))
        .sum();
    println!(
        "rogue publisher for 10 s: fastest joint {fastest:.3} rad/s; refused {} messages; gains version {}",
        rejected_after - rejected_before,
        after["gains_version"]
    );
    // the PUMA 560's slowest joint limit is 5 rad/s
    assert!(fastest < 5.0, "joint speed {fastest} rad/s");
    assert!(rejected_after - rejected_before > 100, "{after}");
    assert_eq!(after["gains_version"], 1, "the rogue gains were not taken: {after}");
    assert!(running(&after), "{after}\n{}", daemon.log());
    assert_eq!(after["safe_stops"], 0, "no forged mode was taken: {after}");
    daemon.stop();
}

/// A client of another user is refused by iceoryx2 (the instance's shared memory is the daemon's user's), and
/// the message says which user runs the instance and how to run the client. Needs root (to be `nobody`).
#[test]
fn a_client_of_another_user_is_told_who_runs_the_instance() {
    use std::os::unix::fs::MetadataExt;
    if std::fs::metadata("/proc/self").map(|m| m.uid()).ok() != Some(0) {
        println!("skipped: needs root to run a client as nobody");
        return;
    }
    let _one = exclusive();
    let instance = unique("other-user");
    let (_config, daemon) = running_daemon(&instance);
    let binary = vservo_system_tests::binary("vservoctl");
    let out = std::process::Command::new("runuser")
        .args(["-u", "nobody", "--"])
        .arg(&binary)
        .args(["status", "--instance", &instance, "--timeout-s", "1"])
        .current_dir("/")
        .output()
        .expect("runuser runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("is run by user \"root\"") && stderr.contains("sudo -u root"), "{stderr}");
    daemon.stop();
}
