//! The supervisor: starts the nodes, restarts crashed ones, reports status, stops the arm safely.

use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::ipc;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use vservo_client::StatusView;
use vservo_config::Config;
use vservo_protocol::{
    CameraTwistMsg, DaemonStatusMsg, FeaturesMsg, JointCommandMsg, JointStateMsg, NodeRole, NodeStatusMsg,
    SCHEMA_VERSION, TelemetryMsg, Topic, daemon_state, node_state, robot_state,
};
use vservo_runtime::clock::{PeriodicTimer, monotonic_ns};

use crate::commands::{Commander, LoopState};
use crate::faults::{Conditions, FaultMonitor};
use crate::safety::Safety;
use crate::systemd::Systemd;

/// The supervisor's cycle.
const CYCLE: Duration = Duration::from_millis(50);
/// A node whose telemetry is older than this is not healthy.
const TELEMETRY_STALE: Duration = Duration::from_millis(500);
/// A node that ran this long healthy has its restart backoff reset.
const STABLE_AFTER: Duration = Duration::from_secs(10);
/// How often the daemon frees what processes that died left behind (a client killed while it held a
/// command slot, a subscriber of a crashed `vservoctl echo`).
const CLEANUP_EVERY: Duration = Duration::from_secs(2);
// The arm is at rest when the rmrc's reference has stopped and no joint moves faster than this (rad/s):
// the nodes' own rule when they outlive the daemon.
use vservo_runtime::AT_REST_RAD_S;

/// One supervised node.
struct Supervised {
    role: NodeRole,
    process: Option<Child>,
    state: u32,
    restarts: u64,
    backoff: Duration,
    restart_at: Option<Instant>,
    started_at: Instant,
    last_exit: i32,
    telemetry: Option<TelemetryMsg>,
    telemetry_at: Option<Instant>,
    /// The loop's progress counter, and when it last moved.
    progress: u64,
    progress_at: Instant,
}

/// Before its first telemetry a started node gets at least this long (creating its iceoryx2 ports, the
/// gain design, a debug build's start).
const START_GRACE: Duration = Duration::from_secs(5);

impl Supervised {
    /// Why the node counts as hung, if it does: its process runs but its loop shows no progress — no
    /// telemetry for `timeout` (a stopped or dead-locked process), or, for the plant, no new tick.
    fn hung(&self, now: Instant, timeout: Duration) -> Option<String> {
        self.process.as_ref()?;
        let own_telemetry = self.telemetry_at.filter(|_| self.telemetry.is_some_and(|t| t.pid == self.pid()));
        let silent_since = own_telemetry.unwrap_or(self.started_at);
        let allowed = if own_telemetry.is_some() { timeout } else { timeout.max(START_GRACE) };
        if now.duration_since(silent_since) > allowed {
            return Some(format!("no telemetry for {:.1} s", now.duration_since(silent_since).as_secs_f64()));
        }
        if self.role == NodeRole::Plant
            && own_telemetry.is_some()
            && now.duration_since(self.progress_at.max(self.started_at)) > timeout
        {
            return Some(format!(
                "no new tick for {:.1} s",
                now.duration_since(self.progress_at.max(self.started_at)).as_secs_f64()
            ));
        }
        None
    }

    fn healthy(&self, now: Instant) -> bool {
        self.process.is_some()
            && self.telemetry_at.is_some_and(|at| now.duration_since(at) < TELEMETRY_STALE)
            && self.telemetry.is_some_and(|t| t.pid == self.pid())
    }

    fn pid(&self) -> u32 {
        self.process.as_ref().map_or(0, Child::id)
    }

    fn signal(&self, signal: Signal) {
        if let Some(child) = &self.process {
            let _ = kill(Pid::from_raw(child.id() as i32), signal);
        }
    }
}

