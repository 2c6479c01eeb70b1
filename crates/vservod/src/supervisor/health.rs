//! The cell's health as the supervisor judges it each cycle: the robot driver's state from the age of its
//! latest joint state, whether the camera sends frames ([`CameraWatch`]), the daemon's state, the conditions a resume depends on, when the daemon is ready
//! and when systemd's watchdog is kept alive. Pure: time is passed in.

use std::time::{Duration, Instant};

use vservo_protocol::{DaemonState, NodeRole, RobotState};

use super::node::{NodeRecord, START_GRACE};
use crate::faults::Conditions;

/// The robot driver's state from the age of its latest joint state: waiting for the first, running, or
/// stalled past `deadline`.
pub fn robot_state(age: Option<Duration>, deadline: Duration) -> RobotState {
    match age {
        None => RobotState::Waiting,
        Some(age) if age > deadline => RobotState::Stalled,
        Some(_) => RobotState::Running,
    }
}

/// How long vservod waits for an external driver's first message (a robot's joint state, a camera's frame) before
/// it says none has appeared.
pub const DRIVER_ABSENT_AFTER: Duration = Duration::from_secs(3);

/// Whether to say now that an external driver (robot or camera; the simulated ones are vservod's own nodes) has
/// not appeared: nothing `heard` of it yet `waited` after the start, longer than [`DRIVER_ABSENT_AFTER`], not
/// said yet.
pub fn driver_absent(external: bool, heard: bool, waited: Duration, said: bool) -> bool {
    external && !heard && waited >= DRIVER_ABSENT_AFTER && !said
}

/// A change of the robot driver's state worth a log line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RobotChange {
    /// No joint state within the deadline.
    Stalled,
    /// Joint states again after a stall.
    Back,
    /// The first joint states.
    Arriving,
}

/// What changed from `was` to `now`, if it is worth a line.
pub fn robot_change(was: RobotState, now: RobotState) -> Option<RobotChange> {
    match (was, now) {
        (a, b) if a == b => None,
        (_, RobotState::Stalled) => Some(RobotChange::Stalled),
        (RobotState::Stalled, RobotState::Running) => Some(RobotChange::Back),
        (_, RobotState::Running) => Some(RobotChange::Arriving),
        _ => None,
    }
}

/// What the camera is judged on: when a frame last showed (the vision node's features), and when the
/// vision node last spoke (its own telemetry, while it runs healthy).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraSeen {
    /// When the latest features arrived: a frame the vision node took.
    pub frame_at: Option<Instant>,
    /// When the vision node's own telemetry last arrived, if the node runs healthy (None: down, hung,
    /// starting).
    pub vision_alive_at: Option<Instant>,
    /// The robot driver's state (the simulated camera takes its images on the robot's joint states).
    pub robot: RobotState,
}

/// Whether the camera sends frames. It is watched only while the vision node runs healthy and the robot
/// runs: a vision node down or hung is the supervisor's (a restart), and the simulated camera takes its
/// images on the robot's joint states, so a stalled robot is that fault, not the camera's. Once watched,
/// the camera is stalled when the vision node has spoken more than `timeout` after the last frame (it ran,
/// and no frame came), or, before the first frame since the watch began (a start, a restart, the robot
/// back), more than `timeout` or [`START_GRACE`], whichever is longer. A stopped vision process (SIGSTOP)
/// speaks no more, so it is a hang, never also a stalled camera.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CameraWatch {
    watching_since: Option<Instant>,
}

impl CameraWatch {
    /// Whether the camera is stalled at `now`.
    pub fn stalled(&mut self, seen: &CameraSeen, timeout: Duration, now: Instant) -> bool {
        let Some(alive_at) = seen.vision_alive_at.filter(|_| seen.robot == RobotState::Running) else {
            self.watching_since = None;
            return false;
        };
        let since = *self.watching_since.get_or_insert(now);
        let (from, allowed) = match seen.frame_at.filter(|at| *at >= since) {
            Some(frame_at) => (frame_at, timeout),
            None => (since, timeout.max(START_GRACE)),
        };
        alive_at.checked_duration_since(from).is_some_and(|silent| silent > allowed)
    }
}

/// The nodes that move the arm and bring it to rest (the rmrc; the simulated plant) all run healthy: while
/// they do, the cell can be made safe.
pub fn motion_nodes_healthy<'a>(nodes: impl IntoIterator<Item = &'a NodeRecord>, now: Instant) -> bool {
    nodes.into_iter().filter(|n| matches!(n.role, NodeRole::Rmrc | NodeRole::Plant)).all(|n| n.healthy(now))
}

