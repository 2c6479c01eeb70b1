//! The four node loops.

pub mod plant;
pub mod rmrc;
pub mod servo;
pub mod vision;

use std::time::Duration;

use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{Node, ipc};
use vservo_protocol::freshness::{self, Issue, Standing};
use vservo_protocol::{CellMode, NodeRole, Payload, TakeMessages};

use crate::telemetry::{Counters, LoopMonitor, TelemetryThread};
use crate::{NodeContext, RuntimeError, realtime};

/// How long an event-driven node waits before it looks at its stop flag again.
const IDLE_WAIT: Duration = Duration::from_millis(100);

/// What every node process has: its telemetry thread (started first, at normal priority, since threads
/// inherit their creator's) and its iceoryx2 node.
struct NodeBase {
    _telemetry: TelemetryThread,
    monitor: LoopMonitor,
    node: Node<ipc::Service>,
}

fn start(context: &NodeContext, role: NodeRole) -> Result<NodeBase, RuntimeError> {
    let period_s = context.runtime.telemetry_period.as_secs_f64();
    let (telemetry, monitor) = TelemetryThread::spawn(&context.instance, role, period_s)?;
    let node = vservo_protocol::create_node(&context.instance, role.name())?;
    Ok(NodeBase { _telemetry: telemetry, monitor, node })
}

/// Applies the role's `[runtime]` settings to the calling thread, once its ports exist; what the system
/// refuses is a warning.
fn go_realtime(context: &NodeContext, role: NodeRole) {
    let runtime = &context.runtime;
    let settings = match role {
        NodeRole::Plant => &runtime.plant,
        NodeRole::Rmrc => &runtime.rmrc,
        NodeRole::Servo => &runtime.servo,
        NodeRole::Vision => &runtime.vision,
    };
    for warning in realtime::apply(settings, runtime) {
        tracing::warn!(node = role.name(), "{warning}");
    }
    tracing::info!(node = role.name(), "running");
}

/// Drains a subscriber and returns its newest message of this build's schema (the protocol's
/// [`TakeMessages`] refuses the others); the refused are counted.
fn latest<T: Payload>(subscriber: &Subscriber<ipc::Service, T, ()>, counters: &Counters) -> Option<T> {
    let mut refused = 0;
    let newest = subscriber.newest_message(&mut refused);
    for _ in 0..refused {
        counters.rejected();
    }
    newest
}

/// The cell mode in force, as a node acts on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ModeInForce {
    /// The servo's twists move the arm.
    Servoing,
    /// Held in a safe stop.
    SafeStop,
    /// A joint move to `goal` at `speed_fraction` of the speed limits (the joints past the arm's zero).
    Moving { goal: vservo_arm::JointVector, speed_fraction: f64 },
}

impl ModeInForce {
    /// The mode a sealed message says; none for a mode this build does not know or a move that is not finite.
    fn of(message: &vservo_protocol::CellModeMsg) -> Option<Self> {
        match CellMode::try_from(message.mode).ok()? {
            CellMode::Servoing => Some(Self::Servoing),
            CellMode::SafeStop => Some(Self::SafeStop),
            CellMode::Moving => {
                let goal = vservo_arm::JointVector::from(message.goal_rad);
                let speed_fraction = message.speed_fraction;
                (goal.iter().all(|v| v.is_finite())
                    && vservo_sim::joint_move::speed_fraction_ok(speed_fraction))
                .then_some(Self::Moving { goal, speed_fraction })
            }
        }
    }
}

/// The cell mode the daemon set: the newest sealed [`CellModeMsg`] heard so far (newest by the daemon's stamp,
/// `vservo_protocol::freshness`). A message without the run's seal, of a mode this build does not know (or a
/// move that is not finite or not at a share of the speed limits a move may use), older than the one in force
/// or stamped in the future, is refused and counted.
///
/// [`CellModeMsg`]: vservo_protocol::CellModeMsg
pub(crate) struct CellModeFollower {
    subscriber: Subscriber<ipc::Service, vservo_protocol::CellModeMsg, ()>,
    /// The mode in force; until the daemon's first word: servoing (the daemon publishes its mode before it
    /// starts a node).
    mode: ModeInForce,
    /// What the mode in force came with; none before the daemon's first word.
    issue: Option<Issue>,
    /// The process of each node the daemon started, by role, as its newest mode announces (none yet: zeros).
    writers: [u32; 4],
    /// The dynamics override the newest mode carries (1 until the daemon's first word).
    speed_scale: f64,
    /// When a sealed mode was last taken (or the follower opened): the daemon's word, a heartbeat at least
    /// every `CELL_MODE_EVERY`.
    heard_at_ns: u64,
    /// The daemon silent for `DAEMON_SILENT_AFTER`: held as in a safe stop (said once per silence).
    daemon_silent: bool,
    /// The node, for its log.
    role: NodeRole,
}

