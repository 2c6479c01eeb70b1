//! One writer per stream (docs/PROTOCOL.md, "One writer per stream"): the daemon creates every service of
//! its instance with exactly the writer slots its design has — one publisher on each data stream, one
//! notifier on each event, one server on `command`, one telemetry publisher per node — checks that a service
//! that already existed has vservo's sizes, and keeps a [`WatchedStream`] for each so that it can list who
//! holds the writer slots (by process id) and name a process that is not the stream's designed writer.
//!
//! What iceoryx2 0.10 enforces is the number of ports: a second publisher on a one-publisher service is
//! refused at creation (`ExceedsMaxSupportedPublishers`, [`ProtocolError::SlotTaken`] here). What it does not
//! do is say *who* may create a port: any process that can open the service's files (the daemon's user, and
//! its group where the files allow) may take a free slot, for example while a node restarts; and such a
//! process can also map the shared memory and write into it without any port at all. The slot count keeps a
//! well-behaved second writer out and makes a taken slot visible; the seals (docs/PROTOCOL.md) keep forged
//! contents out of the streams that carry them; the boundary against a hostile process is the user.

use iceoryx2::identifiers::UniqueNodeId;
use iceoryx2::prelude::*;

use crate::{
    COMMAND_SERVERS, CameraTwistMsg, CellModeMsg, DaemonStatusMsg, EVENT_NOTIFIERS, FeaturesMsg, GainsMsg,
    JointCommandMsg, JointStateMsg, ObjectMsg, Opening, ProtocolError, SimWorldMsg, TelemetryMsg, Topic,
};

/// Who writes a stream by design.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Writer {
    /// The daemon itself.
    Daemon,
    /// A node the daemon starts (by its role's name).
    Node(crate::NodeRole),
    /// Any node the daemon starts (telemetry).
    AnyNode,
    /// The robot driver: the simulated plant, or the user's process.
    RobotDriver,
    /// The camera: the vision node's simulated camera, or the user's process.
    Camera,
}

/// Lists the process ids holding a service's writer slots into the vector it is given.
type ListWriters = Box<dyn Fn(&mut Vec<i32>)>;

/// A service the daemon created, with the way to list the processes holding its writer slots.
pub struct WatchedStream {
    /// The service's name (`vservo/<instance>/<name>`), with `(event)` for an event service.
    pub name: String,
    /// Its designed writer.
    pub writer: Writer,
    list: ListWriters,
}

impl std::fmt::Debug for WatchedStream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WatchedStream").field("name", &self.name).field("writer", &self.writer).finish()
    }
}

impl WatchedStream {
    /// The process ids holding the stream's writer slots now (a dead process's slot counts until it is
    /// cleaned up); `pids` is cleared first.
    pub fn writer_pids(&self, pids: &mut Vec<i32>) {
        pids.clear();
        (self.list)(pids);
    }
}

fn pid_of(node_id: &UniqueNodeId) -> Option<i32> {
    node_id.pid::<ipc::Service>().ok().map(|pid| pid.value())
}

fn check(service: &str, what: &'static str, found: usize, expected: usize) -> Result<(), ProtocolError> {
    if found == expected {
        Ok(())
    } else {
        Err(ProtocolError::Sized { service: service.to_string(), what, found, expected })
    }
}

fn topic_stream<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
    writer: Writer,
) -> Result<WatchedStream, ProtocolError> {
    let factory = crate::open_topic::<T>(node, instance, topic)?;
    let name = topic.service_name(instance);
    let settings = topic.settings();
    let config = factory.static_config();
    check(&name, "max publishers", config.max_publishers(), settings.max_publishers)?;
    check(&name, "max subscribers", config.max_subscribers(), settings.max_subscribers)?;
    check(&name, "history", config.history_size(), settings.history_size)?;
    let list = move |pids: &mut Vec<i32>| {
        factory.dynamic_config().list_publishers(|details| {
            pids.extend(pid_of(&details.node_id));
            CallbackProgression::Continue
        })
    };
    Ok(WatchedStream { name, writer, list: Box::new(list) })
}

