//! Issue 22, part of it: a safe stop is always reachable (the safe-stop path, which no client can crowd
//! out, even with every command slot held); what the configuration accepts, the cell can do (a camera larger
//! than `camera_image` carries, configuration paths that are not regular files or are too long, refused at
//! once); a camera that sends no frame is a named fault (`camera_stalled`), and a stopped vision process is a
//! hang, never also a stalled camera. Real processes over iceoryx2, one test at a time.

use std::process::{Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use vservo_system_tests::{
    Daemon, Killed, binary, config_from, exclusive, fastest_joint_rad_s, repository_root, running,
    running_daemon, safe_stopped_by, status, unique, vservoctl, wait_until,
};

fn python() -> std::path::PathBuf {
    repository_root().join("target/python-venv/bin/python")
}

fn python_client(args: &[&str]) -> (Option<i32>, String) {
    let out = Command::new(python())
        .arg(repository_root().join("clients/python/vservo_client.py"))
        .args(args)
        .output()
        .expect("python runs");
    (
        out.status.code(),
        format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)),
    )
}

/// Another process that takes all 16 command slots and keeps them (killed when dropped).
fn hold_every_command_slot(instance: &str) -> Killed {
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
time.sleep(120)
"#,
        dir = repository_root().join("clients/python").display().to_string(),
    );
    let mut holder = Killed(
        Command::new(python()).args(["-c", &hog]).stdout(Stdio::piped()).spawn().expect("python runs"),
    );
    use std::io::BufRead;
    let mut line = String::new();
    let stdout = holder.0.stdout.as_mut().expect("piped");
    std::io::BufReader::new(stdout).read_line(&mut line).expect("the holder says so");
    assert!(line.contains("holding 16"), "{line}");
    holder
}

/// With every command slot held by another process, `vservoctl safe-stop` stops the cell by the safe-stop
/// path: the status shows `safe-stop` with fault `requested` within a second and the arm comes to rest.
/// The Python client's safe stop takes the same path. With no daemon, the path says so at once.
#[test]
fn with_every_command_slot_held_safe_stop_still_stops_the_cell() {
    let _one = exclusive();
    let instance = unique("stoppath");
    let (_config, daemon) = running_daemon(&instance);
    let holder = hold_every_command_slot(&instance);
    // the premise: a normal command finds no slot
    let (code, out) = vservoctl(&["reload", "--instance", &instance]);
    assert_eq!(code, Some(75), "{out}");
    let (code, out) = python_client(&["--instance", &instance, "reload"]);
    assert_eq!(code, Some(75), "{out}");

    let asked = Instant::now();
    let (code, out) = vservoctl(&["safe-stop", "--instance", &instance]);
    let answered_s = asked.elapsed().as_secs_f64();
    assert_eq!(code, Some(0), "{out}\n{}", daemon.log());
    assert!(out.contains("fault requested"), "{out}");
    assert!(
        wait_until(Duration::from_secs(1), || safe_stopped_by(&instance, "requested")),
        "{:?}",
        status(&instance)
    );
    let shown_s = asked.elapsed().as_secs_f64();
    let log = daemon.log();
    assert_eq!(
        log.lines().filter(|l| l.contains("ERROR") && l.contains("safe-stop path")).count(),
        1,
        "one line, naming the path: {log}"
    );
    // the arm ramps to rest and is held there
    std::thread::sleep(Duration::from_millis(1500));
    let fastest = fastest_joint_rad_s(&instance, "0.5");
    assert!(fastest < 0.01, "the arm is at rest: {fastest} rad/s");
    println!(
        "slots held: vservoctl safe-stop answered (confirmed) after {:.0} ms, status shown within {:.0} ms; \
         joints at most {fastest:.2e} rad/s 1.5 s later ({})",
        answered_s * 1e3,
        shown_s * 1e3,
        out.trim()
    );

    // the Python client takes the same path: the cell is held already, which it says (exit 3)
    let (code, out) = python_client(&["--instance", &instance, "safe-stop"]);
    assert_eq!(code, Some(3), "{out}");
    assert!(out.contains("already in a safe stop (requested)"), "{out}");

    // slots free again: resume, then the Python client stops the cell itself
    drop(holder);
    assert!(
        wait_until(Duration::from_secs(10), || vservoctl(&["resume", "--instance", &instance]).0 == Some(0)),
        "{}",
        daemon.log()
    );
    let asked = Instant::now();
    let (code, out) = python_client(&["--instance", &instance, "safe-stop"]);
    assert_eq!(code, Some(0), "{out}");
    assert!(out.contains("fault requested"), "{out}");
    assert!(safe_stopped_by(&instance, "requested"), "{:?}", status(&instance));
    println!("Python client: {} ({:.0} ms)", out.trim(), asked.elapsed().as_secs_f64() * 1e3);

    // no daemon: nobody reads the path, said at once
    daemon.stop();
    let asked = Instant::now();
    let (code, out) = vservoctl(&["safe-stop", "--instance", &instance]);
    assert_eq!(code, Some(1), "{out}");
    assert!(out.contains("not running"), "{out}");
    assert!(asked.elapsed() < Duration::from_secs(2), "at once: {:?}", asked.elapsed());
}

