//! The supervisor: starts the nodes, restarts crashed and hung ones, reports status, stops the arm safely.
//!
//! [`run`] is a loop of named steps over a [`Daemon`]; each decision is a pure module with its unit tests:
//! [`restart`] (backoff, reset after a stable run), [`node`] (health, hang), [`health`] (robot driver,
//! daemon state, resume conditions, readiness and watchdog), [`status`] (the status message, the tick
//! rate), [`cleanup`] (when dead processes' leftovers are freed), [`shutdown`] (the stop order, at rest).
//! [`launch`] starts processes and [`observe`] drains what the loop published.

mod cleanup;
mod clearance;
mod health;
mod launch;
mod node;
mod observe;
mod restart;
mod shutdown;
mod startup;
mod status;
mod stop_path_watch;
pub mod streams;

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use iceoryx2::prelude::{Node, ipc};
use nix::sys::signal::Signal;
use vservo_client::StatusView;
use vservo_config::Config;
use vservo_protocol::stop_path::SafeStopReader;
use vservo_protocol::{InstanceClaim, NodeRole, NodeState, RobotState};
use vservo_runtime::clock::PeriodicTimer;
use vservo_time::monotonic_ns;

use crate::commands::{Commander, LoopState};
use crate::faults::Conditions;
use crate::helpers::{Helper, Launch, Stops, start_helpers};
use crate::safety::Safety;
use crate::stop_path::Bursts;
use crate::systemd::Systemd;
use cleanup::{Cleanup, CleanupClock};
use clearance::ClearanceWatch;
use health::{CameraSeen, CameraWatch, Readiness, RobotChange};
use launch::{Launcher, Resume, Supervised, telemetry_of, writers_of};
use node::NodeRecord;
use observe::{LoopHeard, Ports};
use restart::RestartPolicy;
use status::StatusFacts;
use streams::{SLOT_TAKEN_EXIT, StreamWatch};

/// The supervisor's cycle.
const CYCLE: Duration = Duration::from_millis(50);

/// Runs the daemon until `stop` is set (SIGTERM/SIGINT); `reload` (SIGHUP) re-reads the configuration.
pub fn run(
    config_path: &Path,
    status_every_s: f64,
    stop: Arc<AtomicBool>,
    reload: Arc<AtomicBool>,
) -> anyhow::Result<()> {
    let Some(mut daemon) = Daemon::start(config_path, status_every_s, &stop)? else {
        tracing::info!("stopped while reading the configuration: nothing was started");
        return Ok(());
    };
    let mut timer = PeriodicTimer::start(CYCLE.as_nanos() as u64);
    while !stop.load(Ordering::Relaxed) {
        timer.wait();
        daemon.cycle(reload.swap(false, Ordering::Relaxed));
    }
    daemon.stop();
    Ok(())
}

/// The configuration's settings the supervisor runs by.
struct Settings {
    instance: String,
    external_robot: bool,
    /// The camera is a driver of its own (`[camera] source = "external"`, GStreamer, ROS 2).
    external_camera: bool,
    robot_deadline: Duration,
    camera_timeout: Duration,
    hang_timeout: Duration,
    stop_timeout: Duration,
    initial_backoff: Duration,
    max_backoff: Duration,
    status_every: Option<Duration>,
    /// The configured arm's joints.
    arm_joints: usize,
}

impl Settings {
    fn of(config: &Config, status_every_s: f64) -> Self {
        let runtime = &config.runtime;
        Self {
            instance: config.instance.clone(),
            external_robot: !config.cell.robot.driver.is_simulated(),
            external_camera: config.cell.vision.source.from_camera_driver(),
            robot_deadline: Duration::from_secs_f64(config.cell.robot.state_timeout_s()),
            camera_timeout: config.faults.camera_timeout(config.cell.timing.vision_period_s),
            hang_timeout: runtime.hang_timeout,
            stop_timeout: runtime.stop_timeout,
            initial_backoff: runtime.restart_backoff_initial,
            max_backoff: runtime.restart_backoff_max,
            status_every: (status_every_s > 0.0).then(|| Duration::from_secs_f64(status_every_s)),
            arm_joints: config.cell.arm.joint_count(),
        }
    }

    /// The nodes vservod starts: an external robot driver is the user's process, so no plant for it.
    fn roles(&self) -> impl Iterator<Item = NodeRole> + '_ {
        NodeRole::ALL.into_iter().filter(|r| !(self.external_robot && *r == NodeRole::Plant))
    }
}

