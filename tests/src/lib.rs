//! # vservo-system-tests — end-to-end tests
//!
//! Owns the tests that run vservo's built binaries the way a user does (command lines, exit codes, the
//! daemon and its processes). This library holds only the helpers those tests share.

use std::path::PathBuf;
use std::process::{Command, Output};

/// The path of a workspace binary built by the same `cargo test` run (`target/<profile>/<name>`).
///
/// `cargo test --workspace` compiles every package's binaries before it runs any test, so the binary is
/// there; the panic says what to do when a test is run on its own.
pub fn binary(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows its own path");
    // target/<profile>/deps/<test>-<hash>
    let profile_dir = exe.parent().and_then(|deps| deps.parent()).expect("target/<profile>/deps");
    let path = profile_dir.join(name);
    assert!(
        path.exists(),
        "{} is not built: run `cargo build --workspace` (or the whole `cargo test --workspace`)",
        path.display()
    );
    path
}

/// Runs a workspace binary with arguments and returns its output.
pub fn run(name: &str, args: &[&str]) -> Output {
    Command::new(binary(name)).args(args).output().expect("the binary starts")
}

/// The repository's root (where `config/` is).
pub fn repository_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ is inside the repository").to_path_buf()
}

/// The default configuration file.
pub fn default_config() -> PathBuf {
    repository_root().join("config/vservo.toml")
}

/// A copy of the default configuration with one piece of text replaced, written to a temporary file that
/// lives as long as the returned guard.
pub fn config_with(old: &str, new: &str) -> TempConfig {
    let text = std::fs::read_to_string(default_config()).expect("the default config is readable");
    assert!(text.contains(old), "the default config holds {old:?}");
    TempConfig::written(&text.replacen(old, new, 1))
}

static TEMP_COUNTER: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A temporary configuration file, removed when dropped.
pub struct TempConfig {
    /// Its path.
    pub path: PathBuf,
    /// The instance it names when written (a test may overwrite the file since).
    instance: Option<String>,
}

impl TempConfig {
    /// `text` in a temporary file of its own (an `extends` in it must be an absolute path).
    pub fn written(text: &str) -> TempConfig {
        let path = std::env::temp_dir().join(format!(
            "vservo-test-{}-{}.toml",
            std::process::id(),
            TEMP_COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        ));
        std::fs::write(&path, text).expect("temporary file is writable");
        let instance = vservo_config::Config::instance_of(&path).ok();
        TempConfig { path, instance }
    }

    /// The path as a string for command lines.
    pub fn arg(&self) -> String {
        self.path.display().to_string()
    }
}

