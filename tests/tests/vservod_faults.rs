//! Faults the daemon must act on (issue 12, in part): a hung node is ended and restarted; however the
//! daemon ends, the nodes bring the arm to rest in order; a restarted node runs the configuration in force,
//! not an edited file; no command-line duration can panic. Real processes over iceoryx2, one test at a time.

use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use serde_json::Value;
use vservo_system_tests::{
    exclusive, fastest_joint_rad_s, run, running, running_daemon, safe_stopped_by, status, unique, wait_until,
};

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

/// A client of another user is refused (the instance's shared memory is the daemon's user's), and the message
/// says what it can know: root's `/run/vservo` is closed to it and may hold another user's instance, and how to
/// run the client as that user. It names no owner for an instance it cannot see. Needs root (to be `nobody`).
#[test]
fn a_client_of_another_user_is_told_what_it_can_know_of_the_instance() {
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
    assert!(!stderr.contains("is run by user"), "{stderr}");
    assert!(
        stderr.contains("/run/vservo is closed to this user (the directory is user \"root\"'s)")
            && stderr.contains("sudo -u <that user>"),
        "{stderr}"
    );
    daemon.stop();
}

/// Issue 37: vservod stopped (SIGSTOP) while the arm tracks a moving board: the nodes hear no word from it for a
/// second and hold the arm on their own; woken, the daemon latches `supervision_stalled`, and a resume on command
/// servos again.
#[test]
fn a_stopped_daemon_is_a_safe_stop_the_nodes_make_on_their_own() {
    let _one = exclusive();
    let instance = unique("stopped-daemon");
    let (_config, daemon) = running_daemon(&instance);
    let (code, out) = vservo_system_tests::vservoctl(&[
        "object",
        "circle",
        "--radius-m",
        "0.05",
        "--rev-per-min",
        "10",
        "--instance",
        &instance,
    ]);
    assert_eq!(code, Some(0), "{out}");
    std::thread::sleep(Duration::from_millis(500));
    let tracking = fastest_joint_rad_s(&instance, "0.3");
    assert!(tracking > 0.02, "the arm follows the board: {tracking} rad/s");
    daemon.signal(Signal::SIGSTOP);
    let _continued = Reaper(vec![daemon.child.id() as i32]);
    // a second of silence, the ramp to rest (tens of ms), then a look at the arm while vservod is still stopped
    std::thread::sleep(Duration::from_millis(1300));
    let held = fastest_joint_rad_s(&instance, "0.3");
    assert!(held < 0.01, "the nodes hold the arm while vservod is stopped: {held} rad/s\n{}", daemon.log());
    let log = daemon.log();
    assert!(
        log.lines().any(|l| l.contains("no word from vservod") && l.contains("node=\"rmrc\"")),
        "the rmrc says why it holds: {log}"
    );
    daemon.signal(Signal::SIGCONT);
    assert!(
        wait_until(Duration::from_secs(5), || safe_stopped_by(&instance, "supervision_stalled")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    // still held after the daemon's word is back, until a resume on command
    std::thread::sleep(Duration::from_millis(500));
    assert!(fastest_joint_rad_s(&instance, "0.3") < 0.01, "held until the resume");
    let (code, out) = vservo_system_tests::vservoctl(&["resume", "--instance", &instance]);
    assert_eq!(code, Some(0), "{out}");
    assert!(
        wait_until(Duration::from_secs(5), || fastest_joint_rad_s(&instance, "0.3") > 0.02),
        "the arm follows the board again\n{}",
        daemon.log()
    );
    daemon.stop();
}