/// The running daemon: its ports, its nodes and what it knows of them.
struct Daemon {
    settings: Settings,
    /// The instance's runtime directory and lock, held while the daemon runs.
    _claim: InstanceClaim,
    node: Node<ipc::Service>,
    ports: Ports,
    /// The safe-stop path: requests no client can crowd out.
    stop_path: SafeStopReader,
    stop_bursts: Bursts,
    launcher: Launcher,
    safety: Safety,
    commander: Commander,
    systemd: Systemd,
    /// The helper processes the configuration asks for (`crate::helpers::HELPERS`).
    helpers: Vec<Helper>,
    nodes: Vec<Supervised>,
    /// Who holds each stream's writer slot.
    streams: StreamWatch,
    heard: LoopHeard,
    robot: RobotState,
    camera: CameraWatch,
    readiness: Readiness,
    cleanup: CleanupClock,
    started_ns: u64,
    last_report: Instant,
    /// Whether the absence of the robot driver has been said.
    driver_absence_said: bool,
    /// Whether the absent camera driver was said.
    camera_absence_said: bool,
    /// The collision guard's nearest distance for the status, and its names for the log.
    clearance: ClearanceWatch,
}

impl Daemon {
    /// Checks the configuration, claims the instance, publishes the cell mode and the gains, then starts
    /// the nodes and the viewer.
    /// `None` when `stop` came while the configuration was read (nothing is started then).
    fn start(config_path: &Path, status_every_s: f64, stop: &AtomicBool) -> anyhow::Result<Option<Self>> {
        let (config, config_text, gains, clearance) = startup::load_config(config_path)?;
        if stop.load(Ordering::Relaxed) {
            return Ok(None);
        }
        let settings = Settings::of(&config, status_every_s);
        let (claim, node) = startup::claim_instance(&settings.instance, &config_text)?;
        let launcher = Launcher {
            executable: std::env::current_exe().context("finding the vservod executable")?,
            config_path: config_path
                .canonicalize()
                .with_context(|| format!("{}: resolving the path", config_path.display()))?,
            runtime_base: claim.base().to_path_buf(),
            // the run's key: the nodes take gains and object commands sealed with it only (never in a message)
            seal_key: vservo_protocol::seal::SealKey::random().context("drawing the run's seal key")?,
        };
        // every service, created here with one writer slot per stream before any other process can
        let streams = vservo_protocol::writers::create_all(&node, &settings.instance)
            .context("creating the instance's services")?;
        let streams =
            StreamWatch::new(streams, settings.external_robot, settings.external_camera, Instant::now());
        let ports = Ports::open(&node, &settings.instance, launcher.seal_key.clone())?;
        let stop_path = SafeStopReader::create(claim.dir())?;
        // the cell mode first: every node finds it in the service's history
        let arm_joints = settings.arm_joints as u32;
        let mut safety = Safety::new(
            &node,
            &settings.instance,
            (config.faults, config.cell.robot.start_held, config.cell.interpolator.speed_scale),
            arm_joints,
            launcher.seal_key.clone(),
        )?;
        let path = &launcher.config_path;
        let commander = Commander::new(
            &node,
            (path, claim.dir()),
            config.clone(),
            config_text,
            launcher.seal_key.clone(),
            &gains,
        )?;
        // every shared-memory object of the instance made so far is ours and owner-only
        claim.check_private().context("the instance's shared memory is not private")?;
        let started_ns = monotonic_ns();
        if settings.external_robot {
            tracing::info!(
                command = config.cell.robot.command.name(),
                period_s = config.cell.robot.period_s,
                deadline_s = settings.robot_deadline.as_secs_f64(),
                driver = config.cell.robot.driver.name(),
                "no plant: waiting for the robot driver's joint states"
            );
        }
        let nodes = start_nodes(&settings, &launcher, commander.config_text())?;
        safety.announce_writers(writers_of(&nodes));
        let launch = Launch {
            vservod: &launcher.executable,
            // the configuration in force, as the nodes get it (and again after a reload), not the user's file
            config_path: &claim.dir().configuration(),
            runtime_base: claim.base(),
            seal_key: &launcher.seal_key,
        };
        let helpers = start_helpers(&config, &launch);
        let now = Instant::now();
        Ok(Some(Self {
            settings,
            _claim: claim,
            node,
            ports,
            stop_path,
            stop_bursts: Bursts::default(),
            launcher,
            safety,
            commander,
            systemd: Systemd::new(),
            helpers,
            nodes,
            streams,
            heard: LoopHeard::default(),
            robot: RobotState::Waiting,
            camera: CameraWatch::default(),
            readiness: Readiness::new(now),
            cleanup: CleanupClock::new(now),
            started_ns,
            last_report: now,
            driver_absence_said: false,
            camera_absence_said: false,
            clearance,
        }))
    }

