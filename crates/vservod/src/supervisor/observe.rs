//! What the supervisor observes of the loop: it drains the services it subscribes to every cycle, keeps
//! the latest of each ([`LoopHeard`]), hands every joint state, twist and feature vector to the fault
//! monitor and each node's telemetry to its record.

use std::time::Instant;

use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{Node, ipc};
use vservo_protocol::seal::SealKey;
use vservo_protocol::{
    CameraTwistMsg, DaemonStatusMsg, FeaturesMsg, JointCommandMsg, JointStateMsg, NodeRole, Refused,
    RobotState, TakeMessages, TelemetryMsg, Topic,
};
use vservo_time::monotonic_ns;

use super::launch::Supervised;
use super::node::NodeRecord;
use super::status::TickRate;
use crate::faults::FaultMonitor;

/// The daemon's ports on the loop's services.
pub struct Ports {
    telemetry: Subscriber<ipc::Service, TelemetryMsg, ()>,
    joint_state: Subscriber<ipc::Service, JointStateMsg, ()>,
    twist: Subscriber<ipc::Service, CameraTwistMsg, ()>,
    command: Subscriber<ipc::Service, JointCommandMsg, ()>,
    features: Subscriber<ipc::Service, FeaturesMsg, ()>,
    /// The daemon's status, published every cycle.
    pub status: Publisher<ipc::Service, DaemonStatusMsg, ()>,
    /// The run's key: only sealed twists and features are evidence.
    key: SealKey,
}

impl Ports {
    /// Opens the ports of instance `instance` on `node`.
    pub fn open(node: &Node<ipc::Service>, instance: &str, key: SealKey) -> anyhow::Result<Self> {
        Ok(Self {
            telemetry: vservo_protocol::subscriber(node, instance, Topic::Telemetry)?,
            joint_state: vservo_protocol::subscriber(node, instance, Topic::JointState)?,
            twist: vservo_protocol::subscriber(node, instance, Topic::CameraTwist)?,
            command: vservo_protocol::subscriber(node, instance, Topic::JointCommand)?,
            features: vservo_protocol::subscriber(node, instance, Topic::Features)?,
            status: vservo_protocol::publisher(node, instance, Topic::Status)?,
            key,
        })
    }

    /// Publishes the status (a full service drops it: the next cycle sends a newer one).
    pub fn publish_status(&self, message: DaemonStatusMsg) {
        if let Ok(sample) = self.status.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
    }
}

/// What the daemon has heard from the loop.
#[derive(Debug, Clone)]
pub struct LoopHeard {
    /// The latest joint state.
    pub joint_state: Option<JointStateMsg>,
    /// When the latest joint state arrived.
    pub joint_state_at: Option<Instant>,
    /// The latest joint command.
    pub command: Option<JointCommandMsg>,
    /// The latest features.
    pub features: Option<FeaturesMsg>,
    /// When the latest features arrived (a frame the vision node took).
    pub features_at: Option<Instant>,
    /// The gains version the servo's latest twist names (0: none yet).
    pub gains_version: u64,
    /// The servo's latest feature error (px; NaN before the first twist).
    pub feature_error_px: f64,
    /// The robot driver's tick rate.
    pub tick_rate: TickRate,
    /// The latest joint state the simulated plant this daemon started sent itself (by the sending process):
    /// what a restarted plant resumes from, never a state another process left in the stream.
    pub plant_state: Option<JointStateMsg>,
    /// The pid of the plant process this daemon started last (kept after its death, for what it sent before).
    plant_pid: Option<u32>,
    /// The writers of joint states of another schema already named in the log: (pid, schema).
    other_schemas_said: Vec<(Option<i32>, u32)>,
}

impl Default for LoopHeard {
    fn default() -> Self {
        Self {
            joint_state: None,
            joint_state_at: None,
            command: None,
            features: None,
            features_at: None,
            gains_version: 0,
            feature_error_px: f64::NAN,
            tick_rate: TickRate::default(),
            plant_state: None,
            plant_pid: None,
            other_schemas_said: Vec::new(),
        }
    }
}