/// What the daemon needs to start a node.
struct Launcher {
    executable: PathBuf,
    config_path: PathBuf,
    /// The base of the instance's runtime directory, handed to the nodes (`VSERVO_RUNTIME_DIR`).
    runtime_base: PathBuf,
}

impl Launcher {
    /// Starts a node on `config_text`, the configuration in force (handed over on its stdin: a node
    /// restarted after an edit that was not reloaded, or was refused, runs what the others run).
    fn spawn(
        &self,
        role: NodeRole,
        heard: Option<&Heard>,
        config_text: &str,
        seal_key: &vservo_protocol::seal::SealKey,
    ) -> std::io::Result<Child> {
        let mut command = Command::new(&self.executable);
        command.arg("--config").arg(&self.config_path).arg("node").arg(role.name()).arg("--config-stdin");
        let list = |values: &[f64]| values.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(",");
        match (role, heard) {
            // the arm stopped where it was last seen
            (NodeRole::Plant, Some(Heard { joint_state: Some(state), .. })) => {
                command.arg(format!("--resume-q={}", list(&state.q_rad)));
                command.arg(format!("--resume-tick={}", state.tick + 1));
            }
            // the marks are where the last frame saw them
            (NodeRole::Vision, Some(Heard { features: Some(features), .. }))
                if features.features_px.iter().all(|v| v.is_finite()) =>
            {
                command.arg(format!("--resume-features={}", list(&features.features_px)));
            }
            _ => {}
        }
        let mut child = command
            .stdin(Stdio::piped())
            .env(crate::node_process::DAEMON_PID_ENV, std::process::id().to_string())
            .env(vservo_protocol::instance_dir::RUNTIME_DIR_ENV, &self.runtime_base)
            // only the daemon talks to systemd
            .env_remove("NOTIFY_SOCKET")
            .env_remove("WATCHDOG_USEC")
            .env_remove("WATCHDOG_PID")
            // a terminal's Ctrl-C reaches the daemon only; it stops the nodes in order
            .process_group(0)
            .spawn()?;
        // a few kB: the pipe takes it whole; closing it ends the node's read
        if let Some(mut stdin) = child.stdin.take() {
            use std::io::Write;
            stdin.write_all(
                format!("{}{}\n{config_text}", crate::node_process::SEAL_KEY_LINE, seal_key.to_hex())
                    .as_bytes(),
            )?;
        }
        Ok(child)
    }
}

struct Ports {
    telemetry: Subscriber<ipc::Service, TelemetryMsg, ()>,
    joint_state: Subscriber<ipc::Service, JointStateMsg, ()>,
    twist: Subscriber<ipc::Service, CameraTwistMsg, ()>,
    command: Subscriber<ipc::Service, JointCommandMsg, ()>,
    features: Subscriber<ipc::Service, FeaturesMsg, ()>,
    status: Publisher<ipc::Service, DaemonStatusMsg, ()>,
}

/// What the daemon has heard from the loop.
#[derive(Default)]
struct Heard {
    joint_state: Option<JointStateMsg>,
    /// When the latest joint state arrived.
    joint_state_at: Option<Instant>,
    command: Option<JointCommandMsg>,
    features: Option<FeaturesMsg>,
    gains_version: u64,
    feature_error_px: f64,
    /// (stamp, tick) a second ago, for the tick rate.
    rate_base: Option<(u64, u64)>,
    tick_rate_hz: f64,
}