fn event_stream(
    node: &Node<ipc::Service>,
    service_name: &str,
    writer: Writer,
) -> Result<WatchedStream, ProtocolError> {
    let (name, factory) = crate::open_event_named(node, service_name)?;
    check(&name, "max notifiers", factory.static_config().max_notifiers(), EVENT_NOTIFIERS)?;
    let list = move |pids: &mut Vec<i32>| {
        factory.dynamic_config().list_notifiers(|details| {
            pids.extend(pid_of(&details.node_id));
            CallbackProgression::Continue
        })
    };
    Ok(WatchedStream { name: format!("{name} (event)"), writer, list: Box::new(list) })
}

fn camera_image_stream(node: &Node<ipc::Service>, instance: &str) -> Result<WatchedStream, ProtocolError> {
    let factory = crate::open_camera_image_service(node, instance, Opening::OpenOrCreate)?;
    let name = format!("vservo/{instance}/{}", crate::CAMERA_IMAGE_SERVICE);
    check(&name, "max publishers", factory.static_config().max_publishers(), 1)?;
    let list = move |pids: &mut Vec<i32>| {
        factory.dynamic_config().list_publishers(|details| {
            pids.extend(pid_of(&details.node_id));
            CallbackProgression::Continue
        })
    };
    Ok(WatchedStream { name, writer: Writer::Camera, list: Box::new(list) })
}

fn command_stream(node: &Node<ipc::Service>, instance: &str) -> Result<WatchedStream, ProtocolError> {
    let factory = crate::open_command_service(node, instance, Opening::OpenOrCreate)?;
    let name = format!("vservo/{instance}/{}", crate::COMMAND_SERVICE);
    check(&name, "max servers", factory.static_config().max_servers(), COMMAND_SERVERS)?;
    check(&name, "max clients", factory.static_config().max_clients(), crate::COMMAND_SLOTS)?;
    let list = move |pids: &mut Vec<i32>| {
        factory.dynamic_config().list_servers(|details| {
            pids.extend(pid_of(&details.node_id));
            CallbackProgression::Continue
        })
    };
    Ok(WatchedStream { name, writer: Writer::Daemon, list: Box::new(list) })
}

/// Creates (or opens, checking vservo's sizes) every service of `instance`, one [`WatchedStream`] each.
/// A service that exists with other sizes is refused ([`ProtocolError::Sized`]): another process made it.
pub fn create_all(node: &Node<ipc::Service>, instance: &str) -> Result<Vec<WatchedStream>, ProtocolError> {
    use crate::NodeRole::{Rmrc, Servo, Vision};
    let event = |topic: Topic, writer| event_stream(node, &topic.service_name(instance), writer);
    Ok(vec![
        topic_stream::<JointStateMsg>(node, instance, Topic::JointState, Writer::RobotDriver)?,
        event(Topic::JointState, Writer::RobotDriver)?,
        topic_stream::<JointCommandMsg>(node, instance, Topic::JointCommand, Writer::Node(Rmrc))?,
        topic_stream::<SimWorldMsg>(node, instance, Topic::SimWorld, Writer::RobotDriver)?,
        topic_stream::<FeaturesMsg>(node, instance, Topic::Features, Writer::Node(Vision))?,
        event(Topic::Features, Writer::Node(Vision))?,
        topic_stream::<CameraTwistMsg>(node, instance, Topic::CameraTwist, Writer::Node(Servo))?,
        topic_stream::<TelemetryMsg>(node, instance, Topic::Telemetry, Writer::AnyNode)?,
        topic_stream::<DaemonStatusMsg>(node, instance, Topic::Status, Writer::Daemon)?,
        topic_stream::<GainsMsg>(node, instance, Topic::Gains, Writer::Daemon)?,
        topic_stream::<ObjectMsg>(node, instance, Topic::Object, Writer::Daemon)?,
        topic_stream::<CellModeMsg>(node, instance, Topic::CellMode, Writer::Daemon)?,
        camera_image_stream(node, instance)?,
        event_stream(node, &format!("vservo/{instance}/{}", crate::CAMERA_IMAGE_SERVICE), Writer::Camera)?,
        command_stream(node, instance)?,
    ])
}