    /// Names what the collision guard stopped the arm for, where this cycle's new safe stop is its.
    fn name_collision(&mut self, stops_before: u64) {
        let monitor = self.safety.monitor();
        let Some(crate::faults::Cause::Collision(word)) = monitor.latched().map(|f| f.cause) else { return };
        if monitor.safe_stops() > stops_before {
            let named = self.clearance.named(word).unwrap_or_else(|| "a distance it watches".to_string());
            tracing::error!(fault = "collision", "the collision guard stopped the arm: {named} too near");
        }
    }

    /// One supervisor cycle.
    fn cycle(&mut self, reload_requested: bool) {
        let now = Instant::now();
        self.helpers.iter_mut().for_each(Helper::poll);
        if reload_requested {
            self.reload();
        }
        // heard before a dead node's leftovers are removed: what it sent last (a plant's last state) is lost with them
        self.heard.drain(&self.ports, &mut self.nodes, self.safety.monitor());
        let lost = self.reap(now);
        self.clean_up(now, lost);
        self.end_hung(now);
        self.hear_stop_path(now);
        let mut conditions = self.judge_robot_and_conditions(now);
        conditions.stream_taken = self.stream_taken(now);
        let stops_before = self.safety.monitor().safe_stops();
        self.safety.cycle(&conditions);
        self.name_collision(stops_before);
        let loop_state = LoopState {
            arm_joints: self.settings.arm_joints,
            joint_state: self.heard.joint_state.as_ref(),
            features: self.heard.features.as_ref(),
            conditions,
        };
        self.commander.serve(&loop_state, &mut self.systemd, &mut self.safety);
        if self.commander.take_node_restart() {
            launch::end_camera_readers(&mut self.nodes);
        }
        self.restart_due(now);
        self.safety.announce_writers(writers_of(&self.nodes));
        self.report(now, conditions.motion_nodes_healthy);
    }

    /// SIGHUP: re-reads the configuration.
    fn reload(&mut self) {
        let outcome = self.commander.reload(&mut self.systemd, self.safety.holding());
        let text = self.commander.describe(&outcome);
        match outcome {
            Ok(_) => tracing::info!("SIGHUP: reloaded: {text}"),
            Err(_) => tracing::warn!("SIGHUP: reload refused: {text}"),
        }
    }

    /// Takes the exit of every node whose process ended and schedules its restart; whether one did.
    fn reap(&mut self, now: Instant) -> bool {
        let mut lost = false;
        for node in &mut self.nodes {
            let Some(exit) = node.reap() else { continue };
            let wait = node.record.ended(exit, now);
            if std::mem::take(&mut node.planned_restart) {
                let role = node.record.role.name();
                tracing::info!(
                    node = role,
                    restart_in_s = wait.as_secs_f64(),
                    "ended to restart with the reload"
                );
                lost = true;
                continue;
            }
            if exit == i32::from(SLOT_TAKEN_EXIT) {
                tracing::error!(
                    node = node.record.role.name(),
                    restart_in_s = wait.as_secs_f64(),
                    "stream taken: the node's port was refused because another process holds the slot"
                );
                lost = true;
                continue;
            }
            tracing::warn!(
                node = node.record.role.name(),
                exit,
                restart_in_s = wait.as_secs_f64(),
                "{}",
                match node.record.role {
                    NodeRole::Plant =>
                        "node lost: the arm stopped with it; restarting it at rest where it was",
                    NodeRole::Rmrc => "node lost: the plant holds the arm until it is back",
                    _ => "node lost: without fresh twists the rmrc ramps the arm to rest",
                }
            );
            lost = true;
        }
        lost
    }