impl Heard {
    /// Takes what arrived; every joint state, twist and feature vector also goes to the fault monitor.
    fn drain(&mut self, ports: &Ports, nodes: &mut [Supervised], monitor: &mut FaultMonitor) {
        while let Ok(Some(sample)) = ports.joint_state.receive() {
            if sample.schema == SCHEMA_VERSION {
                monitor.on_joint_state(&sample);
                self.joint_state = Some(*sample);
                self.joint_state_at = Some(Instant::now());
            }
        }
        while let Ok(Some(sample)) = ports.command.receive() {
            if sample.schema == SCHEMA_VERSION {
                self.command = Some(*sample);
            }
        }
        while let Ok(Some(sample)) = ports.features.receive() {
            if sample.schema == SCHEMA_VERSION {
                monitor.on_features(&sample, monotonic_ns());
                self.features = Some(*sample);
            }
        }
        while let Ok(Some(sample)) = ports.twist.receive() {
            if sample.schema == SCHEMA_VERSION {
                monitor.on_twist(&sample);
                self.gains_version = sample.gains_version;
                self.feature_error_px = sample.feature_error_px;
            }
        }
        let now = Instant::now();
        while let Ok(Some(sample)) = ports.telemetry.receive() {
            let Some(role) = NodeRole::from_index(sample.node).filter(|_| sample.schema == SCHEMA_VERSION)
            else {
                continue;
            };
            if let Some(node) = nodes.iter_mut().find(|n| n.role == role) {
                if sample.progress != node.progress {
                    node.progress = sample.progress;
                    node.progress_at = now;
                }
                node.telemetry = Some(*sample);
                node.telemetry_at = Some(now);
            }
        }
        if let Some(state) = &self.joint_state {
            match self.rate_base {
                Some((stamp, tick)) if state.stamp_ns >= stamp + 1_000_000_000 => {
                    let seconds = (state.stamp_ns - stamp) as f64 / 1e9;
                    self.tick_rate_hz = state.tick.saturating_sub(tick) as f64 / seconds;
                    self.rate_base = Some((state.stamp_ns, state.tick));
                }
                Some(_) => {}
                None => self.rate_base = Some((state.stamp_ns, state.tick)),
            }
        }
    }
}

fn exit_code(status: std::process::ExitStatus) -> i32 {
    status.code().unwrap_or_else(|| -status.signal().unwrap_or(0))
}