impl CellModeFollower {
    pub(crate) fn open(
        node: &Node<ipc::Service>,
        instance: &str,
        role: NodeRole,
    ) -> Result<Self, RuntimeError> {
        Ok(Self {
            subscriber: vservo_protocol::subscriber(node, instance, vservo_protocol::Topic::CellMode)?,
            mode: ModeInForce::Servoing,
            issue: None,
            writers: [0; 4],
            speed_scale: 1.0,
            heard_at_ns: vservo_time::monotonic_ns(),
            daemon_silent: false,
            role,
        })
    }

    /// Takes what arrived; the mode in force.
    pub(crate) fn mode(
        &mut self,
        key: Option<&vservo_protocol::seal::SealKey>,
        counters: &Counters,
    ) -> ModeInForce {
        while let Ok(Some(sample)) = self.subscriber.receive() {
            let message = *sample;
            let sealed = vservo_protocol::seal::sealed_by(key, &message);
            let issue = Issue { stamp_ns: message.stamp_ns, counter: message.sequence };
            let standing = freshness::standing(self.issue, issue, vservo_time::monotonic_ns());
            let scale_ok = message.speed_scale > 0.0 && message.speed_scale <= 1.0;
            match ModeInForce::of(&message) {
                Some(mode)
                    if vservo_protocol::inbox::accept(message).is_ok()
                        && sealed
                        && scale_ok
                        && standing.is_newer() =>
                {
                    self.mode = mode;
                    self.issue = Some(issue);
                    self.writers = message.writers;
                    self.speed_scale = message.speed_scale;
                    self.heard_at_ns = vservo_time::monotonic_ns();
                }
                _ if standing != Standing::Same || !sealed => counters.rejected(),
                _ => {}
            }
        }
        let silent = daemon_silent(self.heard_at_ns, vservo_time::monotonic_ns());
        if silent != self.daemon_silent {
            self.daemon_silent = silent;
            self.say_silence();
        }
        if silent { ModeInForce::SafeStop } else { self.mode }
    }

    /// The dynamics override the daemon's newest mode carries (0–1]: the share of the limits the reference keeps.
    pub(crate) fn speed_scale(&self) -> f64 {
        self.speed_scale
    }

    /// The process the daemon announces as `role`'s (0: none runs, or none announced yet): the only writer
    /// whose sealed stream a consumer takes (`vservo_protocol::freshness::Origin`).
    pub(crate) fn writer(&self, role: NodeRole) -> u32 {
        self.writers[role as usize]
    }

    /// Says when the daemon fell silent and when its word came back (rare: once each per silence).
    fn say_silence(&self) {
        let node = self.role.name();
        if self.daemon_silent {
            tracing::error!(
                node,
                "no word from vservod for {:?} (stopped? a debugger?): holding the arm as in a safe stop",
                vservo_protocol::supervision::DAEMON_SILENT_AFTER
            );
        } else {
            tracing::warn!(node, "vservod's word is back: following the mode it says");
        }
    }
}

/// Whether the daemon is silent: no sealed mode since `heard_at_ns` for `DAEMON_SILENT_AFTER`.
fn daemon_silent(heard_at_ns: u64, now_ns: u64) -> bool {
    now_ns.saturating_sub(heard_at_ns) > vservo_protocol::supervision::DAEMON_SILENT_AFTER.as_nanos() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_daemon_is_silent_only_after_a_second_without_its_word() {
        let second = vservo_protocol::supervision::DAEMON_SILENT_AFTER.as_nanos() as u64;
        assert!(!daemon_silent(1_000, 1_000 + second), "at the bound, not beyond it");
        assert!(daemon_silent(1_000, 1_001 + second));
        assert!(!daemon_silent(5_000, 1_000), "a clock read before the word: not silent");
    }
}