    /// Frees what dead nodes and clients left in shared memory, when due.
    fn clean_up(&mut self, now: Instant, node_lost: bool) {
        let Some(why) = self.cleanup.due(now, node_lost) else { return };
        let cleaned = vservo_protocol::cleanup_dead_nodes(&self.node);
        match why {
            Cleanup::NodeLost => tracing::info!(cleaned, "removed the shared-memory leftovers of dead nodes"),
            // dead clients' ports: their command slots and subscriptions are free again
            Cleanup::Periodic if cleaned > 0 => {
                tracing::debug!(cleaned, "removed the leftovers of processes that died (clients)")
            }
            Cleanup::Periodic => {}
        }
    }

    /// Whether a stream is taken: a foreign process holds a writer slot, or a node's port was refused because
    /// its slots are held and it has not run healthy since.
    fn stream_taken(&mut self, now: Instant) -> bool {
        let foreign = self.streams.cycle(self.nodes.iter().map(|n| &n.record), now);
        let refused = self
            .nodes
            .iter()
            .any(|n| n.record.last_exit == i32::from(SLOT_TAKEN_EXIT) && !n.record.healthy(now));
        foreign || refused
    }

    /// A hung node is ended like a crashed one: killed here, reaped and restarted by the next cycles.
    fn end_hung(&mut self, now: Instant) {
        for node in &mut self.nodes {
            let Some(why) = node.record.hang(now, self.settings.hang_timeout) else { continue };
            tracing::error!(
                node = node.record.role.name(),
                pid = node.record.pid.unwrap_or(0),
                "node hung ({why}): killing it (SIGKILL) to restart it"
            );
            node.record.state = NodeState::Hung;
            node.signal(Signal::SIGKILL);
            // a stopped process dies of SIGKILL only once it runs again
            node.signal(Signal::SIGCONT);
        }
    }

    /// The robot driver's state from its latest joint state (a change logged), whether the camera sends
    /// frames, and what a resume depends on.
    fn judge_robot_and_conditions(&mut self, now: Instant) -> Conditions {
        let age = self.heard.joint_state_at.map(|at| now.duration_since(at));
        let robot = health::robot_state(age, self.settings.robot_deadline);
        log_robot_change(health::robot_change(self.robot, robot), self.settings.robot_deadline);
        self.robot = robot;
        let waited = Duration::from_nanos(monotonic_ns().saturating_sub(self.started_ns));
        let (external_robot, external_camera) = (self.settings.external_robot, self.settings.external_camera);
        if health::driver_absent(
            external_robot,
            robot != RobotState::Waiting,
            waited,
            self.driver_absence_said,
        ) {
            self.driver_absence_said = true;
            startup::say_absent(&self.settings.instance, "robot driver", "ros2, franka", waited);
        }
        let heard_camera = self.heard.features_at.is_some();
        if health::driver_absent(external_camera, heard_camera, waited, self.camera_absence_said) {
            self.camera_absence_said = true;
            startup::say_absent(&self.settings.instance, "camera driver", "ros2", waited);
        }
        let vision = self.nodes.iter().find(|n| n.record.role == NodeRole::Vision);
        let seen = CameraSeen {
            frame_at: self.heard.features_at,
            vision_alive_at: vision
                .filter(|n| n.record.healthy(now))
                .and_then(|n| n.record.heard.telemetry_at),
            robot,
        };
        let camera_stalled = self.camera.stalled(&seen, self.settings.camera_timeout, now);
        let records = self.nodes.iter().map(|n| &n.record);
        let external = self.settings.external_robot;
        health::resume_conditions(monotonic_ns(), robot, external, camera_stalled, records, now)
    }

    /// Starts again every node whose backoff is over, resuming where the loop was.
    fn restart_due(&mut self, now: Instant) {
        let resume = Resume {
            // the arm's joints, from a driver of this arm
            joints: self.heard.plant_state.and_then(|s| {
                let q = s.arm_q_rad(self.settings.arm_joints)?;
                Some((q[..self.settings.arm_joints].to_vec(), s.tick))
            }),
            features_px: self.heard.features.map(|f| f.features_px),
        };
        for node in self.nodes.iter_mut().filter(|n| n.process.is_none() && n.record.restart.due(now)) {
            let role = node.record.role;
            match self.launcher.spawn(role, &resume, self.commander.config_text()) {
                Ok(child) => {
                    node.record.restarted(child.id(), now);
                    node.process = Some(child);
                    tracing::info!(
                        node = role.name(),
                        restarts = node.record.restart.restarts(),
                        "restarted"
                    );
                }
                Err(e) => {
                    tracing::error!(node = role.name(), "restart failed: {e}");
                    node.record.restart.start_failed(now);
                }
            }
        }
    }