/// Runs the daemon until SIGTERM/SIGINT.
pub fn run(
    config_path: &Path,
    status_every_s: f64,
    stop: Arc<AtomicBool>,
    reload: Arc<AtomicBool>,
) -> anyhow::Result<()> {
    // read once: the text the nodes are handed is the text validated here
    let config_text = std::fs::read_to_string(config_path)
        .with_context(|| format!("{}: reading the configuration", config_path.display()))?;
    let config = Config::from_toml(&config_text, &config_path.display().to_string())?;
    // design the gains and place the arm now: a configuration that cannot run is refused before any node starts
    vservo_cell::Cell::new(&config).with_context(|| format!("{}", config_path.display()))?;
    if let vservo_config::VisionSource::Directory(directory) = &config.vision.source {
        anyhow::bail!(
            "{}: camera.source = \"directory\" ({}): recorded images cannot close the loop; check them open-loop with `vservoctl vision extract`, or set camera.source = \"simulated\" or \"external\"",
            config_path.display(),
            directory.display()
        );
    }
    let external_robot = config.robot.driver == vservo_config::RobotDriver::External;
    let robot_deadline = Duration::from_secs_f64(config.robot.state_timeout_s());
    let instance = config.instance.clone();
    // the instance's runtime directory, lock and shared-memory prefix, out of other users' reach
    let claim = vservo_protocol::InstanceClaim::claim(&instance)?;
    if let Some(reason) = &claim.renewed_because {
        tracing::warn!(instance, reason, "the instance's shared-memory prefix was replaced by a new one");
    }
    // clients that find the instance by its name read its arm and camera from here
    claim.write_configuration(&config_text)?;
    let launcher = Launcher {
        executable: std::env::current_exe().context("finding the vservod executable")?,
        config_path: config_path
            .canonicalize()
            .with_context(|| format!("{}: resolving the path", config_path.display()))?,
        runtime_base: claim.base().to_path_buf(),
    };
    let node = vservo_protocol::create_node_in(claim.dir(), "daemon")?;
    let cleaned = vservo_protocol::cleanup_dead_nodes(&node);
    if cleaned > 0 {
        tracing::info!(instance, cleaned, "removed the leftovers of dead nodes of an earlier run");
    }
    let ports = Ports {
        telemetry: vservo_protocol::subscriber(&node, &instance, Topic::Telemetry)?,
        joint_state: vservo_protocol::subscriber(&node, &instance, Topic::JointState)?,
        twist: vservo_protocol::subscriber(&node, &instance, Topic::CameraTwist)?,
        command: vservo_protocol::subscriber(&node, &instance, Topic::JointCommand)?,
        features: vservo_protocol::subscriber(&node, &instance, Topic::Features)?,
        status: vservo_protocol::publisher(&node, &instance, Topic::Status)?,
    };
    // the run's key: the nodes take gains and object commands sealed with it only (never in a message)
    let seal_key = vservo_protocol::seal::SealKey::random().context("drawing the run's seal key")?;
    // the cell mode first: every node finds it in the service's history
    let mut safety = Safety::new(&node, &instance, config.faults, seal_key)?;
    let mut commander = Commander::new(&node, &launcher.config_path, config.clone(), config_text, seal_key)?;
    // every shared-memory object of the instance made so far is ours and owner-only
    claim.check_private().context("the instance's shared memory is not private")?;
    let daemon_started = monotonic_ns();
    let mut systemd = Systemd::new();
    let runtime = &config.runtime;
    let initial_backoff = Duration::from_secs_f64(runtime.restart_backoff_initial_s);
    let max_backoff = Duration::from_secs_f64(runtime.restart_backoff_max_s);
    let hang_timeout = Duration::from_secs_f64(runtime.hang_timeout_s);

    tracing::info!(instance, config = %launcher.config_path.display(), "starting the nodes");
    if external_robot {
        tracing::info!(
            command = config.robot.command.name(),
            period_s = config.robot.period_s,
            deadline_s = robot_deadline.as_secs_f64(),
            "robot.driver = external: no plant; waiting for the driver's joint states"
        );
    }
    let mut nodes: Vec<Supervised> = Vec::new();
    // an external robot driver is the user's process: vservod starts no plant for it
    for role in NodeRole::ALL.into_iter().filter(|r| !(external_robot && *r == NodeRole::Plant)) {
        let process = launcher
            .spawn(role, None, commander.config_text(), &seal_key)
            .with_context(|| format!("starting the {} node", role.name()))?;
        nodes.push(Supervised {
            role,
            process: Some(process),
            state: node_state::RUNNING,
            restarts: 0,
            backoff: initial_backoff,
            restart_at: None,
            started_at: Instant::now(),
            last_exit: 0,
            telemetry: None,
            telemetry_at: None,
            progress: 0,
            progress_at: Instant::now(),
        });
    }

    let mut viewer = crate::viewer::Viewer::start(
        &config.viewer,
        &launcher.executable,
        &launcher.config_path,
        claim.base(),
    );
    let mut heard = Heard { feature_error_px: f64::NAN, ..Heard::default() };
    let mut timer = PeriodicTimer::start(CYCLE.as_nanos() as u64);
    let mut last_report = Instant::now();
    let mut last_watchdog = Instant::now();
    let mut ever_ready = false;
    let mut robot = robot_state::WAITING;
    let mut last_cleanup = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        timer.wait();
        let now = Instant::now();
        viewer.poll();
        if reload.swap(false, Ordering::Relaxed) {
            match commander.reload(&mut systemd) {
                Ok(what) => tracing::info!("SIGHUP: reloaded: {what}"),
                Err(why) => tracing::warn!("SIGHUP: reload refused: {why}"),
            }
        }
        // reap, then restart what is due
        let mut lost = false;
        for n in nodes.iter_mut() {
            if let Some(child) = &mut n.process
                && let Ok(Some(status)) = child.try_wait()
            {
                n.process = None;
                n.last_exit = exit_code(status);
                n.state = node_state::BACKING_OFF;
                if now.duration_since(n.started_at) > STABLE_AFTER {
                    n.backoff = initial_backoff;
                }
                n.restart_at = Some(now + n.backoff);
                tracing::warn!(
                    node = n.role.name(),
                    exit = n.last_exit,
                    restart_in_s = n.backoff.as_secs_f64(),
                    "{}",
                    match n.role {
                        NodeRole::Plant =>
                            "node lost: the arm stopped with it; restarting it at rest where it was",
                        NodeRole::Rmrc => "node lost: the plant holds the arm until it is back",
                        _ => "node lost: without fresh twists the rmrc ramps the arm to rest",
                    }
                );
                n.backoff = (n.backoff * 2).min(max_backoff);
                lost = true;
            }
        }
        if lost {
            let cleaned = vservo_protocol::cleanup_dead_nodes(&node);
            tracing::info!(cleaned, "removed the shared-memory leftovers of dead nodes");
            last_cleanup = now;
        } else if now.duration_since(last_cleanup) >= CLEANUP_EVERY {
            // dead clients' ports: their command slots and subscriptions are free again
            let cleaned = vservo_protocol::cleanup_dead_nodes(&node);
            if cleaned > 0 {
                tracing::debug!(cleaned, "removed the leftovers of processes that died (clients)");
            }
            last_cleanup = now;
        }
        heard.drain(&ports, &mut nodes, safety.monitor());
        // a hung node is ended like a crashed one: killed here, reaped and restarted by the next cycles
        for n in nodes.iter_mut().filter(|n| n.state != node_state::HUNG) {
            if let Some(why) = n.hung(now, hang_timeout) {
                tracing::error!(
                    node = n.role.name(),
                    pid = n.pid(),
                    "node hung ({why}): killing it (SIGKILL) to restart it"
                );
                n.state = node_state::HUNG;
                n.signal(Signal::SIGKILL);
                // a stopped process dies of SIGKILL only once it runs again
                n.signal(Signal::SIGCONT);
            }
        }
        robot =
            robot_transition(robot, heard.joint_state_at.map(|at| now.duration_since(at)), robot_deadline);
        // the nodes that move the arm and bring it to rest: while they run, the cell can be made safe
        let motion_nodes_healthy = nodes
            .iter()
            .filter(|n| matches!(n.role, NodeRole::Rmrc | NodeRole::Plant))
            .all(|n| n.healthy(now));
        let conditions = Conditions { now_ns: monotonic_ns(), robot, external_robot, motion_nodes_healthy };
        safety.cycle(&conditions);
        commander.serve(
            &LoopState {
                joint_state: heard.joint_state.as_ref(),
                features: heard.features.as_ref(),
                conditions,
            },
            &mut systemd,
            &mut safety,
        );
        for n in nodes.iter_mut() {
            if n.process.is_none() && n.restart_at.is_some_and(|at| now >= at) {
                match launcher.spawn(n.role, Some(&heard), commander.config_text(), &seal_key) {
                    Ok(child) => {
                        n.process = Some(child);
                        n.state = node_state::RUNNING;
                        n.restarts += 1;
                        n.restart_at = None;
                        n.started_at = now;
                        n.progress_at = now;
                        tracing::info!(node = n.role.name(), restarts = n.restarts, "restarted");
                    }
                    Err(e) => {
                        tracing::error!(node = n.role.name(), "restart failed: {e}");
                        n.restart_at = Some(now + n.backoff);
                    }
                }
            }
        }

        let all_healthy = nodes.iter().all(|n| n.healthy(now));
        let state = match (all_healthy && robot == robot_state::RUNNING, ever_ready) {
            _ if safety.holding() => daemon_state::SAFE_STOP,
            (true, _) => daemon_state::RUNNING,
            (false, false) => daemon_state::STARTING,
            (false, true) => daemon_state::DEGRADED,
        };
        let mut message =
            status_message(&nodes, &heard, commander.gains_version(), state, daemon_started, now);
        message.robot = robot;
        safety.fill(&mut message);
        if let Ok(sample) = ports.status.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
        let telemetry = telemetry_of(&nodes);
        let view = StatusView::new(&instance, &message, &telemetry);
        if all_healthy && robot == robot_state::RUNNING && !ever_ready {
            ever_ready = true;
            systemd.ready(&view.one_line());
            tracing::info!("ready: every node runs");
        }
        // the keep-alive says the cell can be made safe: withheld only while a node that brings the arm to
        // rest (the rmrc; the simulated plant) is not healthy. A servo or vision restart, a safe stop or a
        // stalled external driver (whose own deadline holds the arm) do not stop it
        if let Some(every) = systemd.watchdog_every
            && ever_ready
            && motion_nodes_healthy
            && now.duration_since(last_watchdog) >= every
        {
            systemd.watchdog();
            last_watchdog = now;
        }
        if status_every_s > 0.0 && now.duration_since(last_report).as_secs_f64() >= status_every_s {
            last_report = now;
            let line = view.one_line();
            systemd.status(&line);
            tracing::info!("{line}");
        }
    }

    viewer.stop();
    stop_safely(&mut nodes, &ports, &mut heard, &mut systemd, runtime.stop_timeout_s, safety.monitor());
    let cleaned = vservo_protocol::cleanup_dead_nodes(&node);
    if cleaned > 0 {
        tracing::info!(cleaned, "removed the leftovers of nodes that did not stop cleanly");
    }
    tracing::info!("stopped");
    Ok(())
}

