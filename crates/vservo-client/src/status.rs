//! The status of a running instance as users see it (`vservoctl status`, the daemon's one-line status):
//! the daemon's view of its nodes joined with each node's latest telemetry.

use std::collections::BTreeMap;

use serde::Serialize;
use vservo_protocol::{
    DaemonState, DaemonStatusMsg, DriverError, Fault, NodeRole, NodeState, RobotState, TelemetryMsg,
    TimingMsg, UnknownCode,
};

/// Percentiles in microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TimingUs {
    /// Samples in the window.
    pub count: u64,
    /// Median (µs).
    pub p50: f64,
    /// 99th percentile (µs).
    pub p99: f64,
    /// 99.9th percentile (µs).
    pub p999: f64,
    /// Largest (µs).
    pub max: f64,
}

impl From<&TimingMsg> for TimingUs {
    fn from(t: &TimingMsg) -> Self {
        let us = |ns: u64| ns as f64 / 1e3;
        Self { count: t.count, p50: us(t.p50_ns), p99: us(t.p99_ns), p999: us(t.p999_ns), max: us(t.max_ns) }
    }
}

/// One node.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeView {
    /// "not started", "running", "backing off" (restart pending), "stopped" or "hung" (being killed, then
    /// restarted).
    pub state: &'static str,
    /// Whether its process runs and is not hung.
    pub running: bool,
    /// Restarts since the daemon started.
    pub restarts: u64,
    /// Its telemetry is fresh.
    pub healthy: bool,
    /// Process id (0 when not running).
    pub pid: u32,
    /// Loop cycles since it started.
    pub cycles: u64,
    /// Cycles a period or more late since it started.
    pub overruns: u64,
    /// Periods skipped after stalls.
    pub skipped_periods: u64,
    /// plant: late answers from the rmrc (previous command's reference followed).
    pub late_answers: u64,
    /// Input messages refused.
    pub rejected_messages: u64,
    /// Wake-up latency over the last telemetry window.
    pub wake_latency_us: Option<TimingUs>,
    /// Execution time over the last telemetry window.
    pub execution_us: Option<TimingUs>,
    /// plant only: state → rmrc → answer round trip over the last window.
    pub round_trip_us: Option<TimingUs>,
    /// vision only: the camera's frame period (between capture stamps) over the last window.
    pub frame_period_us: Option<TimingUs>,
    /// servo only: from an image's capture to its twist, over the last window.
    pub capture_latency_us: Option<TimingUs>,
}

/// The fault that holds the cell in a safe stop, or the last one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FaultView {
    /// "position_limit", "velocity_limit", "torque_saturated", "driver_fault", "target_lost",
    /// "robot_stalled", "requested", … (`vservo_protocol::Fault`).
    pub name: &'static str,
    /// A driver fault's reason as the robot gave it (e.g. the Franka's "communication_constraints_violation"),
    /// if the driver gave one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub driver_error: Option<&'static str>,
    /// The joints it concerns (1–7), if any.
    pub joints: Vec<u32>,
    /// Whether it holds the cell now (false: it was resumed).
    pub active: bool,
    /// How long ago it was found (s).
    pub since_s: f64,
    /// The daemon's uptime when it was found (s).
    pub at_uptime_s: f64,
}

/// The whole instance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StatusView {
    /// The instance name.
    pub instance: String,
    /// "starting", "running", "moving" (a client's joint move), "degraded", "stopping" or "safe-stop" (a fault holds the arm at rest: see
    /// `fault`).
    pub state: &'static str,
    /// The fault that holds the cell, or the last one; null when none since the start.
    pub fault: Option<FaultView>,
    /// Safe stops since the daemon started.
    pub safe_stops: u64,
    /// Since the daemon started (s).
    pub uptime_s: f64,
    /// The daemon's process id.
    pub daemon_pid: u32,
    /// Per node, by name.
    pub nodes: BTreeMap<&'static str, NodeView>,
    /// How many nodes the daemon runs (3 with an external robot driver: no plant).
    pub supervised_nodes: usize,
    /// The robot driver: "waiting" (no joint state yet), "running" or "stalled" (none within the deadline).
    pub robot: &'static str,
    /// Joint states per wall-clock second.
    pub tick_rate_hz: f64,
    /// The servo's latest RMS feature error (px); null before the first frame.
    pub feature_error_px: Option<f64>,
    /// Gains version in use.
    pub gains_version: u64,
    /// Overruns per node, by name.
    pub overruns: BTreeMap<&'static str, u64>,
    /// The dynamics override in force: the share of the arm's speed, acceleration and jerk limits (and of the
    /// tool's caps) the reference keeps (`vservoctl speed`).
    pub speed_scale: f64,
    /// The collision guard's nearest distance, the rmrc's reference as it stands; null without a guard or with
    /// nothing within 1 m.
    pub clearance: Option<ClearanceView>,
}

