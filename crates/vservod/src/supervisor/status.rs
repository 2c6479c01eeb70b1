//! The daemon's status message and the tick rate it reports. Pure: stamps and time are passed in.

use std::time::{Duration, Instant};

use vservo_protocol::{
    DaemonState, DaemonStatusMsg, DriverError, Fault, NodeStatusMsg, RobotState, SCHEMA_VERSION,
};

use super::node::NodeRecord;

/// The tick rate is joint states per second of the daemon's clock over this last span.
pub const RATE_WINDOW: Duration = Duration::from_secs(1);
/// Samples kept for the window: one per supervisor cycle (50 ms), and one more at the window's start.
const RATE_SAMPLES: usize = 24;

/// The robot driver's tick rate: joint states counted as they arrive, per second of the daemon's clock over
/// the last second. It drops to 0 as soon as the driver is found stalled (the count starts afresh), and
/// counts again from the first states after it is back, over what has passed since.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TickRate {
    /// Joint states received since the daemon started.
    received: u64,
    /// (when, `received` then), oldest first, spanning at most the window.
    samples: std::collections::VecDeque<(Instant, u64)>,
}

impl TickRate {
    /// One joint state arrived.
    pub fn on_state(&mut self) {
        self.received += 1;
    }

    /// Takes a sample at `now` (once a supervisor cycle); a stalled driver forgets the count.
    pub fn sample(&mut self, now: Instant, stalled: bool) {
        if stalled {
            self.samples.clear();
            return;
        }
        // keep the newest sample at or before the window's start, and everything after it
        while self.samples.len() >= 2
            && self.samples.get(1).is_some_and(|(at, _)| now.duration_since(*at) >= RATE_WINDOW)
        {
            self.samples.pop_front();
        }
        if self.samples.len() == RATE_SAMPLES {
            self.samples.pop_front();
        }
        self.samples.push_back((now, self.received));
    }

    /// Joint states per second over the samples kept (0 with fewer than two).
    pub fn hz(&self) -> f64 {
        match (self.samples.front(), self.samples.back()) {
            (Some((first_at, first)), Some((last_at, last))) if last_at > first_at => {
                (last - first) as f64 / last_at.duration_since(*first_at).as_secs_f64()
            }
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
        driver_error: DriverError::None.into(),
        reserved: 0,
        // the dynamics override in force (`Safety::fill`)
        speed_scale: 1.0,
        // the collision guard's nearest distance (`ClearanceWatch::fill`)
        clearance_m: f64::NAN,
        clearance_between: [0; vservo_protocol::CLEARANCE_NAME_BYTES],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::restart::RestartPolicy;
    use vservo_protocol::NodeRole;

    const S: u64 = 1_000_000_000;

    /// Feeds `rate` `per_cycle` joint states in each of `cycles` 50 ms cycles after `from`; returns the time
    /// of the last sample.
    fn run(rate: &mut TickRate, from: Instant, cycles: u32, per_cycle: u32, stalled: bool) -> Instant {
        let cycle = Duration::from_millis(50);
        for i in 1..=cycles {
            (0..per_cycle).for_each(|_| rate.on_state());
            rate.sample(from + cycle * i, stalled);
        }
        from + cycle * cycles
    }

    #[test]
    fn the_tick_rate_counts_states_per_second_and_drops_at_once_to_zero_on_a_stall() {
        let mut rate = TickRate::default();
        let t0 = Instant::now();
        assert_eq!(rate.hz(), 0.0, "nothing heard");
        rate.sample(t0, false);
        let t = run(&mut rate, t0, 40, 50, false);
        assert_eq!(rate.hz(), 1000.0, "1 kHz over the last second");
        // the driver slows to 500 Hz: within a second the rate says so
        let t = run(&mut rate, t, 20, 25, false);
        assert_eq!(rate.hz(), 500.0);
        // states stop: the rate falls while the deadline has not passed, and is 0 once stalled
        let t = run(&mut rate, t, 2, 0, false);
        assert!(rate.hz() < 500.0 && rate.hz() > 0.0, "{}", rate.hz());
        let t = run(&mut rate, t, 1, 0, true);
        assert_eq!(rate.hz(), 0.0, "stalled");
        // back: counted from its first states, not a second later
        let t = run(&mut rate, t, 2, 50, false);
        assert_eq!(rate.hz(), 1000.0, "back at 1 kHz after two cycles");
        let _ = run(&mut rate, t, 40, 50, false);
        assert_eq!(rate.hz(), 1000.0);
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