/// What a resume (and the fault monitor) depends on besides the messages.
pub fn resume_conditions<'a>(
    now_ns: u64,
    robot: RobotState,
    external_robot: bool,
    camera_stalled: bool,
    nodes: impl IntoIterator<Item = &'a NodeRecord>,
    now: Instant,
) -> Conditions {
    Conditions {
        now_ns,
        robot,
        external_robot,
        motion_nodes_healthy: motion_nodes_healthy(nodes, now),
        stream_taken: false,
        camera_stalled,
    }
}

/// The daemon's state: a safe stop holds; every node healthy with the robot running is running, or moving
/// while a client's joint move is in force; before the first time it was, starting; after, degraded.
pub fn daemon_state(
    holding: bool,
    moving: bool,
    all_healthy: bool,
    robot: RobotState,
    ever_ready: bool,
) -> DaemonState {
    match (all_healthy && robot == RobotState::Running, ever_ready) {
        _ if holding => DaemonState::SafeStop,
        (true, _) if moving => DaemonState::Moving,
        (true, _) => DaemonState::Running,
        (false, false) => DaemonState::Starting,
        (false, true) => DaemonState::Degraded,
    }
}

/// Readiness and systemd's keep-alive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Readiness {
    ever_ready: bool,
    last_watchdog: Instant,
}

impl Readiness {
    /// Not ready yet, at the start `now`.
    pub fn new(now: Instant) -> Self {
        Self { ever_ready: false, last_watchdog: now }
    }

    /// Whether the daemon has been ready once.
    pub fn ever_ready(&self) -> bool {
        self.ever_ready
    }

    /// Whether the daemon became ready just now (every node healthy, the robot running, for the first time).
    pub fn became_ready(&mut self, all_healthy: bool, robot: RobotState) -> bool {
        let ready = all_healthy && robot == RobotState::Running && !self.ever_ready;
        self.ever_ready |= ready;
        ready
    }