fn telemetry_of(nodes: &[Supervised]) -> [Option<TelemetryMsg>; 4] {
    let mut out = [None; 4];
    for n in nodes {
        out[n.role as usize] = n.telemetry.filter(|t| t.pid == n.pid());
    }
    out
}

fn status_message(
    nodes: &[Supervised],
    heard: &Heard,
    designed_gains_version: u64,
    state: u32,
    daemon_started: u64,
    now: Instant,
) -> DaemonStatusMsg {
    let stamp_ns = monotonic_ns();
    let mut statuses = [NodeStatusMsg::default(); 4];
    for n in nodes {
        statuses[n.role as usize] = NodeStatusMsg {
            restarts: n.restarts,
            last_telemetry_ns: n.telemetry.map_or(0, |t| t.stamp_ns),
            state: n.state,
            pid: n.pid(),
            last_exit: n.last_exit,
            healthy: u32::from(n.healthy(now)),
        };
    }
    DaemonStatusMsg {
        schema: SCHEMA_VERSION,
        state,
        stamp_ns,
        uptime_ns: stamp_ns - daemon_started,
        // the version the servo runs, once it has said; until then the one designed
        gains_version: if heard.gains_version > 0 { heard.gains_version } else { designed_gains_version },
        nodes: statuses,
        // no rate from stale data: a driver (or plant) silent for a second ticks at 0/s
        tick_rate_hz: match heard.joint_state_at {
            Some(at) if now.duration_since(at) < Duration::from_secs(1) => heard.tick_rate_hz,
            _ => 0.0,
        },
        feature_error_px: heard.feature_error_px,
        pid: std::process::id(),
        robot: robot_state::WAITING,
        fault: 0,
        fault_joints: 0,
        fault_since_ns: 0,
        safe_stops: 0,
    }
}

