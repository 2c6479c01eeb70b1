//! The daemon's status message and the tick rate it reports. Pure: stamps and time are passed in.

use std::time::{Duration, Instant};

use vservo_protocol::{DaemonState, DaemonStatusMsg, Fault, NodeStatusMsg, RobotState, SCHEMA_VERSION};

use super::node::NodeRecord;

/// A tick rate from joint states no older than this is reported; an older one is 0/s (a driver or plant
/// silent for a second ticks at 0/s).
pub const RATE_WINDOW: Duration = Duration::from_secs(1);
/// The rate is measured over at least this span of joint-state stamps (ns).
const RATE_SPAN_NS: u64 = 1_000_000_000;

/// The robot driver's tick rate, measured over a second of its joint states' stamps.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TickRate {
    /// (stamp, tick) at the start of the span being measured.
    base: Option<(u64, u64)>,
    hz: f64,
}

impl TickRate {
    /// Takes the latest joint state's stamp (ns) and tick.
    pub fn observe(&mut self, stamp_ns: u64, tick: u64) {
        match self.base {
            Some((base_stamp, base_tick)) if stamp_ns >= base_stamp + RATE_SPAN_NS => {
                let seconds = (stamp_ns - base_stamp) as f64 / 1e9;
                self.hz = tick.saturating_sub(base_tick) as f64 / seconds;
                self.base = Some((stamp_ns, tick));
            }
            Some(_) => {}
            None => self.base = Some((stamp_ns, tick)),
        }
    }

    /// The rate to report when the latest joint state is `age` old (none: never heard).
    pub fn reported_hz(&self, age: Option<Duration>) -> f64 {
        match age {
            Some(age) if age < RATE_WINDOW => self.hz,
            _ => 0.0,
        }
    }
}

/// What the status says besides the nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusFacts {
    /// The daemon's state.
    pub state: DaemonState,
    /// The robot driver's state.
    pub robot: RobotState,
    /// CLOCK_MONOTONIC now, and at the daemon's start (ns).
    pub stamp_ns: u64,
    /// CLOCK_MONOTONIC at the daemon's start (ns).
    pub started_ns: u64,
    /// The version the servo said it runs (0: not yet said).
    pub servo_gains_version: u64,
    /// The version the daemon designed last.
    pub designed_gains_version: u64,
    /// The tick rate to report.
    pub tick_rate_hz: f64,
    /// The servo's latest feature error (px).
    pub feature_error_px: f64,
    /// The daemon's pid.
    pub pid: u32,
}

/// The status message: the nodes as the supervisor sees them and `facts`; the fault fields are the
/// safety's to fill.
pub fn status_message<'a>(
    nodes: impl IntoIterator<Item = &'a NodeRecord>,
    facts: &StatusFacts,
    now: Instant,
) -> DaemonStatusMsg {
    let mut statuses = [NodeStatusMsg::default(); 4];
    for node in nodes {
        statuses[node.role as usize] = node.status(now);
    }
    DaemonStatusMsg {
        schema: SCHEMA_VERSION,
        state: facts.state.into(),
        stamp_ns: facts.stamp_ns,
        uptime_ns: facts.stamp_ns.saturating_sub(facts.started_ns),
        // the version the servo runs, once it has said; until then the one designed
        gains_version: if facts.servo_gains_version > 0 {
            facts.servo_gains_version
        } else {
            facts.designed_gains_version
        },
        nodes: statuses,
        tick_rate_hz: facts.tick_rate_hz,
        feature_error_px: facts.feature_error_px,
        pid: facts.pid,
        robot: facts.robot.into(),
        fault: Fault::None.into(),
        fault_joints: 0,
        fault_since_ns: 0,
        safe_stops: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::restart::RestartPolicy;
    use vservo_protocol::NodeRole;

    const S: u64 = 1_000_000_000;

    #[test]
    fn the_tick_rate_is_measured_over_a_second_and_zero_when_the_states_stop() {
        let mut rate = TickRate::default();
        rate.observe(10 * S, 100);
        rate.observe(10 * S + S / 2, 600);
        assert_eq!(rate.reported_hz(Some(Duration::ZERO)), 0.0, "not a second yet");
        rate.observe(11 * S, 1100);
        assert_eq!(rate.reported_hz(Some(Duration::from_millis(999))), 1000.0);
        assert_eq!(rate.reported_hz(Some(RATE_WINDOW)), 0.0, "silent for a second");
        assert_eq!(rate.reported_hz(None), 0.0);
        rate.observe(13 * S, 1600);
        assert_eq!(rate.reported_hz(Some(Duration::ZERO)), 250.0);
    }

    #[test]
    fn the_status_names_each_node_in_its_slot_and_the_servos_gains_version_once_it_said() {
        let t0 = Instant::now();
        let policy = RestartPolicy::new(Duration::from_millis(100), Duration::from_secs(1), t0);
        let nodes = [NodeRecord::started(NodeRole::Vision, 77, policy)];
        let facts = StatusFacts {
            state: DaemonState::Starting,
            robot: RobotState::Waiting,
            stamp_ns: 5 * S,
            started_ns: 2 * S,
            servo_gains_version: 0,
            designed_gains_version: 1,
            tick_rate_hz: 0.0,
            feature_error_px: f64::NAN,
            pid: 9,
        };
        let message = status_message(&nodes, &facts, t0);
        assert_eq!((message.uptime_ns, message.gains_version, message.pid), (3 * S, 1, 9));
        let vision = message.nodes[NodeRole::Vision as usize];
        assert_eq!((vision.pid, vision.state), (77, vservo_protocol::NodeState::Running.into()));
        assert_eq!(message.nodes[NodeRole::Plant as usize], NodeStatusMsg::default(), "not supervised");
        let said = status_message(&nodes, &StatusFacts { servo_gains_version: 3, ..facts }, t0);
        assert_eq!(said.gains_version, 3);
    }
}