/// The collision guard's nearest distance.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ClearanceView {
    /// The distance (m; negative: an overlap).
    pub distance_m: f64,
    /// Between what: "camera – table".
    pub between: String,
}

/// The name of a code another process wrote: its enum's, or "unknown".
fn name_of<E: TryFrom<u32, Error = UnknownCode>>(code: u32, name: fn(E) -> &'static str) -> &'static str {
    E::try_from(code).map_or("unknown", name)
}

impl StatusView {
    /// Joins the daemon's status with the latest telemetry of each node (`telemetry[role as usize]`).
    pub fn new(instance: &str, daemon: &DaemonStatusMsg, telemetry: &[Option<TelemetryMsg>; 4]) -> Self {
        let mut nodes = BTreeMap::new();
        let mut overruns = BTreeMap::new();
        let supervised_nodes =
            daemon.nodes.iter().filter(|n| n.state != u32::from(NodeState::NotStarted)).count();
        for role in NodeRole::ALL {
            let status = &daemon.nodes[role as usize];
            let latest = telemetry[role as usize].as_ref();
            let timing = |f: fn(&TelemetryMsg) -> &TimingMsg| {
                latest.map(f).filter(|t| t.count > 0).map(TimingUs::from)
            };
            let view = NodeView {
                state: name_of(status.state, NodeState::name),
                running: status.state == u32::from(NodeState::Running),
                restarts: status.restarts,
                healthy: status.healthy != 0,
                pid: status.pid,
                cycles: latest.map_or(0, |t| t.cycles),
                overruns: latest.map_or(0, |t| t.overruns),
                skipped_periods: latest.map_or(0, |t| t.skipped_periods),
                late_answers: latest.map_or(0, |t| t.late_answers),
                rejected_messages: latest.map_or(0, |t| t.rejected_messages),
                wake_latency_us: timing(|t| &t.wake_latency),
                execution_us: timing(|t| &t.execution),
                round_trip_us: timing(|t| &t.round_trip),
                frame_period_us: timing(|t| &t.frame_period),
                capture_latency_us: timing(|t| &t.capture_latency),
            };
            overruns.insert(role.name(), view.overruns);
            nodes.insert(role.name(), view);
        }
        let fault = (daemon.fault != u32::from(Fault::None)).then(|| FaultView {
            name: name_of(daemon.fault, Fault::name),
            driver_error: DriverError::try_from(daemon.driver_error)
                .ok()
                .filter(|reason| *reason != DriverError::None)
                .map(DriverError::name),
            joints: (0..vservo_protocol::MAX_JOINTS as u32)
                .filter(|j| daemon.fault_joints & (1 << j) != 0)
                .map(|j| j + 1)
                .collect(),
            active: daemon.state == u32::from(DaemonState::SafeStop),
            since_s: vservo_time::seconds_between(daemon.stamp_ns, daemon.fault_since_ns),
            at_uptime_s: vservo_time::seconds_between(
                daemon.uptime_ns,
                daemon.stamp_ns.saturating_sub(daemon.fault_since_ns),
            ),
        });
        Self {
            instance: instance.to_string(),
            state: name_of(daemon.state, DaemonState::name),
            fault,
            safe_stops: daemon.safe_stops,
            uptime_s: vservo_time::Nanos(daemon.uptime_ns).seconds(),
            daemon_pid: daemon.pid,
            robot: name_of(daemon.robot, RobotState::name),
            nodes,
            supervised_nodes,
            tick_rate_hz: daemon.tick_rate_hz,
            feature_error_px: daemon.feature_error_px.is_finite().then_some(daemon.feature_error_px),
            gains_version: daemon.gains_version,
            overruns,
            speed_scale: daemon.speed_scale,
            clearance: daemon.clearance_m.is_finite().then(|| ClearanceView {
                distance_m: daemon.clearance_m,
                between: String::from_utf8_lossy(&daemon.clearance_between)
                    .trim_end_matches('\0')
                    .to_string(),
            }),
        }
    }

    /// The collision guard's nearest distance as a phrase ("clearance 31 mm (camera – table)"), if there is one.
    pub fn clearance_text(&self) -> Option<String> {
        self.clearance.as_ref().map(|c| format!("clearance {:.0} mm ({})", c.distance_m * 1e3, c.between))
    }

    /// One line: state, nodes up, robot, tick rate, plant lateness and round trip, frame period and
    /// capture-to-twist latency, error, gains version.
    pub fn one_line(&self) -> String {
        let up = self.nodes.values().filter(|n| n.running).count();
        let restarts: u64 = self.nodes.values().map(|n| n.restarts).sum();
        let node = |name: &str| self.nodes.get(name);
        let us = |t: Option<TimingUs>| t.map_or("-".to_string(), |t| format!("{:.0}/{:.0}", t.p50, t.p99));
        let ms = |t: Option<TimingUs>| {
            t.map_or("-".to_string(), |t| format!("{:.1}/{:.1}", t.p50 / 1e3, t.max / 1e3))
        };
        let error = self.feature_error_px.map_or("-".to_string(), |e| format!("{e:.2}"));
        let state = match &self.fault {
            Some(f) if f.active => {
                let joints = if f.joints.is_empty() {
                    String::new()
                } else {
                    format!(" joint {}", f.joints.iter().map(u32::to_string).collect::<Vec<_>>().join(","))
                };
                let reason = f.driver_error.map_or(String::new(), |reason| format!(": {reason}"));
                format!("{} ({}{reason}{joints} for {:.1} s)", self.state, f.name, f.since_s)
            }
            _ => self.state.to_string(),
        };
        let clearance = self.clearance_text().map_or(String::new(), |text| format!(" {text}"));
        format!(
            "{state} nodes {up}/{} robot {} ticks {:.0}/s late(p50/p99 µs) {} round-trip {} frame(p50/max ms) {} capture→twist {} overruns {} restarts {restarts} error {error} px gains v{}{clearance}",
            self.supervised_nodes,
            self.robot,
            self.tick_rate_hz,
            us(node("plant").and_then(|p| p.wake_latency_us)),
            us(node("plant").and_then(|p| p.round_trip_us)),
            ms(node("vision").and_then(|p| p.frame_period_us)),
            ms(node("servo").and_then(|p| p.capture_latency_us)),
            self.overruns.values().sum::<u64>(),
            self.gains_version
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_view_names_the_codes_and_says_unknown_for_a_number_it_does_not_know() {
        let mut daemon = DaemonStatusMsg {
            state: DaemonState::SafeStop.into(),
            robot: RobotState::Stalled.into(),
            fault: Fault::RobotStalled.into(),
            fault_joints: 0b100,
            ..DaemonStatusMsg::default()
        };
        daemon.nodes[NodeRole::Rmrc as usize].state = NodeState::BackingOff.into();
        let view = StatusView::new("cell", &daemon, &[None; 4]);
        assert_eq!((view.state, view.robot), ("safe-stop", "stalled"));
        assert_eq!(view.nodes["rmrc"].state, "backing off");
        assert_eq!(view.nodes["plant"].state, "not started");
        assert_eq!(view.supervised_nodes, 1);
        let fault = view.fault.expect("a fault");
        assert_eq!((fault.name, fault.joints, fault.active), ("robot_stalled", vec![3], true));
        daemon.state = 99;
        assert_eq!(StatusView::new("cell", &daemon, &[None; 4]).state, "unknown");
    }

    #[test]
    fn the_clearance_is_shown_with_its_names_and_left_out_without_a_guard() {
        let mut daemon = DaemonStatusMsg::default();
        assert_eq!(StatusView::new("cell", &daemon, &[None; 4]).clearance, None, "NaN: no guard");
        daemon.clearance_m = 0.0314;
        daemon.clearance_between[..16].copy_from_slice("camera – table".as_bytes());
        let view = StatusView::new("cell", &daemon, &[None; 4]);
        let clearance = view.clearance.as_ref().expect("a clearance");
        assert_eq!((clearance.distance_m, clearance.between.as_str()), (0.0314, "camera – table"));
        assert!(view.one_line().ends_with(" clearance 31 mm (camera – table)"), "{}", view.one_line());
    }

    #[test]
    fn a_driver_fault_names_the_robots_reason() {
        let daemon = DaemonStatusMsg {
            state: DaemonState::SafeStop.into(),
            fault: Fault::DriverFault.into(),
            driver_error: DriverError::FrankaJointMotionGeneratorAccelerationDiscontinuity.into(),
            ..DaemonStatusMsg::default()
        };
        let view = StatusView::new("cell", &daemon, &[None; 4]);
        let fault = view.fault.as_ref().expect("a fault");
        assert_eq!(fault.driver_error, Some("joint_motion_generator_acceleration_discontinuity"));
        assert!(
            view.one_line()
                .starts_with("safe-stop (driver_fault: joint_motion_generator_acceleration_discontinuity"),
            "{}",
            view.one_line()
        );
    }

    #[test]
    fn a_seven_joint_arms_fault_names_its_seventh_joint() {
        let daemon = DaemonStatusMsg {
            state: DaemonState::SafeStop.into(),
            fault: Fault::VelocityLimit.into(),
            fault_joints: 0b100_0001,
            ..DaemonStatusMsg::default()
        };
        let fault = StatusView::new("cell", &daemon, &[None; 4]).fault.expect("a fault");
        assert_eq!(fault.joints, vec![1, 7]);
    }
}