/// The robot driver's state after a supervisor cycle, from the age of its latest joint state; a change is
/// logged. Stalled: the rmrc commands nothing (it answers joint states only) and, when states come again,
/// starts its reference at rest from the measured joints.
fn robot_transition(was: u32, age: Option<Duration>, deadline: Duration) -> u32 {
    let now = match age {
        None => robot_state::WAITING,
        Some(age) if age > deadline => robot_state::STALLED,
        Some(_) => robot_state::RUNNING,
    };
    match (was, now) {
        (a, b) if a == b => {}
        (_, robot_state::STALLED) => tracing::error!(
            deadline_s = deadline.as_secs_f64(),
            "robot driver stalled: no joint state within the deadline; no motion is commanded until it is back"
        ),
        (robot_state::STALLED, robot_state::RUNNING) => {
            tracing::warn!("robot driver back: following it again from where the arm is, at rest")
        }
        (_, robot_state::RUNNING) => tracing::info!("robot driver: joint states arrive"),
        _ => {}
    }
    now
}

fn wait_for_exit(node: &mut Supervised, timeout: Duration) -> bool {
    let until = Instant::now() + timeout;
    while let Some(child) = &mut node.process {
        match child.try_wait() {
            Ok(Some(status)) => {
                node.last_exit = exit_code(status);
                node.process = None;
            }
            _ if Instant::now() >= until => return false,
            _ => std::thread::sleep(Duration::from_millis(5)),
        }
    }
    node.state = node_state::STOPPED;
    true
}

