//! One supervised node as the supervisor knows it, apart from its process: its state, its restart policy,
//! what its telemetry said and when, and the decisions on it — healthy, hung, its line in the status. Pure:
//! time is passed in, the process is only its pid.

use std::time::{Duration, Instant};

use vservo_protocol::{NodeRole, NodeState, NodeStatusMsg, TelemetryMsg};

use super::restart::RestartPolicy;

/// A node whose telemetry is older than this is not healthy.
pub const TELEMETRY_STALE: Duration = Duration::from_millis(500);
/// Before its first telemetry a started node gets at least this long (creating its iceoryx2 ports, the
/// gain design, a debug build's start).
pub const START_GRACE: Duration = Duration::from_secs(5);

/// Why a node counts as hung: its process runs but its loop shows no progress.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum Hang {
    /// No telemetry (a stopped or dead-locked process).
    #[error("no telemetry for {:.1} s", .0.as_secs_f64())]
    NoTelemetry(Duration),
    /// The plant's tick does not advance.
    #[error("no new tick for {:.1} s", .0.as_secs_f64())]
    NoNewTick(Duration),
}

/// What the node's telemetry said, and when.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TelemetryHeard {
    /// The latest telemetry.
    pub telemetry: Option<TelemetryMsg>,
    /// When it arrived.
    pub telemetry_at: Option<Instant>,
    /// The loop's progress counter, and when it last moved.
    pub progress: u64,
    /// When `progress` last moved.
    pub progress_at: Option<Instant>,
}

/// One node, apart from its process.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeRecord {
    /// Which node.
    pub role: NodeRole,
    /// Its process's pid while it runs.
    pub pid: Option<u32>,
    /// Its state.
    pub state: NodeState,
    /// When it starts again.
    pub restart: RestartPolicy,
    /// How its last process ended (the exit code, or minus the signal).
    pub last_exit: i32,
    /// What its telemetry said.
    pub heard: TelemetryHeard,
}

impl NodeRecord {
    /// A node whose process `pid` started at `now`.
    pub fn started(role: NodeRole, pid: u32, restart: RestartPolicy) -> Self {
        Self {
            role,
            pid: Some(pid),
            state: NodeState::Running,
            restart,
            last_exit: 0,
            heard: TelemetryHeard::default(),
        }
    }

    /// Takes one telemetry message of this node, arrived at `now`.
    pub fn on_telemetry(&mut self, telemetry: TelemetryMsg, now: Instant) {
        if telemetry.progress != self.heard.progress || self.heard.progress_at.is_none() {
            self.heard.progress = telemetry.progress;
            self.heard.progress_at = Some(now);
        }
        self.heard.telemetry = Some(telemetry);
        self.heard.telemetry_at = Some(now);
    }

    /// The latest telemetry, if the running process sent it (not its predecessor).
    pub fn own_telemetry(&self) -> Option<TelemetryMsg> {
        self.heard.telemetry.filter(|t| self.pid.is_some_and(|pid| t.pid == pid))
    }

    /// Its process ended at `now` with `exit`: it backs off; returns the wait before its restart.
    pub fn ended(&mut self, exit: i32, now: Instant) -> Duration {
        self.pid = None;
        self.last_exit = exit;
        self.state = NodeState::BackingOff;
        self.restart.ended(now)
    }

    /// Its process `pid` started again at `now`.
    pub fn restarted(&mut self, pid: u32, now: Instant) {
        self.pid = Some(pid);
        self.state = NodeState::Running;
        self.restart.restarted(now);
        self.heard.progress_at = Some(now);
    }

    /// Its process was stopped on purpose.
    pub fn stopped(&mut self, exit: Option<i32>) {
        self.pid = None;
        if let Some(exit) = exit {
            self.last_exit = exit;
        }
        self.state = NodeState::Stopped;
    }

    /// Running, its own telemetry fresh.
    pub fn healthy(&self, now: Instant) -> bool {
        self.own_telemetry().is_some()
            && self.heard.telemetry_at.is_some_and(|at| now.duration_since(at) < TELEMETRY_STALE)
    }

    /// Why the node counts as hung at `now`, if it does: its process runs but its loop shows no progress —
    /// no telemetry for `timeout` (at least [`START_GRACE`] before the first), or, for the plant, no new
    /// tick. A node already being ended as hung is not judged again.
    pub fn hang(&self, now: Instant, timeout: Duration) -> Option<Hang> {
        if self.pid.is_none() || self.state == NodeState::Hung {
            return None;
        }
        let started_at = self.restart.started_at();
        let own_telemetry_at = self.heard.telemetry_at.filter(|_| self.own_telemetry().is_some());
        let silent_since = own_telemetry_at.unwrap_or(started_at);
        let allowed = if own_telemetry_at.is_some() { timeout } else { timeout.max(START_GRACE) };
        if now.duration_since(silent_since) > allowed {
            return Some(Hang::NoTelemetry(now.duration_since(silent_since)));
        }
        let still_since = self.heard.progress_at.map_or(started_at, |at| at.max(started_at));
        if self.role == NodeRole::Plant
            && own_telemetry_at.is_some()
            && now.duration_since(still_since) > timeout
        {
            return Some(Hang::NoNewTick(now.duration_since(still_since)));
        }
        None
    }