impl Drop for TempConfig {
    /// Removes the file and, for an instance of this test run (its name, as written, ends in `-<this process id>`), what
    /// its daemon left: the instance's runtime directory and shared memory. A test's configuration outlives
    /// its daemons (they are declared after it, and dropped — killed and waited for — first), so this runs
    /// when the test is over, passed or failed.
    fn drop(&mut self) {
        if let Some(instance) = &self.instance
            && instance.ends_with(&format!("-{}", std::process::id()))
        {
            remove_instance(instance);
        }
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Removes what a stopped instance leaves behind: its runtime directory (lock, prefix, configuration,
/// safe-stop path; kept by the daemon for drivers across its restarts) and its shared memory
/// (`/dev/shm/<prefix>*`).
pub fn remove_instance(instance: &str) {
    let Ok(dir) = vservo_protocol::InstanceDir::locate(instance) else { return };
    if let Ok(entries) = std::fs::read_dir("/dev/shm") {
        for entry in entries.flatten() {
            if entry.file_name().to_string_lossy().starts_with(&dir.prefix) {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir.path);
}

mod scripts;
pub use scripts::{run_file, run_script, run_script_to_convergence};

// ---- the daemon, for the tests that run it (one at a time per test binary) ----

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use serde_json::Value;

/// One real-time test at a time: they measure timing on a two-core machine.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Holds the one-test-at-a-time lock of this test binary: the daemon tests measure timing on two cores.
pub fn exclusive() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A configuration of the default cell under its own instance name.
pub fn instance_config(instance: &str) -> TempConfig {
    config_with("name = \"default\"", &format!("name = \"{instance}\""))
}

/// An instance name no other test or run uses.
pub fn unique(name: &str) -> String {
    format!("it-{name}-{}", std::process::id())
}

/// A folder for a test's files (`<temp>/vservo-<name>`), removed when the test ends, passed or failed.
pub struct ScratchDir(pub PathBuf);

impl ScratchDir {
    /// Makes the folder (a name of [`unique`] keeps tests and runs apart).
    pub fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("vservo-{name}"));
        std::fs::create_dir_all(&dir).expect("a scratch folder");
        Self(dir)
    }

    /// Writes `text` to the file `name` in it; its path.
    pub fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, text).expect("written");
        path
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A running daemon; killed (and its nodes with it) if the test ends early.
pub struct Daemon {
    /// The daemon process.
    pub child: Child,
    log: PathBuf,
}

impl Daemon {
    /// Starts vservod on `config`, its log in a file beside it.
    pub fn start(config: &TempConfig) -> Daemon {
        Self::start_with(config, &[], "0")
    }

    /// With extra environment variables and a status interval.
    pub fn start_with(config: &TempConfig, env: &[(&str, &Path)], status_every_s: &str) -> Daemon {
        let mut command = Command::new(binary("vservod"));
        command.envs(env.iter().map(|(k, v)| (*k, *v)));
        Self::spawn(command, config, status_every_s)
    }

    /// In the network namespace `netns` (`ip netns exec`, which becomes vservod: killing it kills the daemon).
    pub fn start_in(config: &TempConfig, netns: &str) -> Daemon {
        let mut command = Command::new("ip");
        command.args(["netns", "exec", netns]).arg(binary("vservod"));
        Self::spawn(command, config, "0")
    }

    /// Run by another user (`uid`, `gid`; the test runs as root), with no runtime directory in its
    /// environment: its instance lands in that user's own base (`/tmp/vservo-<uid>`). The process is
    /// vservod itself (no `runuser` in between), so killing it kills the daemon.
    pub fn start_as(config: &TempConfig, uid: u32, gid: u32) -> Daemon {
        use std::os::unix::process::CommandExt;
        let mut command = Command::new(binary("vservod"));
        command
            .uid(uid)
            .gid(gid)
            .env_remove("VSERVO_RUNTIME_DIR")
            .env_remove("XDG_RUNTIME_DIR")
            .current_dir("/");
        Self::spawn(command, config, "0")
    }

    fn spawn(mut command: Command, config: &TempConfig, status_every_s: &str) -> Daemon {
        let log = config.path.with_extension("log");
        let stderr = std::fs::File::create(&log).expect("log file");
        let child = command
            .args(["--config", &config.arg(), "--status-every-s", status_every_s])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .expect("vservod starts");
        Daemon { child, log }
    }

    /// The daemon's log so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// Sends the daemon a signal.
    pub fn signal(&self, signal: Signal) {
        kill(Pid::from_raw(self.child.id() as i32), signal).expect("the daemon can be signalled");
    }

    /// Waits for the daemon to exit; its exit code, or None if it did not within `timeout`.
    pub fn wait(&mut self, timeout: Duration) -> Option<i32> {
        let until = Instant::now() + timeout;
        loop {
            if let Some(status) = self.child.try_wait().expect("try_wait") {
                return Some(status.code().unwrap_or(-1));
            }
            if Instant::now() >= until {
                return None;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if self.child.try_wait().ok().flatten().is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        let _ = std::fs::remove_file(&self.log);
    }
}

/// `vservoctl status --json` of an instance, if a daemon answers.
pub fn status(instance: &str) -> Option<Value> {
    let out = run("vservoctl", &["status", "--json", "--instance", instance, "--timeout-s", "1"]);
    out.status.success().then(|| serde_json::from_slice(&out.stdout).expect("status --json prints JSON"))
}

/// Polls `condition` every 0.1 s until it holds (true) or `timeout` passes (false).
pub fn wait_until(timeout: Duration, mut condition: impl FnMut() -> bool) -> bool {
    let until = Instant::now() + timeout;
    while Instant::now() < until {
        if condition() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    false
}

/// The pace a healthy cell's loop keeps: joint states per wall-clock second, over the supervisor's last
/// second (the control period is 1 ms).
pub const PACE_HZ: f64 = 900.0;

/// Waits up to `timeout` for one poll in which every instance runs and its loop kept [`PACE_HZ`] over the
/// last second. A single sample is not enough on these shared VMs: a stall of the whole machine (100 ms
/// and more, seen in CI with the plant at FIFO 80 skipping 300 periods) takes any one second below the pace
/// through no fault of the cell, while a cell that cannot keep the pace never reaches it. On failure,
/// the statuses of the last poll.
pub fn keep_pace(instances: &[&str], timeout: Duration) -> Result<(), Vec<Option<Value>>> {
    let mut last = Vec::new();
    let paced = wait_until(timeout, || {
        last = instances.iter().map(|instance| status(instance)).collect();
        last.iter().all(|s| {
            s.as_ref().is_some_and(|s| running(s) && s["tick_rate_hz"].as_f64().is_some_and(|r| r > PACE_HZ))
        })
    });
    if paced { Ok(()) } else { Err(last) }
}

/// The numbers of a JSON array (NaN for `null`: a NaN on the wire prints as `null`).
pub fn numbers(value: &Value) -> Vec<f64> {
    value.as_array().expect("array").iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect()
}

/// `vservoctl echo TOPIC` on the instance for `seconds`: every message heard, as JSON (the echo is killed if
/// the test ends early).
pub fn echo_lines(instance: &str, topic: &str, seconds: &str) -> Vec<Value> {
    let mut echo = Killed(
        Command::new(binary("vservoctl"))
            .args(["echo", topic, "--instance", instance, "--duration-s", seconds])
            .stdout(Stdio::piped())
            .spawn()
            .expect("echo starts"),
    );
    let stdout = echo.0.stdout.take().expect("piped");
    let lines =
        BufReader::new(stdout).lines().map(|l| serde_json::from_str(&l.expect("line")).expect("JSON"));
    let values = lines.collect();
    let _ = echo.0.wait();
    values
}

/// The status says every node runs and is healthy.
pub fn running(status: &Value) -> bool {
    status["state"] == "running"
}

/// A daemon of the default cell under `instance`, once every node runs (its configuration lives as long as
/// the returned guard).
pub fn running_daemon(instance: &str) -> (TempConfig, Daemon) {
    running_daemon_of("config/vservo.toml", instance)
}

/// [`running_daemon`] of the repository's configuration `file` (`config/…`, its bases merged in).
pub fn running_daemon_of(file: &str, instance: &str) -> (TempConfig, Daemon) {
    running_daemon_with(file, instance, &[])
}

/// [`running_daemon_of`] with pieces of the file's text replaced as [`config_from`] does.
pub fn running_daemon_with(
    file: &str,
    instance: &str,
    replacements: &[(&str, &str)],
) -> (TempConfig, Daemon) {
    let name = format!("name = \"{instance}\"");
    let named = [&[("name = \"default\"", name.as_str())][..], replacements].concat();
    let config = config_from(file, &named);
    let daemon = Daemon::start(&config);
    assert!(
        wait_until(Duration::from_secs(10), || status(instance).is_some_and(|s| running(&s))),
        "{}",
        daemon.log()
    );
    (config, daemon)
}

impl Daemon {
    /// SIGTERM, and the daemon exits 0.
    pub fn stop(mut self) {
        self.signal(Signal::SIGTERM);
        assert_eq!(self.wait(Duration::from_secs(5)), Some(0), "{}", self.log());
    }
}

/// A copy of a configuration file of the repository (`config/…`) with pieces of text replaced, written to a
/// temporary file that lives as long as the returned guard.
pub fn config_from(file: &str, replacements: &[(&str, &str)]) -> TempConfig {
    // the file with its bases merged in: the copy lives elsewhere, where a relative `extends` finds nothing
    let mut text = vservo_config::resolve(repository_root().join(file)).expect("the config is readable");
    for (old, new) in replacements {
        assert!(text.contains(old), "{file} holds {old:?}");
        text = text.replacen(old, new, 1);
    }
    TempConfig::written(&text)
}

/// A child process killed when the guard is dropped (a test that fails still cleans up).
pub struct Killed(pub Child);

impl Killed {
    /// Sends it a signal.
    pub fn signal(&self, signal: Signal) {
        let _ = kill(Pid::from_raw(self.0.id() as i32), signal);
    }
}

impl Drop for Killed {
    fn drop(&mut self) {
        // a stopped process must be continued to die of SIGKILL promptly
        let _ = kill(Pid::from_raw(self.0.id() as i32), Signal::SIGCONT);
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A detached tmux session (a real terminal for a command), killed when the test ends, passed or not.
pub struct TmuxSession(pub String);

impl TmuxSession {
    /// What the pane shows now.
    pub fn capture(&self) -> String {
        let out =
            Command::new("tmux").args(["capture-pane", "-p", "-t", &self.0]).output().expect("tmux runs");
        String::from_utf8_lossy(&out.stdout).to_string()
    }
}

impl Drop for TmuxSession {
    fn drop(&mut self) {
        let _ = Command::new("tmux").args(["kill-session", "-t", &self.0]).output();
    }
}

/// A thread of the test's own (a fake driver) that runs until the guard is dropped: its body gets the stop
/// flag to poll, and a test that fails still stops and joins it.
pub struct LoopThread {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl LoopThread {
    /// Starts `body` on a thread with the flag it must stop at.
    pub fn spawn(body: impl FnOnce(&std::sync::atomic::AtomicBool) + Send + 'static) -> Self {
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || body(&flag));
        Self { stop, thread: Some(thread) }
    }
}

impl Drop for LoopThread {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// `vservoctl ARGS`: its exit code and what it printed (stdout, then stderr).
pub fn vservoctl(args: &[&str]) -> (Option<i32>, String) {
    let out = run("vservoctl", args);
    (
        out.status.code(),
        format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)),
    )
}

/// The instance is held in a safe stop by `fault`.
pub fn safe_stopped_by(instance: &str, fault: &str) -> bool {
    status(instance).is_some_and(|s| s["state"] == "safe-stop" && s["fault"]["name"] == fault)
}

/// The fastest joint speed in `vservoctl echo joint_state` lines over `seconds`.
pub fn fastest_joint_rad_s(instance: &str, seconds: &str) -> f64 {
    let (_, out) = vservoctl(&["echo", "joint_state", "--instance", instance, "--duration-s", seconds]);
    let states: Vec<Value> = out.lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
    assert!(states.len() > 50, "joint states heard: {}", states.len());
    states
        .iter()
        .flat_map(|s| s["qd_rad_s"].as_array().cloned().unwrap_or_default())
        .map(|v| v.as_f64().unwrap_or(f64::INFINITY).abs())
        .fold(0.0, f64::max)
}

/// The calibration issue's bars on a `vservoctl calibrate --json` report against `[camera.truth]`:
/// `tool_from_camera` within 1 mm and 0.2°, fx and fy within 0.3 %, k1 within 0.01, from 12 views; and the
/// premise, that the configuration believed a camera 5 mm, 2° and 2 % off.
pub fn assert_calibration_within_the_bars(report: &Value) {
    let number = |value: &Value, key: &str| value[key].as_f64().unwrap_or_else(|| panic!("{key} in {value}"));
    // the camera's pose in the frame it is fixed to: tool_from_camera on the hand, base_from_camera fixed
    let mount = report["changes"]["mount"].as_str().unwrap_or_else(|| panic!("changes.mount in {report}"));
    let (translation_mm, rotation_deg) = (format!("{mount}_translation_mm"), format!("{mount}_rotation_deg"));
    let believed = &report["configured_error_against_truth"];
    assert!((number(believed, &translation_mm) - 5.0).abs() < 0.01, "{believed}");
    assert!((number(believed, &rotation_deg) - 2.0).abs() < 0.01, "{believed}");
    assert!((number(believed, "fx_percent") + 1.96).abs() < 0.01, "{believed}");
    assert_eq!(report["views"].as_array().map(Vec::len), Some(12), "every view used: {report}");
    let error = &report["error_against_truth"];
    assert!(number(error, &translation_mm) < 1.0, "{error}");
    assert!(number(error, &rotation_deg) < 0.2, "{error}");
    assert!(number(error, "fx_percent").abs() < 0.3, "{error}");
    assert!(number(error, "fy_percent").abs() < 0.3, "{error}");
    assert!(number(error, "k1").abs() < 0.01, "{error}");
    assert!(number(report, "rms_px") < 0.5, "{report}");
    // the last line's object has what the issue names
    for key in ["fx", "fy", "k1"] {
        assert!(report[key].is_number(), "{key}: {report}");
    }
    let solved = &report[mount];
    assert_eq!(solved["translation_m"].as_array().map(Vec::len), Some(3), "{report}");
    assert_eq!(solved["quaternion_xyzw"].as_array().map(Vec::len), Some(4), "{report}");
}

/// Two network namespaces joined by a veth pair, as the two PCs of a cell on their own network (needs root);
/// deleted, with the pair, when dropped.
pub struct TwoHosts {
    /// The namespaces' names.
    pub names: [String; 2],
    /// Their addresses on the pair's network.
    pub addresses: [String; 2],
}

impl TwoHosts {
    /// `vs<pid>a` (10.N.M.1) and `vs<pid>b` (10.N.M.2), N.M from this process's id.
    pub fn new() -> Result<Self, String> {
        let pid = std::process::id();
        let names = [format!("vs{pid}a"), format!("vs{pid}b")];
        let subnet = format!("10.{}.{}", 100 + (pid / 256) % 100, pid % 256);
        let addresses = [format!("{subnet}.1"), format!("{subnet}.2")];
        let hosts = Self { names, addresses };
        let [a, b] = &hosts.names;
        let (veth_a, veth_b) = (format!("{a}v"), format!("{b}v"));
        let steps: Vec<Vec<String>> = vec![
            vec!["netns".into(), "add".into(), a.clone()],
            vec!["netns".into(), "add".into(), b.clone()],
            ["link", "add", &veth_a, "type", "veth", "peer", "name", &veth_b].map(String::from).to_vec(),
            ["link", "set", &veth_a, "netns", a].map(String::from).to_vec(),
            ["link", "set", &veth_b, "netns", b].map(String::from).to_vec(),
            ["-n", a, "addr", "add", &format!("{}/24", hosts.addresses[0]), "dev", &veth_a]
                .map(String::from)
                .to_vec(),
            ["-n", b, "addr", "add", &format!("{}/24", hosts.addresses[1]), "dev", &veth_b]
                .map(String::from)
                .to_vec(),
            ["-n", a, "link", "set", &veth_a, "up"].map(String::from).to_vec(),
            ["-n", b, "link", "set", &veth_b, "up"].map(String::from).to_vec(),
            ["-n", a, "link", "set", "lo", "up"].map(String::from).to_vec(),
            ["-n", b, "link", "set", "lo", "up"].map(String::from).to_vec(),
        ];
        for step in steps {
            let out = Command::new("ip").args(&step).output().map_err(|e| format!("ip: {e}"))?;
            if !out.status.success() {
                return Err(format!("ip {}: {}", step.join(" "), String::from_utf8_lossy(&out.stderr)));
            }
        }
        Ok(hosts)
    }
}

impl Drop for TwoHosts {
    fn drop(&mut self) {
        for name in &self.names {
            let _ = Command::new("ip").args(["netns", "del", name]).output();
        }
    }
}

/// A Python script of the repository (`script`, relative to its root) run by the project's environment with
/// `args`, its standard error into `log`; killed when the guard is dropped.
pub fn python_process(script: &str, args: &[&str], log: &Path) -> Killed {
    let child = Command::new(repository_root().join("target/python-venv/bin/python"))
        .arg(repository_root().join(script))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).expect("the script's log"))
        .spawn()
        .unwrap_or_else(|e| panic!("{script} starts (scripts/setup.sh makes the environment): {e}"));
    Killed(child)
}

/// The ROS 2 arm's node (clients/python/ros2_control_arm.py: a ros2_control arm and a ROS camera on MuJoCo) for
/// `scene` in DDS domain `domain`, with `extra` arguments: `--duration-s` 120 at most, its summary written to
/// `summary` when it ends, its log beside the scene.
pub fn ros2_control_arm(scene: &Path, domain: u32, summary: &Path, extra: &[&str]) -> Killed {
    let (scene_arg, domain_arg, summary_arg) =
        (scene.display().to_string(), domain.to_string(), summary.display().to_string());
    let mut args = vec!["--scene", &scene_arg, "--domain", &domain_arg, "--summary", &summary_arg];
    args.extend_from_slice(&["--duration-s", "120"]);
    args.extend_from_slice(extra);
    python_process("clients/python/ros2_control_arm.py", &args, &scene.with_extension("arm.log"))
}

/// The PyBullet driver (clients/python/pybullet_driver.py: the arm of `urdf` and its hand camera) for `scene`
/// and `instance`, its log beside the scene.
pub fn pybullet_driver(scene: &Path, urdf: &Path, instance: &str) -> Killed {
    let (scene_arg, urdf_arg) = (scene.display().to_string(), urdf.display().to_string());
    let args = ["--scene", scene_arg.as_str(), "--urdf", urdf_arg.as_str(), "--instance", instance];
    python_process("clients/python/pybullet_driver.py", &args, &scene.with_extension("driver.log"))
}

/// `nobody`'s uid and gid, when the test runs as root (it plants files as that user); `None`, said, otherwise.
pub fn nobody() -> Option<(u32, u32)> {
    if !nix::unistd::geteuid().is_root() {
        println!("skipped: needs root to plant another user's files");
        return None;
    }
    let user = nix::unistd::User::from_name("nobody").ok().flatten().expect("the user nobody exists");
    Some((user.uid.as_raw(), user.gid.as_raw()))
}

pub mod collision;
pub use collision::{clearance, refused_towards_then_moved_away};