/// Stops the servo and vision (the servo's last twist is zero), lets the rmrc ramp the arm to rest at its
/// acceleration limits, then stops the rmrc and the plant. Nodes that do not exit in time are killed.
fn stop_safely(
    nodes: &mut [Supervised],
    ports: &Ports,
    heard: &mut Heard,
    systemd: &mut Systemd,
    timeout_s: f64,
    monitor: &mut FaultMonitor,
) {
    systemd.stopping();
    tracing::info!("stopping: zero twist, ramping the arm to rest");
    let started = Instant::now();
    let by_role = |role: NodeRole| nodes.iter().position(|n| n.role == role);
    let outer = [by_role(NodeRole::Servo), by_role(NodeRole::Vision)];
    let inner = [by_role(NodeRole::Rmrc), by_role(NodeRole::Plant)];
    for &i in outer.iter().flatten() {
        nodes[i].signal(Signal::SIGTERM);
    }
    for &i in outer.iter().flatten() {
        if !wait_for_exit(&mut nodes[i], Duration::from_millis(400)) {
            nodes[i].signal(Signal::SIGKILL);
            wait_for_exit(&mut nodes[i], Duration::from_millis(100));
        }
    }
    // the arm comes to rest under the rmrc while the plant runs
    let loop_alive = inner.iter().flatten().all(|&i| nodes[i].process.is_some());
    let deadline = started + Duration::from_secs_f64(timeout_s);
    let fastest = |v: &[f64; 6]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut at_rest = !loop_alive;
    let mut speeds = (f64::NAN, f64::NAN);
    while loop_alive && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
        heard.drain(ports, nodes, monitor);
        if let (Some(state), Some(command)) = (&heard.joint_state, &heard.command) {
            speeds = (fastest(&command.qd_ref_rad_s), fastest(&state.qd_rad_s));
            if speeds.0 == 0.0 && speeds.1 < AT_REST_RAD_S {
                at_rest = true;
                break;
            }
        }
    }
    if at_rest {
        tracing::info!(
            after_s = started.elapsed().as_secs_f64(),
            joint_speed_rad_s = speeds.1,
            "the arm is at rest"
        );
    } else {
        tracing::warn!(
            timeout_s,
            reference_speed_rad_s = speeds.0,
            joint_speed_rad_s = speeds.1,
            "the arm did not come to rest in time; stopping the drives anyway (the plant holds it)"
        );
    }
    for &i in inner.iter().flatten() {
        nodes[i].signal(Signal::SIGTERM);
        if !wait_for_exit(&mut nodes[i], Duration::from_millis(300)) {
            nodes[i].signal(Signal::SIGKILL);
            wait_for_exit(&mut nodes[i], Duration::from_millis(100));
        }
    }
}