impl LoopHeard {
    /// Takes what arrived; every joint state, twist and feature vector also goes to the fault monitor, each
    /// node's telemetry to its record.
    pub fn drain(&mut self, ports: &Ports, nodes: &mut [Supervised], monitor: &mut FaultMonitor) {
        let now = Instant::now();
        let started_plant =
            nodes.iter().find(|n| n.record.role == NodeRole::Plant).and_then(|n| n.record.pid);
        self.plant_pid = started_plant.or(self.plant_pid);
        // a message of another schema is refused by `TakeMessages`, the protocol's one place for it
        while let Some((taken, sender)) = ports.joint_state.next_sent() {
            let state = match taken {
                Ok(state) => state,
                Err(Refused::Schema { found }) => {
                    self.name_other_schema(sender, found);
                    continue;
                }
            };
            if sent_by(sender, self.plant_pid) {
                self.plant_state = Some(state);
            }
            monitor.on_joint_state(&state);
            self.joint_state = Some(state);
            self.joint_state_at = Some(now);
            self.tick_rate.on_state();
        }
        ports.command.each_message(|command| {
            monitor.on_joint_command(&command);
            self.command = Some(command);
        });
        // what does not carry the vision node's or the servo's seal is not theirs, and shows nothing
        let key = &ports.key;
        ports.features.each_message(|features| {
            if !key.verifies(&features) {
                return;
            }
            monitor.on_features(&features, monotonic_ns());
            self.features = Some(features);
            self.features_at = Some(now);
        });
        ports.twist.each_message(|twist| {
            if !key.verifies(&twist) {
                return;
            }
            monitor.on_twist(&twist);
            self.gains_version = twist.gains_version;
            self.feature_error_px = twist.feature_error_px;
        });
        ports.telemetry.each_message(|telemetry| {
            route_telemetry(nodes.iter_mut().map(|n| &mut n.record), telemetry, now);
        });
    }

    /// Says once per writer and schema that the robot driver speaks another schema: its joint states are refused
    /// (by `TakeMessages`), so the cell hears no robot, and the log says whose and which.
    fn name_other_schema(&mut self, sender: Option<i32>, found: u32) {
        if self.other_schemas_said.contains(&(sender, found)) || self.other_schemas_said.len() >= 16 {
            return;
        }
        self.other_schemas_said.push((sender, found));
        let pid = sender.map_or("unknown".to_string(), |pid| pid.to_string());
        tracing::error!(
            pid = sender.unwrap_or(0),
            driver_schema = found,
            schema = vservo_protocol::SCHEMA_VERSION,
            "the robot driver (pid {pid}) speaks schema {found}; this vservod speaks {}: its joint states are \
             refused; see docs/PROTOCOL.md's changelog (\"Changelog and migration\") for what changed since",
            vservo_protocol::SCHEMA_VERSION
        );
    }

    /// The tick rate to report, sampled at `now` (0 while the robot driver is stalled).
    pub fn tick_rate_hz(&mut self, now: Instant, robot: RobotState) -> f64 {
        self.tick_rate.sample(now, robot == RobotState::Stalled);
        self.tick_rate.hz()
    }
}

/// Whether the process that sent a message (`sender`, as its header tells) is `process`.
fn sent_by(sender: Option<i32>, process: Option<u32>) -> bool {
    matches!((sender, process), (Some(sender), Some(process)) if u32::try_from(sender) == Ok(process))
}

/// Hands a telemetry message to the record of the node it names (none: a role not supervised, or not one).
pub fn route_telemetry<'a>(
    nodes: impl IntoIterator<Item = &'a mut NodeRecord>,
    telemetry: TelemetryMsg,
    now: Instant,
) {
    let Some(role) = NodeRole::from_index(telemetry.node) else { return };
    if let Some(node) = nodes.into_iter().find(|n| n.role == role) {
        node.on_telemetry(telemetry, now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::node::tests_support::telemetry;
    use crate::supervisor::restart::RestartPolicy;
    use std::time::Duration;

    #[test]
    fn a_state_is_the_plants_only_when_its_process_sent_it() {
        assert!(sent_by(Some(41), Some(41)));
        assert!(!sent_by(Some(42), Some(41)), "another process");
        assert!(!sent_by(None, Some(41)), "a sender that cannot be told");
        assert!(!sent_by(Some(41), None), "no plant started");
        assert!(!sent_by(Some(-1), Some(u32::MAX)));
    }

    #[test]
    fn telemetry_reaches_the_node_it_names_and_no_other() {
        let t0 = Instant::now();
        let policy = RestartPolicy::new(Duration::from_millis(100), Duration::from_secs(1), t0);
        let mut nodes =
            [NodeRecord::started(NodeRole::Rmrc, 5, policy), NodeRecord::started(NodeRole::Servo, 6, policy)];
        let mut servo = telemetry(6, 3);
        servo.node = NodeRole::Servo as u32;
        route_telemetry(&mut nodes[..], servo, t0);
        assert_eq!(nodes[1].heard.telemetry, Some(servo));
        assert_eq!(nodes[0].heard.telemetry, None);
        let mut plant = telemetry(4, 3);
        plant.node = NodeRole::Plant as u32;
        route_telemetry(&mut nodes[..], plant, t0);
        let mut bogus = telemetry(4, 3);
        bogus.node = 99;
        route_telemetry(&mut nodes[..], bogus, t0);
        assert_eq!(nodes[0].heard.telemetry, None, "a plant not supervised, a role that is none");
    }
}