    /// Publishes the status; tells systemd when the daemon is ready, keeps its watchdog alive, and writes
    /// the status line every `status_every`.
    fn report(&mut self, now: Instant, motion_nodes_healthy: bool) {
        let all_healthy = self.nodes.iter().all(|n| n.record.healthy(now));
        let state = health::daemon_state(
            self.safety.holding(),
            self.safety.joint_move().is_some(),
            all_healthy,
            self.robot,
            self.readiness.ever_ready(),
        );
        let facts = StatusFacts {
            state,
            robot: self.robot,
            stamp_ns: monotonic_ns(),
            started_ns: self.started_ns,
            servo_gains_version: self.heard.gains_version,
            designed_gains_version: self.commander.gains_version(),
            tick_rate_hz: self.heard.tick_rate_hz(now, self.robot),
            feature_error_px: self.heard.feature_error_px,
            pid: std::process::id(),
        };
        let mut message = status::status_message(self.nodes.iter().map(|n| &n.record), &facts, now);
        self.safety.fill(&mut message);
        self.clearance.fill(self.heard.command.as_ref(), &mut message);
        self.ports.publish_status(message);
        let telemetry = telemetry_of(&self.nodes);
        let view = StatusView::new(&self.settings.instance, &message, &telemetry);
        if self.readiness.became_ready(all_healthy, self.robot) {
            self.systemd.ready(&view.one_line());
            tracing::info!("ready: every node runs");
        }
        if self.readiness.watchdog_due(self.systemd.watchdog_every, motion_nodes_healthy, now) {
            self.systemd.watchdog();
        }
        if self.settings.status_every.is_some_and(|every| now.duration_since(self.last_report) >= every) {
            self.last_report = now;
            let line = view.one_line();
            self.systemd.status(&line);
            tracing::info!("{line}");
        }
    }

    /// Stops the helpers that stop `when`.
    fn stop_helpers(&mut self, when: Stops) {
        self.helpers.iter_mut().filter(|helper| helper.stops() == when).for_each(Helper::stop);
    }

    /// Stops the helpers and the nodes in order, the arm brought to rest first.
    fn stop(mut self) {
        self.stop_helpers(Stops::First);
        self.systemd.stopping();
        tracing::info!("stopping: zero twist, ramping the arm to rest");
        shutdown::stop_safely(
            &mut self.nodes,
            &self.ports,
            &mut self.heard,
            self.settings.stop_timeout,
            self.safety.monitor(),
        );
        // the arm's drivers last: they carry the ramp to rest to the arm, then command rest as they end
        self.stop_helpers(Stops::Last);
        let cleaned = vservo_protocol::cleanup_dead_nodes(&self.node);
        if cleaned > 0 {
            tracing::info!(cleaned, "removed the leftovers of nodes that did not stop cleanly");
        }
        tracing::info!("stopped");
    }
}

/// Starts every node the configuration asks for.
fn start_nodes(
    settings: &Settings,
    launcher: &Launcher,
    config_text: &str,
) -> anyhow::Result<Vec<Supervised>> {
    tracing::info!(instance = settings.instance, config = %launcher.config_path.display(), "starting the nodes");
    settings
        .roles()
        .map(|role| {
            let child = launcher
                .spawn(role, &Resume::default(), config_text)
                .with_context(|| format!("starting the {} node", role.name()))?;
            let policy = RestartPolicy::new(settings.initial_backoff, settings.max_backoff, Instant::now());
            Ok(Supervised {
                record: NodeRecord::started(role, child.id(), policy),
                process: Some(child),
                planned_restart: false,
            })
        })
        .collect()
}

/// One line per change of the robot driver's state. Stalled: the rmrc commands nothing (it answers joint
/// states only) and, when states come again, starts its reference at rest from the measured joints.
fn log_robot_change(change: Option<RobotChange>, deadline: Duration) {
    match change {
        Some(RobotChange::Stalled) => tracing::error!(
            deadline_s = deadline.as_secs_f64(),
            "robot driver stalled: no joint state within the deadline; no motion is commanded until it is back"
        ),
        Some(RobotChange::Back) => {
            tracing::warn!("robot driver back: following it again from where the arm is, at rest")
        }
        Some(RobotChange::Arriving) => tracing::info!("robot driver: joint states arrive"),
        None => {}
    }
}
