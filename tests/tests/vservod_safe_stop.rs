//! The fault reaction (issue 12): faults end in a safe stop that names them, the arm is brought to rest and
//! held, and the cell servos again on `vservoctl resume` only once the cause is gone; clients that are idle
//! or gone hold no command slot, a full command service answers "busy", and a command flood is logged in a
//! summary. Real processes over iceoryx2, one test at a time.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

use vservo_system_tests::{
    Daemon, LoopThread, config_from, echo_lines, exclusive, fastest_joint_rad_s, numbers, running,
    running_daemon, safe_stopped_by, status, unique, vservoctl, wait_until,
};

/// The board jumps while the arm servos: two marks leave the image and the rest are no longer the board's
/// layout. After `faults.target_lost_s` (1 s) the cell is in a safe stop named `target_lost`, the arm at
/// rest; a resume is refused while the marks are not seen, and accepted once the board is back; the loop
/// then converges.
#[test]
fn lost_marks_end_in_a_safe_stop_at_rest_and_the_cell_resumes_once_they_are_seen() {
    let _one = exclusive();
    let instance = unique("lost");
    let (_config, daemon) = running_daemon(&instance);
    let (code, out) = vservoctl(&["object", "step", "--by-m", "-0.2,0,0", "--instance", &instance]);
    assert_eq!(code, Some(0), "{out}");
    let stepped = Instant::now();
    assert!(
        wait_until(Duration::from_secs(5), || safe_stopped_by(&instance, "target_lost")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    println!(
        "marks lost → safe stop after {:.2} s (faults.target_lost_s = 1)",
        stepped.elapsed().as_secs_f64()
    );
    let log = daemon.log();
    assert!(
        log.lines().any(|l| l.contains("ERROR") && l.contains("safe stop") && l.contains("target_lost")),
        "{log}"
    );
    // held at rest
    std::thread::sleep(Duration::from_millis(500));
    let fastest = fastest_joint_rad_s(&instance, "0.5");
    println!("in the safe stop: fastest joint {fastest:.5} rad/s");
    assert!(fastest < 0.01, "the arm is at rest: {fastest} rad/s");
    let (code, out) = vservoctl(&["resume", "--instance", &instance]);
    assert_eq!(code, Some(3), "refused while the marks are lost: {out}");
    assert!(out.contains("four marks"), "{out}");
    let (text_code, text) = vservoctl(&["status", "--instance", &instance]);
    assert_eq!(text_code, Some(0));
    assert!(text.contains("safe-stop") && text.contains("fault target_lost"), "{text}");

    // the board back: the marks are seen, the cell resumes on command and converges
    let (code, out) = vservoctl(&["object", "step", "--by-m", "0.2,0,0", "--instance", &instance]);
    assert_eq!(code, Some(0), "{out}");
    assert!(
        wait_until(Duration::from_secs(5), || vservoctl(&["resume", "--instance", &instance]).0 == Some(0)),
        "{}",
        daemon.log()
    );
    assert!(
        wait_until(Duration::from_secs(20), || status(&instance).is_some_and(|s| running(&s)
            && s["fault"]["active"] == false
            && s["feature_error_px"].as_f64().is_some_and(|e| e < 1.0))),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    assert!(daemon.log().contains("resumed on command after target_lost"), "{}", daemon.log());
    daemon.stop();
}

/// A robot driver of the test's own (velocity commands, 1 kHz) that reports what the test sets: fault bits,
/// its status, its joint count, or silence.
struct FakeDriver {
    faults: Arc<AtomicU32>,
    driver_status: Arc<AtomicU32>,
    joint_count: Arc<AtomicU32>,
    silent: Arc<AtomicBool>,
    _thread: LoopThread,
}

impl FakeDriver {
    fn start(instance: &str) -> Self {
        use vservo_protocol::{CommandMode, DriverStatus, JointCommandMsg, JointStateMsg, Topic};
        let faults = Arc::new(AtomicU32::new(0));
        let driver_status = Arc::new(AtomicU32::new(DriverStatus::Following.into()));
        let silent = Arc::new(AtomicBool::new(false));
        let joint_count = Arc::new(AtomicU32::new(6));
        let (f, d, q, n) = (faults.clone(), driver_status.clone(), silent.clone(), joint_count.clone());
        let instance = instance.to_string();
        let thread = LoopThread::spawn(move |s| {
            // started with the daemon: it waits for the instance, as a driver does (docs/DRIVERS.md)
            let dir = vservo_protocol::InstanceDir::locate_waiting(&instance, Duration::from_secs(10))
                .expect("the instance");
            let node = vservo_protocol::create_node_in(&dir, "test-driver").expect("a node");
            let states = vservo_protocol::publisher::<JointStateMsg>(&node, &instance, Topic::JointState)
                .expect("joint_state");
            let notifier = vservo_protocol::notifier(&node, &instance, Topic::JointState).expect("event");
            let commands =
                vservo_protocol::subscriber::<JointCommandMsg>(&node, &instance, Topic::JointCommand)
                    .expect("joint_command");
            let epoch = std::process::id() as u64;
            use std::f64::consts::{FRAC_PI_4, PI};
            let mut joints = [0.0, FRAC_PI_4, -PI, 0.0, FRAC_PI_4, 0.0, 0.0];
            let mut tick = 0u64;
            let started = Instant::now();
            while !s.load(Ordering::Relaxed) {
                tick += 1;
                let next = started + Duration::from_millis(tick);
                std::thread::sleep(next.saturating_duration_since(Instant::now()));
                while let Ok(Some(command)) = commands.receive() {
                    if command.driver_epoch == epoch {
                        for (j, v) in command.qd_ref_rad_s.iter().enumerate() {
                            joints[j] += v * 1e-3;
                        }
                    }
                }
                if q.load(Ordering::Relaxed) {
                    continue;
                }
                let stamp_ns = vservo_time::monotonic_ns();
                let _ = states.send_copy(JointStateMsg {
                    faults: f.load(Ordering::Relaxed),
                    tick,
                    stamp_ns,
                    driver_epoch: epoch,
                    period_ns: 1_000_000,
                    command_mode: CommandMode::Velocity.into(),
                    driver_status: d.load(Ordering::Relaxed),
                    joint_count: n.load(Ordering::Relaxed),
                    q_rad: joints,
                    torque_nm: [f64::NAN; vservo_protocol::MAX_JOINTS],
                    ..JointStateMsg::default()
                });
                let _ = notifier.notify();
            }
        });
        Self { faults, driver_status, joint_count, silent, _thread: thread }
    }
}

/// Issue 37: a joint move that takes the marks out of view, then `servo`: a `target_lost` stop. The resume is
/// refused saying that a joint move needs no marks, `servo` says the cell is held, a joint move back ends the
/// stop, and `servo` there converges again, with no restart. Another stop still refuses a joint move.
#[test]
fn a_target_lost_after_a_joint_move_is_left_by_a_joint_move_back() {
    let _one = exclusive();
    let instance = unique("lost-move");
    let (_config, daemon) = running_daemon(&instance);
    let states = echo_lines(&instance, "joint_state", "0.2");
    let q = numbers(&states.last().expect("a joint state")["q_rad"])[..6].to_vec();
    let csv = |q: &[f64]| q.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
    let ok = |args: &[&str]| {
        let (code, out) = vservoctl(args);
        assert_eq!(code, Some(0), "{args:?}: {out}");
        out
    };
    // the joint move at its goal, the arm at rest
    let arrived = || {
        assert!(
            wait_until(Duration::from_secs(10), || status(&instance).is_some_and(|s| s["state"] == "moving")
                && fastest_joint_rad_s(&instance, "0.3") < 0.01),
            "{}",
            daemon.log()
        )
    };
    // a turn of the waist by 1 rad: the board leaves the view
    let mut away = q.clone();
    away[0] += 1.0;
    ok(&["move-joints", "--instance", &instance, "--q", &csv(&away), "--speed-fraction", "0.3"]);
    arrived();
    ok(&["servo", "--instance", &instance]);
    assert!(
        wait_until(Duration::from_secs(10), || safe_stopped_by(&instance, "target_lost")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    let (code, out) = vservoctl(&["resume", "--instance", &instance]);
    assert!(code != Some(0) && out.contains("four marks") && out.contains("move-joints"), "{code:?}: {out}");
    let (code, out) = vservoctl(&["servo", "--instance", &instance]);
    assert!(code != Some(0) && out.contains("safe stop (target_lost)"), "{code:?}: {out}");
    // the way out: a joint move back, which ends the stop
    let out = ok(&["move-joints", "--instance", &instance, "--q", &csv(&q), "--speed-fraction", "0.3"]);
    assert!(out.contains("out of the safe stop (target_lost"), "{out}");
    arrived();
    ok(&["servo", "--instance", &instance]);
    assert!(
        wait_until(Duration::from_secs(20), || status(&instance)
            .is_some_and(|s| running(&s) && s["feature_error_px"].as_f64().is_some_and(|e| e < 1.0))),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    // any other stop still needs a resume first
    ok(&["safe-stop", "--instance", &instance]);
    let (code, out) = vservoctl(&["move-joints", "--instance", &instance, "--q", &csv(&q)]);
    assert!(code != Some(0) && out.contains("`vservoctl resume` first"), "{code:?}: {out}");
    daemon.stop();
}

/// The default cell with an external camera (none sends frames) and the test's driver, running: its instance,
/// daemon, driver and configuration (kept while the daemon runs).
fn cell_with_fake_driver(name: &str) -> (String, Daemon, FakeDriver, impl Sized) {
    let instance = unique(name);
    let config = config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("source = \"simulated\"", "source = \"external\""),
            (
                "driver = \"simulated\"",
                "driver = \"external\"\ncommand = \"velocity\"\nstart = \"servoing\"\nspeed_scale = 1.0",
            ),
        ],
    );
    let daemon = Daemon::start(&config);
    let driver = FakeDriver::start(&instance);
    assert!(
        wait_until(Duration::from_secs(10), || status(&instance).is_some_and(|s| running(&s))),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    (instance, daemon, driver, config)
}

/// With an external driver (the test's): a torque saturation that lasts, a driver fault, a joint beyond its
/// position range, a stall and a client's request each end in a safe stop that names it (and the joint),
/// with an ERROR line; a short saturation does not; a resume is refused, naming the cause, while it is
/// there, and accepted once it is gone.
#[test]
fn faults_of_the_robot_end_in_a_named_safe_stop_and_resume_waits_for_their_cause() {
    use vservo_protocol::fault_bits;
    let _one = exclusive();
    let (instance, daemon, driver, _config) = cell_with_fake_driver("driver-faults");
    let resume = || vservoctl(&["resume", "--instance", &instance]);

    // joint 2's torque at its limit: 0.3 s is no fault, lasting past faults.saturation_s (0.5 s) is
    let saturated_joint_2 = 1 << (fault_bits::TORQUE_SATURATED_SHIFT + 1);
    driver.faults.store(saturated_joint_2, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(300));
    driver.faults.store(0, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(300));
    assert!(
        status(&instance).is_some_and(|s| running(&s)),
        "a short saturation is no fault: {:?}",
        status(&instance)
    );
    driver.faults.store(saturated_joint_2, Ordering::Relaxed);
    assert!(
        wait_until(Duration::from_secs(3), || safe_stopped_by(&instance, "torque_saturated")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    assert_eq!(status(&instance).expect("status")["fault"]["joints"], serde_json::json!([2]));
    let (code, out) = resume();
    assert_eq!(code, Some(3), "{out}");
    assert!(out.contains("joint 2 torque is at its limit"), "{out}");
    driver.faults.store(0, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(resume().0, Some(0));
    assert!(wait_until(Duration::from_secs(2), || status(&instance).is_some_and(|s| running(&s))));

    // a driver fault, for a moment: at once
    driver.driver_status.store(vservo_protocol::DriverStatus::Fault.into(), Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(20));
    driver.driver_status.store(vservo_protocol::DriverStatus::Following.into(), Ordering::Relaxed);
    assert!(
        wait_until(Duration::from_secs(2), || safe_stopped_by(&instance, "driver_fault")),
        "{:?}",
        status(&instance)
    );
    assert_eq!(resume().0, Some(0));

    // joint 5 beyond its range
    driver.faults.store(1 << (fault_bits::POSITION_LIMIT_SHIFT + 4), Ordering::Relaxed);
    assert!(
        wait_until(Duration::from_secs(2), || safe_stopped_by(&instance, "position_limit")),
        "{:?}",
        status(&instance)
    );
    assert_eq!(status(&instance).expect("status")["fault"]["joints"], serde_json::json!([5]));
    let (code, out) = resume();
    assert!(code == Some(3) && out.contains("joint 5 is beyond its position range"), "{out}");
    driver.faults.store(0, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(200));
    let (code, out) = resume();
    assert_eq!(code, Some(0), "{out}");

    // the driver falls silent: robot_stalled; no resume until its states come again
    driver.silent.store(true, Ordering::Relaxed);
    assert!(
        wait_until(Duration::from_secs(2), || safe_stopped_by(&instance, "robot_stalled")),
        "{:?}",
        status(&instance)
    );
    let (code, out) = resume();
    assert!(code == Some(3) && out.contains("do not arrive"), "{out}");
    driver.silent.store(false, Ordering::Relaxed);
    assert!(wait_until(Duration::from_secs(3), || resume().0 == Some(0)), "{}", daemon.log());

    // a client's safe stop, and a second one refused
    let (code, out) = vservoctl(&["safe-stop", "--instance", &instance]);
    assert_eq!(code, Some(0), "{out}");
    assert!(safe_stopped_by(&instance, "requested"));
    assert_eq!(vservoctl(&["safe-stop", "--instance", &instance]).0, Some(3));
    assert_eq!(resume().0, Some(0));
    assert_eq!(resume().0, Some(3), "nothing to resume");

    let after = status(&instance).expect("status");
    assert_eq!(after["safe_stops"], 5, "{after}");
    let log = daemon.log();
    for name in ["torque_saturated", "driver_fault", "position_limit", "robot_stalled", "requested"] {
        assert!(
            log.lines().any(|l| l.contains("ERROR") && l.contains("safe stop") && l.contains(name)),
            "{name}: {log}"
        );
        assert!(log.contains(&format!("resumed on command after {name}")), "{name}: {log}");
    }
    drop(driver);
    daemon.stop();
}

/// A driver of another arm (seven joints where the configuration has six): the rmrc does not follow it, the
/// cell stops with a driver fault that says so, and it resumes once the driver reports the configured arm.
#[test]
fn a_driver_of_another_joint_count_is_refused_by_name() {
    let _one = exclusive();
    let (instance, daemon, driver, _config) = cell_with_fake_driver("joint-count");
    driver.joint_count.store(7, Ordering::Relaxed);
    assert!(
        wait_until(Duration::from_secs(2), || safe_stopped_by(&instance, "driver_fault")),
        "{:?}",
        status(&instance)
    );
    let (code, out) = vservoctl(&["resume", "--instance", &instance]);
    assert!(code == Some(3) && out.contains("reports 7 joints; the configured arm has 6"), "{out}");
    driver.joint_count.store(6, Ordering::Relaxed);
    assert!(
        wait_until(Duration::from_secs(3), || vservoctl(&["resume", "--instance", &instance]).0 == Some(0)),
        "{}",
        daemon.log()
    );
    assert!(daemon.log().contains("reports 7 joints"), "{}", daemon.log());
    drop(driver);
    daemon.stop();
}

/// Idle clients hold no command slot (twenty Python clients, each sending a command in turn); with every
/// slot held by others, `vservoctl` and the Python client answer "busy" (exit 75) without crashing; the
/// slots of a client process that is killed are freed; a flood of commands is logged as its first lines
/// and a summary.
#[test]
fn idle_or_gone_clients_hold_no_slot_a_full_service_answers_busy_and_floods_are_summarised() {
    let _one = exclusive();
    let instance = unique("slots");
    let (_config, daemon) = running_daemon(&instance);
    let python = vservo_system_tests::repository_root().join("target/python-venv/bin/python");
    let client_dir = vservo_system_tests::repository_root().join("clients/python");
    let script = format!(
        r#"
import sys, time
sys.path.insert(0, {dir:?})
import vservo_client as v
clients = [v.Client({instance:?}) for _ in range(20)]
replies = [c.reload().accepted for c in clients]
print("accepted", sum(replies), "of", len(replies))
"#,
        dir = client_dir.display().to_string(),
        instance = instance
    );
    let out = std::process::Command::new(&python).args(["-c", &script]).output().expect("python runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("accepted 20 of 20"), "{stdout}{}", String::from_utf8_lossy(&out.stderr));

    // a process that takes every slot and keeps them
    let hog = format!(
        r#"
import sys, time
import iceoryx2 as iox2
sys.path.insert(0, {dir:?})
import vservo_client as v
c = v.Client({instance:?})
service = c.node.service_builder(c._service_name("command")).request_response(v.Command, v.CommandReply).open()
ports = [service.client_builder().create() for _ in range(16)]
print("holding", len(ports), flush=True)
time.sleep(60)
"#,
        dir = client_dir.display().to_string(),
        instance = instance
    );
    let mut holder = vservo_system_tests::Killed(
        std::process::Command::new(&python)
            .args(["-c", &hog])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("python runs"),
    );
    {
        use std::io::BufRead;
        let mut line = String::new();
        let stdout = holder.0.stdout.as_mut().expect("piped");
        std::io::BufReader::new(stdout).read_line(&mut line).expect("the holder says so");
        assert!(line.contains("holding 16"), "{line}");
    }
    let (code, out) = vservoctl(&["reload", "--instance", &instance]);
    assert_eq!(code, Some(75), "{out}");
    assert!(out.contains("busy") && !out.contains("panicked"), "{out}");
    let out = std::process::Command::new(&python)
        .arg(client_dir.join("vservo_client.py"))
        .args(["--instance", &instance, "reload"])
        .output()
        .expect("python runs");
    assert_eq!(out.status.code(), Some(75), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("Traceback"));
    // the holder dies without letting go: its slots come back
    holder.signal(nix::sys::signal::Signal::SIGKILL);
    let _ = holder.0.wait();
    let freed = Instant::now();
    assert!(
        wait_until(Duration::from_secs(10), || vservoctl(&["reload", "--instance", &instance]).0 == Some(0)),
        "{}",
        daemon.log()
    );
    println!("a killed client's slots were free again after {:.1} s", freed.elapsed().as_secs_f64());

    // a flood: ten clients at once, 10 commands each
    let flood = format!(
        r#"
import sys
sys.path.insert(0, {dir:?})
import vservo_client as v
c = v.Client({instance:?})
print(sum(c.set_target([151, 168, 318, 178, 339, 75, 172, 70 + (i % 2)]).accepted for i in range(10)))
"#,
        dir = client_dir.display().to_string(),
        instance = instance
    );
    let flooders: Vec<std::process::Child> = (0..10)
        .map(|_| {
            std::process::Command::new(&python)
                .args(["-c", &flood])
                .stdout(std::process::Stdio::piped())
                .spawn()
                .expect("python runs")
        })
        .collect();
    let accepted: u64 = flooders
        .into_iter()
        .map(|f| {
            let out = f.wait_with_output().expect("a flooder ends");
            String::from_utf8_lossy(&out.stdout).trim().parse::<u64>().unwrap_or(0)
        })
        .sum();
    assert_eq!(accepted, 100, "{}", daemon.log());
    std::thread::sleep(Duration::from_millis(1500));
    let log = daemon.log();
    let lines = log.lines().filter(|l| l.contains("command accepted")).count();
    let summaries: Vec<&str> = log.lines().filter(|l| l.contains("command flood")).collect();
    let summarised: u64 = summaries
        .iter()
        .filter_map(|l| l.split("command flood: ").nth(1)?.split(' ').next()?.parse::<u64>().ok())
        .sum();
    println!(
        "100 commands: {lines} lines one by one in the whole run, {} summaries covering {summarised}",
        summaries.len()
    );
    assert!(!summaries.is_empty(), "{log}");
    assert!(lines as u64 + summarised >= 100, "every command is in a line or a summary\n{log}");
    // ten lines a second at most (the unit test of the limit holds the arithmetic): at the flood's pace
    // (about 20 commands a second here) about half of it goes into the summaries
    assert!(summarised >= 30, "{summarised} commands summarised\n{log}");
    daemon.stop();
}

/// An external robot driver and an external camera that never appear (not started, another instance, another
/// schema) are said within 5 s: vservod would otherwise wait at "robot waiting" for good. And the cell it waits for
/// starts held.
#[test]
fn a_robot_driver_and_a_camera_that_never_appear_are_said_within_five_seconds() {
    let _one = exclusive();
    let instance = unique("no-driver");
    let config = config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("source = \"simulated\"", "source = \"external\""),
            ("driver = \"simulated\"", "driver = \"external\"\ncommand = \"velocity\"\nspeed_scale = 1.0"),
        ],
    );
    let daemon = Daemon::start(&config);
    let started = Instant::now();
    let said = || {
        let log = daemon.log();
        log.contains("no robot driver has appeared") && log.contains("no camera driver has appeared")
    };
    assert!(wait_until(Duration::from_secs(5), said), "{}", daemon.log());
    assert!(
        started.elapsed() >= Duration::from_secs(2),
        "not before it could have appeared: {}",
        daemon.log()
    );
    assert!(daemon.log().contains("the cell starts held"), "{}", daemon.log());
}