    /// Its line in the daemon's status.
    pub fn status(&self, now: Instant) -> NodeStatusMsg {
        NodeStatusMsg {
            restarts: self.restart.restarts(),
            last_telemetry_ns: self.heard.telemetry.map_or(0, |t| t.stamp_ns),
            state: self.state.into(),
            pid: self.pid.unwrap_or(0),
            last_exit: self.last_exit,
            healthy: u32::from(self.healthy(now)),
        }
    }
}

/// What the supervisor's unit tests build nodes from.
#[cfg(test)]
pub mod tests_support {
    use vservo_protocol::TelemetryMsg;

    /// The telemetry of process `pid` at loop progress `progress`.
    pub fn telemetry(pid: u32, progress: u64) -> TelemetryMsg {
        // a number, not the default's NaN: the tests compare messages
        let feature_error_px = 0.0;
        TelemetryMsg { pid, progress, feature_error_px, ..TelemetryMsg::default() }
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::telemetry;
    use super::*;

    const MS: Duration = Duration::from_millis(1);
    const TIMEOUT: Duration = Duration::from_secs(1);

    fn node(role: NodeRole, t0: Instant) -> NodeRecord {
        NodeRecord::started(role, 42, RestartPolicy::new(100 * MS, 5000 * MS, t0))
    }

    #[test]
    fn a_node_is_healthy_while_its_own_telemetry_is_fresh() {
        let t0 = Instant::now();
        let mut node = node(NodeRole::Servo, t0);
        assert!(!node.healthy(t0), "no telemetry yet");
        node.on_telemetry(telemetry(7, 1), t0);
        assert!(!node.healthy(t0), "its predecessor's telemetry");
        node.on_telemetry(telemetry(42, 2), t0);
        assert!(node.healthy(t0 + TELEMETRY_STALE - MS));
        assert!(!node.healthy(t0 + TELEMETRY_STALE), "stale");
        node.ended(-9, t0 + MS);
        assert!(!node.healthy(t0 + MS), "no process");
        let status = node.status(t0 + MS);
        assert_eq!(
            (status.state, status.pid, status.last_exit, status.healthy),
            (NodeState::BackingOff.into(), 0, -9, 0)
        );
    }

    #[test]
    fn a_silent_node_is_hung_after_the_timeout_or_the_start_grace_before_its_first_telemetry() {
        let t0 = Instant::now();
        let mut node = node(NodeRole::Servo, t0);
        assert_eq!(node.hang(t0 + START_GRACE, TIMEOUT), None, "starting");
        assert!(matches!(node.hang(t0 + START_GRACE + MS, TIMEOUT), Some(Hang::NoTelemetry(_))));
        node.on_telemetry(telemetry(42, 1), t0 + 100 * MS);
        assert_eq!(node.hang(t0 + 1100 * MS, TIMEOUT), None);
        let hang = node.hang(t0 + 1101 * MS, TIMEOUT).expect("silent for the timeout");
        assert_eq!(hang.to_string(), "no telemetry for 1.0 s");
        // being ended as hung, it is not judged again; without a process, never
        node.state = NodeState::Hung;
        assert_eq!(node.hang(t0 + 5000 * MS, TIMEOUT), None);
        node.ended(-9, t0 + 5000 * MS);
        assert_eq!(node.hang(t0 + 9000 * MS, TIMEOUT), None);
    }

    #[test]
    fn a_plant_whose_tick_stands_still_is_hung_though_its_telemetry_comes() {
        let t0 = Instant::now();
        let mut plant = node(NodeRole::Plant, t0);
        let mut servo = node(NodeRole::Servo, t0);
        for ms in (0..=1500).step_by(100) {
            plant.on_telemetry(telemetry(42, 7), t0 + ms * MS);
            servo.on_telemetry(telemetry(42, 7), t0 + ms * MS);
        }
        assert!(matches!(plant.hang(t0 + 1500 * MS, TIMEOUT), Some(Hang::NoNewTick(_))));
        assert_eq!(servo.hang(t0 + 1500 * MS, TIMEOUT), None, "only the plant ticks");
        plant.on_telemetry(telemetry(42, 8), t0 + 1600 * MS);
        assert_eq!(plant.hang(t0 + 1600 * MS, TIMEOUT), None);
    }

    #[test]
    fn a_restart_counts_and_gives_the_new_process_its_grace() {
        let t0 = Instant::now();
        let mut node = node(NodeRole::Rmrc, t0);
        node.on_telemetry(telemetry(42, 1), t0);
        let wait = node.ended(1, t0 + 10 * MS);
        node.restarted(43, t0 + 10 * MS + wait);
        let status = node.status(t0 + 10 * MS + wait);
        assert_eq!((status.restarts, status.pid, status.state), (1, 43, NodeState::Running.into()));
        // the old process's telemetry is not the new one's
        assert_eq!(node.own_telemetry(), None);
        assert_eq!(node.hang(t0 + 10 * MS + wait + START_GRACE, TIMEOUT), None);
    }
}