/// Runs a binary, killing it if it has not exited after `guard`; its exit code (None: killed), output and
/// how long it ran.
fn run_guarded(name: &str, args: &[&str], guard: Duration) -> (Option<i32>, String, Duration) {
    let started = Instant::now();
    let mut child = Killed(
        Command::new(binary(name))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("starts"),
    );
    let code = loop {
        if let Some(exit) = child.0.try_wait().expect("waits") {
            break exit.code();
        }
        if started.elapsed() > guard {
            break None;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let took = started.elapsed();
    let mut text = String::new();
    if code.is_some() {
        use std::io::Read;
        let _ = child.0.stdout.take().map(|mut o| o.read_to_string(&mut text));
        let _ = child.0.stderr.take().map(|mut e| e.read_to_string(&mut text));
    }
    (code, text, took)
}

/// A 16384² camera is refused at start naming the key; `/dev/zero`, a FIFO, a directory and a file over
/// 1 MiB given as the configuration are refused at once, naming the file, by vservod and vservoctl.
#[test]
fn what_the_configuration_accepts_the_cell_can_do() {
    let _one = exclusive();
    let huge = config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{}\"", unique("huge"))),
            ("width_px = 512", "width_px = 16384"),
            ("height_px = 512", "height_px = 16384"),
        ],
    );
    let guard = Duration::from_secs(20);
    for (name, args) in [
        ("vservod", vec!["--config", huge.path.to_str().expect("utf-8")]),
        ("vservoctl", vec!["sim", "--config", huge.path.to_str().expect("utf-8"), "--out", "/nonexistent/x"]),
        ("vservoctl", vec!["gains", "--config", huge.path.to_str().expect("utf-8")]),
    ] {
        let (code, out, took) = run_guarded(name, &args, guard);
        assert!(code.is_some_and(|c| c != 0), "{name} {args:?}: {code:?} {out}");
        assert!(out.contains("camera.width_px") && out.contains("1310720"), "{name} {args:?}: {out}");
        println!("{name} {}: refused in {:.0} ms", args[0], took.as_secs_f64() * 1e3);
    }

    let scratch = std::env::temp_dir().join(format!("vservo-stop-path-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).expect("scratch");
    let fifo = scratch.join("fifo.toml");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::from_bits_truncate(0o600)).expect("mkfifo");
    let long = scratch.join("long.toml");
    let mut text = std::fs::read_to_string(vservo_system_tests::default_config()).expect("default");
    while text.len() as u64 <= vservo_config::MAX_CONFIG_FILE_BYTES {
        text.push_str(&format!("# {}\n", "padding ".repeat(16)));
    }
    std::fs::write(&long, text).expect("written");
    let cases = [
        ("/dev/zero", "a character device"),
        (fifo.to_str().expect("utf-8"), "a FIFO"),
        (scratch.to_str().expect("utf-8"), "a directory"),
        (long.to_str().expect("utf-8"), "longer than 1 MiB"),
    ];
    for (path, why) in cases {
        for (name, args) in [
            ("vservod", vec!["--config", path]),
            ("vservoctl", vec!["gains", "--config", path]),
            ("vservoctl", vec!["status", "--config", path]),
        ] {
            let (code, out, took) = run_guarded(name, &args, Duration::from_secs(10));
            assert!(code.is_some_and(|c| c != 0), "{name} {args:?}: exit {code:?} after {took:?}: {out}");
            assert!(out.contains(path) && out.contains(why), "{name} {args:?}: {out}");
            assert!(took < Duration::from_secs(5), "{name} {args:?}: {took:?}");
            println!("{name} {} {path}: refused in {:.0} ms ({why})", args[0], took.as_secs_f64() * 1e3);
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
}

/// A camera thread like vservod_external_camera's: the board at the desired pose, one frame every vision
/// period, while `sending` is set.
fn start_camera(
    instance: &str,
    config: &vservo_config::Config,
    sending: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    last_sent: Arc<std::sync::Mutex<Option<Instant>>>,
) -> std::thread::JoinHandle<()> {
    let instance = instance.to_string();
    let config = config.clone();
    std::thread::spawn(move || {
        let dir = vservo_protocol::InstanceDir::locate_waiting(&instance, Duration::from_secs(10))
            .expect("the instance");
        let node = vservo_protocol::create_node_in(&dir, "test-camera").expect("a node");
        let publisher = vservo_protocol::camera_image_publisher(&node, &instance).expect("camera_image");
        let notifier = vservo_protocol::camera_image_notifier(&node, &instance).expect("camera_image event");
        let mut renderer = vservo_vision::Renderer::new(config.cell.camera, config.cell.vision.render);
        let image = renderer.render(&config.cell.board, &config.cell.desired.camera_from_board, 0).clone();
        let period = Duration::from_secs_f64(config.cell.timing.vision_period_s);
        let mut frame = 0;
        while !stop.load(Ordering::Relaxed) {
            if sending.load(Ordering::Relaxed) {
                let now_ns = vservo_time::monotonic_ns();
                vservo_runtime::nodes::vision::publish_image(
                    &publisher,
                    &image,
                    (frame, now_ns),
                    vservo_protocol::Exposure::UNKNOWN,
                );
                let _ = notifier.notify();
                *last_sent.lock().expect("lock") = Some(Instant::now());
                frame += 1;
            }
            std::thread::sleep(period);
        }
    })
}

/// An external camera that stops sending frames: a safe stop named `camera_stalled`, not before the
/// timeout (6 vision periods, 0.51 s), within the timeout plus a telemetry period and a supervisor cycle;
/// resume is refused while no frame comes and allowed once frames come again.
#[test]
fn an_external_camera_that_stops_sending_is_a_named_fault_and_frames_again_allow_a_resume() {
    let _one = exclusive();
    let instance = unique("camstall");
    let config = config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("source = \"simulated\"", "source = \"external\""),
        ],
    );
    let loaded = vservo_config::Config::load(&config.path).expect("config");
    let timeout = loaded.faults.camera_timeout(loaded.cell.timing.vision_period_s);
    let daemon = Daemon::start(&config);
    let (sending, stop) = (Arc::new(AtomicBool::new(true)), Arc::new(AtomicBool::new(false)));
    let last_sent = Arc::new(std::sync::Mutex::new(None));
    let camera = start_camera(&instance, &loaded, sending.clone(), stop.clone(), last_sent.clone());
    assert!(
        wait_until(Duration::from_secs(15), || status(&instance).is_some_and(|s| running(&s))),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    // frames for a while: no fault
    std::thread::sleep(Duration::from_secs(2));
    assert!(status(&instance).is_some_and(|s| running(&s)), "{:?}", status(&instance));

    sending.store(false, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(100));
    let last = last_sent.lock().expect("lock").expect("frames were sent");
    assert!(
        wait_until(Duration::from_secs(3), || safe_stopped_by(&instance, "camera_stalled")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    let after = last.elapsed();
    assert!(after >= timeout, "not before the timeout: {after:?} < {timeout:?}");
    let log = daemon.log();
    assert!(
        log.lines().any(|l| l.contains("ERROR") && l.contains("camera_stalled") && l.contains("no frame")),
        "{log}"
    );
    let (code, out) = vservoctl(&["resume", "--instance", &instance]);
    assert!(code == Some(3) && out.contains("no frame"), "refused while no frame comes: {out}");

    sending.store(true, Ordering::Relaxed);
    let back = Instant::now();
    assert!(
        wait_until(Duration::from_secs(3), || vservoctl(&["resume", "--instance", &instance]).0 == Some(0)),
        "{}",
        daemon.log()
    );
    println!(
        "camera silent: safe stop camera_stalled seen {:.0} ms after the last frame (timeout {:.0} ms; status polled); \
         resumed {:.0} ms after frames came again",
        after.as_secs_f64() * 1e3,
        timeout.as_secs_f64() * 1e3,
        back.elapsed().as_secs_f64() * 1e3
    );
    stop.store(true, Ordering::Relaxed);
    let _ = camera.join();
    daemon.stop();
}

/// The simulated camera is the vision node's own loop: it cannot stall apart from its node (or from the
/// robot whose joint states it renders on). A stopped vision process (SIGSTOP) is a hung node, killed and
/// restarted by the supervisor, and never also a `camera_stalled` fault.
#[test]
fn a_stopped_vision_process_is_a_hung_node_not_a_stalled_camera() {
    let _one = exclusive();
    let instance = unique("visstop");
    let (_config, daemon) = running_daemon(&instance);
    let before = status(&instance).expect("status");
    let pid = before["nodes"]["vision"]["pid"].as_u64().expect("vision pid") as i32;
    kill(Pid::from_raw(pid), Signal::SIGSTOP).expect("SIGSTOP");
    let stopped = Instant::now();
    let mut faults_seen = Vec::new();
    let restarted = wait_until(Duration::from_secs(8), || {
        let now = status(&instance);
        if let Some(fault) = now.as_ref().and_then(|s| s["fault"]["name"].as_str()) {
            faults_seen.push(fault.to_string());
        }
        now.is_some_and(|s| s["nodes"]["vision"]["restarts"] == 1 && running(&s))
    });
    assert!(restarted, "{:?}\n{}", status(&instance), daemon.log());
    let log = daemon.log();
    assert!(log.contains("node hung"), "{log}");
    assert!(!log.contains("camera_stalled"), "no double report: {log}");
    assert!(!faults_seen.iter().any(|f| f == "camera_stalled"), "{faults_seen:?}");
    println!(
        "vision stopped: hung, restarted and running again after {:.1} s; faults seen: {:?}",
        stopped.elapsed().as_secs_f64(),
        faults_seen
    );
    daemon.stop();
}

/// The safe-stop path is the daemon's user's only (mode 0600 in the instance's 0750 directory), as the
/// command service is: another local user (`nobody`) cannot write it, and the cell keeps running; the same
/// write by the daemon's user stops it. Needs root (to be `nobody`).
#[test]
fn another_user_cannot_ask_on_the_safe_stop_path() {
    use std::os::unix::fs::MetadataExt;
    if std::fs::metadata("/proc/self").map(|m| m.uid()).ok() != Some(0) {
        println!("skipped: needs root to write as nobody");
        return;
    }
    let _one = exclusive();
    let instance = unique("stopother");
    let (_config, daemon) = running_daemon(&instance);
    let path = vservo_protocol::InstanceDir::locate(&instance).expect("the instance").safe_stop_path();
    let mode = std::fs::symlink_metadata(&path).expect("the safe-stop path").mode();
    assert_eq!(mode & 0o777, 0o600, "{mode:o}");
    let write_as = |user: Option<&str>| {
        let script = format!("printf x > '{}'", path.display());
        let mut command = match user {
            Some(user) => {
                let mut c = Command::new("runuser");
                c.args(["-u", user, "--", "sh", "-c", &script]);
                c
            }
            None => {
                let mut c = Command::new("sh");
                c.args(["-c", &script]);
                c
            }
        };
        command.current_dir("/").output().expect("runs")
    };
    let refused = write_as(Some("nobody"));
    assert!(!refused.status.success(), "nobody wrote the safe-stop path");
    std::thread::sleep(Duration::from_millis(300));
    assert!(status(&instance).is_some_and(|s| running(&s)), "{:?}", status(&instance));
    // the premise: the same write by the daemon's user stops the cell
    assert!(write_as(None).status.success());
    assert!(
        wait_until(Duration::from_secs(1), || safe_stopped_by(&instance, "requested")),
        "{:?}",
        status(&instance)
    );
    println!("nobody's write refused: {}", String::from_utf8_lossy(&refused.stderr).trim());
    daemon.stop();
}

/// The security review's swap: a process of the daemon's user replaced the safe-stop FIFO with a plain file, and
/// every request written to it was swallowed. Now the daemon sees the path is no longer its FIFO within a cycle:
/// a safe stop (`requested`), an ERROR line saying so, and the FIFO made again, which then takes requests as
/// before.
#[test]
fn a_replaced_safe_stop_path_is_a_safe_stop_and_is_made_again() {
    use std::os::unix::fs::FileTypeExt;
    let _one = exclusive();
    let instance = unique("stop-path-swap");
    let (_config, daemon) = running_daemon(&instance);
    let dir = vservo_protocol::InstanceDir::locate(&instance).expect("the instance's directory");
    let path = dir.safe_stop_path();
    std::fs::remove_file(&path).expect("the FIFO removed");
    std::fs::write(&path, b"").expect("a plain file in its place");
    assert!(
        wait_until(Duration::from_secs(2), || safe_stopped_by(&instance, "requested")),
        "{:?}\n{}",
        status(&instance),
        daemon.log()
    );
    assert!(daemon.log().contains("the safe-stop path was replaced"), "{}", daemon.log());
    assert!(
        wait_until(Duration::from_secs(1), || {
            std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_fifo())
        }),
        "the FIFO made again"
    );
    // it takes requests again: resume, then a safe stop on the path
    assert_eq!(vservoctl(&["resume", "--instance", &instance]).0, Some(0));
    assert!(wait_until(Duration::from_secs(2), || status(&instance).is_some_and(|s| running(&s))));
    let (code, out) = vservoctl(&["safe-stop", "--instance", &instance]);
    assert_eq!(code, Some(0), "{out}");
    assert!(safe_stopped_by(&instance, "requested"), "{out}");
    daemon.stop();
}

/// Issue 37: vservod answers SIGTERM within a second during any parse. The longest the bounds allow: a
/// configuration of a megabyte with its bases (an overlay of config/arms/ur5e.toml padded with comments)
/// reading a URDF of nearly the most elements (the UR5e with 4,900 more links on fixed joints: 19,634), a
/// valid arm. SIGTERM at 5, 30 and 100 ms into the start: vservod ends within the bar with 0, having started
/// nothing when the stop came while it read.
#[test]
fn vservod_answers_sigterm_within_a_second_while_it_parses_the_longest_files_the_bounds_allow() {
    let _one = exclusive();
    let root = repository_root();
    // its collision meshes named from where the copy is (the file names them relative to config/arms/)
    let meshes = root.join("target/airo_models").display().to_string();
    let ur5e = std::fs::read_to_string(root.join("config/arms/ur5e.urdf"))
        .expect("the UR5e")
        .replace("../../target/airo_models", &meshes);
    let extra: String = (0..4_900)
        .map(|i| {
            format!(
                "<link name=\"x{i}\"/><joint name=\"xj{i}\" type=\"fixed\"><parent link=\"base_link\"/>\
                 <child link=\"x{i}\"/></joint>\n"
            )
        })
        .collect();
    let scratch = vservo_system_tests::ScratchDir::new(&unique("longest-parse"));
    let urdf = scratch.write("long.urdf", &ur5e.replace("</robot>", &format!("{extra}</robot>")));
    let mut text = format!(
        "extends = \"{}\"\n[instance]\nname = \"{}\"\n[robot.arm]\nurdf = \"{}\"\n",
        root.join("config/arms/ur5e.toml").display(),
        unique("longest-parse"),
        urdf.display()
    );
    let bases: u64 = ["config/arms/ur5e.toml", "config/vservo-robust.toml", "config/vservo.toml"]
        .iter()
        .map(|base| std::fs::metadata(root.join(base)).map_or(0, |m| m.len()))
        .sum();
    let line = "# padding padding padding padding padding padding padding padding padding padding\n";
    while (text.len() + line.len()) as u64 + bases <= vservo_config::MAX_CONFIG_FILE_BYTES {
        text.push_str(line);
    }
    let config = vservo_system_tests::TempConfig::written(&text);
    // the premise: the files are within the bounds, a configuration that runs
    let started = Instant::now();
    let loaded = vservo_config::Config::load(&config.path);
    println!("the longest files, read in this process in {:.3} s", started.elapsed().as_secs_f64());
    assert!(loaded.is_ok(), "{:?}", loaded.err());
    for delay_ms in [5u64, 30, 100] {
        let mut daemon = Daemon::start(&config);
        std::thread::sleep(Duration::from_millis(delay_ms));
        let signalled = Instant::now();
        daemon.signal(Signal::SIGTERM);
        let code = daemon.wait(Duration::from_secs(10));
        let answered = signalled.elapsed();
        let log = daemon.log();
        println!(
            "SIGTERM {delay_ms} ms into the start: exit {code:?} {:.3} s after it{}",
            answered.as_secs_f64(),
            if log.contains("nothing was started") { ", nothing started" } else { "" }
        );
        assert_eq!(code, Some(0), "{log}");
        assert!(answered < Duration::from_secs(1), "answered after {answered:?}\n{log}");
    }
}
