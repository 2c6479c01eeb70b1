//! The instance's side: the robot driver's streams (`joint_state` and its event out, `joint_command` in) and
//! the cell's mode (to know when a resume asks for the robot's recovery).

use anyhow::Context as _;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::ipc;
use vservo_protocol::inbox::TakeMessages;
use vservo_protocol::{CellModeMsg, JointCommandMsg, JointStateMsg, Topic};

/// The driver's ports on the instance.
pub struct CellPorts {
    states: Publisher<ipc::Service, JointStateMsg, ()>,
    wake: Notifier<ipc::Service>,
    commands: Subscriber<ipc::Service, JointCommandMsg, ()>,
    modes: Subscriber<ipc::Service, CellModeMsg, ()>,
    _node: iceoryx2::node::Node<ipc::Service>,
}

impl CellPorts {
    /// Opens the robot driver's streams of `instance` in `dir` (its one writer slot: another robot driver
    /// running is an error).
    pub fn connect(instance: &str, dir: &vservo_protocol::InstanceDir) -> anyhow::Result<Self> {
        let node = vservo_protocol::create_node_in(dir, "franka-driver")?;
        Ok(Self {
            states: vservo_protocol::publisher(&node, instance, Topic::JointState)
                .context("the joint_state stream (is another robot driver running?)")?,
            wake: vservo_protocol::notifier(&node, instance, Topic::JointState)?,
            commands: vservo_protocol::subscriber(&node, instance, Topic::JointCommand)?,
            modes: vservo_protocol::subscriber(&node, instance, Topic::CellMode)?,
            _node: node,
        })
    }

    /// Publishes a joint state and wakes its readers (the rmrc); `false` if it could not be sent.
    pub fn publish(&self, state: JointStateMsg) -> bool {
        let sent = self.states.loan_uninit().is_ok_and(|sample| sample.write_payload(state).send().is_ok());
        let _ = self.wake.notify();
        sent
    }

    /// Every command waiting, in order (another schema's counted in `refused`).
    pub fn each_command(&self, refused: &mut u64, taken: impl FnMut(JointCommandMsg)) {
        *refused += self.commands.each_message(taken);
    }

    /// The newest cell mode published since the last look, if any (its seal is the driver side's to check).
    pub fn newest_mode(&mut self) -> Option<CellModeMsg> {
        let mut other_schema = 0;
        self.modes.newest_message(&mut other_schema)
    }
}