    /// Whether to send the keep-alive at `now`: it says the cell can be made safe, so it is withheld only
    /// while a node that brings the arm to rest is not healthy (a servo or vision restart, a safe stop or a
    /// stalled external driver, whose own deadline holds the arm, do not stop it); every `every`, once ready.
    pub fn watchdog_due(
        &mut self,
        every: Option<Duration>,
        motion_nodes_healthy: bool,
        now: Instant,
    ) -> bool {
        let due = every.is_some_and(|every| {
            self.ever_ready && motion_nodes_healthy && now.duration_since(self.last_watchdog) >= every
        });
        if due {
            self.last_watchdog = now;
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::restart::RestartPolicy;

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn the_robot_waits_runs_and_stalls_by_the_age_of_its_latest_state() {
        let deadline = 50 * MS;
        assert_eq!(robot_state(None, deadline), RobotState::Waiting);
        let late = DRIVER_ABSENT_AFTER;
        assert!(driver_absent(true, false, late, false));
        assert!(!driver_absent(true, false, late, true), "said once");
        assert!(!driver_absent(true, false, late / 2, false), "not yet");
        assert!(!driver_absent(false, false, late, false), "the simulated driver is vservod's own");
        assert!(!driver_absent(true, true, late, false), "heard");
    }

    #[test]
    fn a_camera_is_stalled_when_its_running_node_speaks_a_timeout_after_the_last_frame() {
        let t0 = Instant::now();
        let timeout = 510 * MS;
        let mut watch = CameraWatch::default();
        let seen = |frame_ms: Option<u64>, alive_ms: Option<u64>| CameraSeen {
            frame_at: frame_ms.map(|ms| t0 + Duration::from_millis(ms)),
            vision_alive_at: alive_ms.map(|ms| t0 + Duration::from_millis(ms)),
            robot: RobotState::Running,
        };
        // the watch begins at t0: no frame yet, the start grace (5 s) holds
        assert!(!watch.stalled(&seen(None, Some(0)), timeout, t0));
        assert!(!watch.stalled(&seen(None, Some(4900)), timeout, t0 + 4900 * MS));
        assert!(watch.stalled(&seen(None, Some(5100)), timeout, t0 + 5100 * MS), "never a frame");
        // frames every 85 ms: not stalled; then none, while the node speaks on: stalled past the timeout
        assert!(!watch.stalled(&seen(Some(5100), Some(5150)), timeout, t0 + 5150 * MS));
        assert!(!watch.stalled(&seen(Some(5100), Some(5600)), timeout, t0 + 5600 * MS));
        assert!(watch.stalled(&seen(Some(5100), Some(5700)), timeout, t0 + 5700 * MS));
        // a node stopped (SIGSTOP) speaks no more: however long, no camera stall (the hang is the supervisor's)
        assert!(!watch.stalled(&seen(Some(6000), Some(6090)), timeout, t0 + 9000 * MS));
        // a vision node down, or the robot stalled (the simulated camera waits for joint states): not watched,
        // and the watch begins again, with the grace, when they run
        assert!(!watch.stalled(&seen(Some(6000), None), timeout, t0 + 9000 * MS));
        let robot_stalled = CameraSeen { robot: RobotState::Stalled, ..seen(Some(6000), Some(9000)) };
        assert!(!watch.stalled(&robot_stalled, timeout, t0 + 9000 * MS));
        assert!(!watch.stalled(&seen(Some(6000), Some(9100)), timeout, t0 + 9100 * MS), "grace again");
        assert!(watch.stalled(&seen(Some(6000), Some(14200)), timeout, t0 + 14200 * MS));
        assert!(!watch.stalled(&seen(Some(14250), Some(14300)), timeout, t0 + 14300 * MS), "frames again");
    }

    #[test]
    fn the_daemon_starts_runs_degrades_and_a_safe_stop_overrides_all() {
        let (running, stalled) = (RobotState::Running, RobotState::Stalled);
        assert_eq!(daemon_state(false, false, false, running, false), DaemonState::Starting);
        assert_eq!(
            daemon_state(false, false, true, stalled, false),
            DaemonState::Starting,
            "the robot is part of it"
        );
        assert_eq!(daemon_state(false, false, true, running, false), DaemonState::Running);
        assert_eq!(daemon_state(false, false, false, running, true), DaemonState::Degraded);
        assert_eq!(daemon_state(false, false, true, stalled, true), DaemonState::Degraded);
        assert_eq!(daemon_state(true, false, true, running, true), DaemonState::SafeStop);
        assert_eq!(daemon_state(true, false, false, stalled, false), DaemonState::SafeStop);
        assert_eq!(daemon_state(false, true, true, running, true), DaemonState::Moving);
        assert_eq!(daemon_state(true, true, true, running, true), DaemonState::SafeStop, "held on the way");
        assert_eq!(daemon_state(false, true, false, running, true), DaemonState::Degraded);
    }

    #[test]
    fn ready_once_and_the_watchdog_only_while_the_arm_can_be_brought_to_rest() {
        let t0 = Instant::now();
        let mut readiness = Readiness::new(t0);
        let every = Some(100 * MS);
        assert!(!readiness.watchdog_due(every, true, t0 + 200 * MS), "not before ready");
        assert!(!readiness.became_ready(true, RobotState::Stalled));
        assert!(readiness.became_ready(true, RobotState::Running));
        assert!(!readiness.became_ready(true, RobotState::Running), "once");
        assert!(readiness.ever_ready());
        assert!(readiness.watchdog_due(every, true, t0 + 200 * MS));
        assert!(!readiness.watchdog_due(every, true, t0 + 250 * MS), "not again within the interval");
        assert!(!readiness.watchdog_due(every, false, t0 + 400 * MS), "withheld: the rmrc is down");
        assert!(readiness.watchdog_due(every, true, t0 + 400 * MS));
        assert!(!readiness.watchdog_due(None, true, t0 + 900 * MS), "systemd asked for none");
    }

    #[test]
    fn the_resume_conditions_count_the_rmrc_and_plant_but_not_the_servo_or_vision() {
        let t0 = Instant::now();
        let policy = RestartPolicy::new(100 * MS, 100 * MS, t0);
        let mut nodes: Vec<NodeRecord> =
            NodeRole::ALL.into_iter().map(|role| NodeRecord::started(role, 1, policy)).collect();
        for node in &mut nodes {
            node.heard.telemetry_at = Some(t0);
            node.heard.telemetry = Some(crate::supervisor::node::tests_support::telemetry(1, 1));
        }
        let conditions = resume_conditions(5, RobotState::Running, true, false, &nodes, t0);
        assert!(conditions.motion_nodes_healthy);
        assert_eq!(
            (conditions.now_ns, conditions.robot, conditions.external_robot),
            (5, RobotState::Running, true)
        );
        let servo = nodes.iter().position(|n| n.role == NodeRole::Servo).expect("servo");
        nodes[servo].ended(1, t0);
        assert!(motion_nodes_healthy(&nodes, t0), "a servo restart keeps the arm safe");
        let rmrc = nodes.iter().position(|n| n.role == NodeRole::Rmrc).expect("rmrc");
        nodes[rmrc].ended(1, t0);
        assert!(!resume_conditions(5, RobotState::Running, true, false, &nodes, t0).motion_nodes_healthy);
        // an external driver: no plant among the nodes, the rmrc alone counts
        nodes.retain(|n| n.role != NodeRole::Plant && n.role != NodeRole::Rmrc);
        assert!(motion_nodes_healthy(&nodes, t0));
    }
}
