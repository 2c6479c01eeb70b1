//! # vservo-protocol — the instance and its services
//!
//! This crate owns how vservo's processes reach each other: the iceoryx2 services of one vservo instance
//! (`vservo/<instance>/<service>`, docs/PROTOCOL.md), their fixed-size `#[repr(C)]` payloads with a schema
//! version, and the one function every participant uses to open each service with the same settings. A client
//! in another language follows docs/PROTOCOL.md, which documents the same names, type names and offsets.
//!
//! The services ([`Topic`]): `joint_state` (the robot only: driver epoch, period, command interface, status,
//! q, q̇, τ), `joint_command` (in the driver's interface: torque, velocity or position), `camera_image` (a `u8`
//! slice with a [`CameraImageHeader`], 8-bit gray up to 1280 × 1024), `sim_world` (the simulated board's
//! pose), `features`, `camera_twist`, `telemetry`, `status`, `gains`, `object`, `cell_mode` (servoing, a safe
//! stop with its fault, or a joint move with its goal and share of the speed limits), and the `command`
//! request-response service ([`COMMAND_SLOTS`] client slots, each held only while a request waits: targets,
//! object commands, reload, safe stop, resume, `move_joints` and `servo`). Each port kind has one function
//! that opens a service with its sizes ([`Opening`]: the daemon's processes open or create, clients only
//! open), and [`cleanup_dead_nodes`] frees what dead processes left.
//!
//! Modules (the messages themselves, their codes, tables, seals and freshness rules are `vservo-wire`'s, the
//! schema, re-exported here at the same paths: [`messages`], [`codes`], [`declare`], [`inbox`], [`layout`],
//! [`seal`], [`freshness`], [`supervision`], [`clock`]):
//! - [`camera_image`]: the camera image stream (pixels under a header, one publisher) and its wake-up event.
//! - [`instance_dir`]: where an instance lives out of other users' reach: the runtime directory
//!   `<base>/<instance>` with its lock, its random shared-memory prefix and the `schema` file the daemon
//!   writes ([`instance_dir::SCHEMA_FILE`]: the schema it speaks, which every client and driver checks before it
//!   opens anything, naming both schemas when they differ), iceoryx2's root path `<base>/iceoryx2`, the node
//!   counter made owner-only, a prefix under which another user's file turned up replaced. [`InstanceClaim`]
//!   is the daemon's, [`InstanceDir::locate`] the nodes' and clients': the user's own instance wherever it is,
//!   another user's named only when none is ours; [`InstanceDir::configuration`] is where the daemon writes
//!   the configuration it runs.
//! - [`writers`]: one writer per stream. The daemon creates every service with one writer slot (one
//!   publisher, one notifier, one server; telemetry one per node), checks that a service that existed has
//!   vservo's sizes, and lists who holds each writer slot by process id ([`writers::WatchedStream`]); a port
//!   refused because its slots are held is [`ProtocolError::SlotTaken`] (a writer first cleans up dead
//!   processes' leftovers and tries once more).
//! - [`stop_path`]: the safe-stop FIFO in the instance's directory, which no client can exhaust (the daemon
//!   reads it without blocking; `vservoctl safe-stop` and the Python client write it).
//! - [`signals`]: SIGINT and SIGTERM as a flag, for the processes that run until stopped, and the end of a
//!   helper with the daemon that started it.

pub mod camera_image;
pub mod instance_dir;
pub mod signals;
pub mod stop_path;
pub mod writers;

pub use vservo_wire::{clock, codes, declare, freshness, inbox, layout, messages, seal, stream, supervision};

pub use camera_image::{
    CAMERA_IMAGE_SERVICE, Exposure, camera_image_listener, camera_image_notifier, camera_image_publisher,
    camera_image_subscriber, open_camera_image_service, publish_mono8,
};
pub use codes::{
    CellMode, CommandKind, CommandMode, DaemonState, DriverError, DriverStatus, Fault, Interaction,
    MarkStatus, NodeState, PixelFormat, RobotState, ServoFeatures, UnknownCode, Verdict,
};
pub use declare::{FieldInfo, WireField, WireMessage};
pub use inbox::{Payload, Refused, TakeMessages};
pub use instance_dir::{InstanceClaim, InstanceDir, InstanceDirError};
pub use messages::*;

use iceoryx2::port::listener::{Listener, ListenerCreateError};
use iceoryx2::port::notifier::{Notifier, NotifierCreateError};
use iceoryx2::port::publisher::{Publisher, PublisherCreateError};
use iceoryx2::port::subscriber::{Subscriber, SubscriberCreateError};
use iceoryx2::prelude::*;

/// The services of one instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Topic {
    /// robot driver → rmrc, vision, vservod: [`JointStateMsg`], every driver period; with an event of the
    /// same name.
    JointState,
    /// rmrc → robot driver: [`JointCommandMsg`], in answer to each joint state; the driver reads it at its
    /// next deadline (no event).
    JointCommand,
    /// simulated plant → simulated camera: [`SimWorldMsg`], every tick; simulation only.
    SimWorld,
    /// vision → servo: [`FeaturesMsg`], per frame; with an event of the same name.
    Features,
    /// servo → rmrc: [`CameraTwistMsg`], per frame.
    CameraTwist,
    /// every node → anyone: [`TelemetryMsg`], 10 Hz.
    Telemetry,
    /// vservod → anyone: [`DaemonStatusMsg`], 10 Hz.
    Status,
    /// vservod → servo: [`GainsMsg`], on each accepted reload or target.
    Gains,
    /// vservod → plant: [`ObjectMsg`], on each accepted object command.
    Object,
    /// vservod → rmrc, servo: [`CellModeMsg`], on each change (servoing, safe stop).
    CellMode,
}

/// Telemetry publishers at once: one per node.
pub const TELEMETRY_WRITERS: usize = 4;

/// Below this joint speed (rad/s) the arm is at rest (the joint servo's last friction corrections stay below
/// it): where the nodes stop when the daemon is gone, the daemon's shutdown waits, and `vservoctl calibrate`
/// takes a view.
pub const AT_REST_RAD_S: f64 = 0.01;

/// Notifiers of an event service at once: the one writer of the data service it wakes for.
pub const EVENT_NOTIFIERS: usize = 1;

/// Listeners of an event service at once.
pub const EVENT_LISTENERS: usize = 4;

/// Servers of the `command` service: the daemon.
pub const COMMAND_SERVERS: usize = 1;

/// How a service is sized. Openers that ask for no more than these open it whoever created it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopicSettings {
    /// Publishers at once (a restarted node's dead predecessor counts until it is cleaned up).
    pub max_publishers: usize,
    /// Subscribers at once.
    pub max_subscribers: usize,
    /// Samples a late subscriber receives at once.
    pub history_size: usize,
    /// The most samples a subscriber may buffer (older ones are dropped: safe overflow).
    pub subscriber_max_buffer_size: usize,
}

impl Topic {
    /// Every topic.
    pub const ALL: [Topic; 10] = [
        Topic::JointState,
        Topic::JointCommand,
        Topic::SimWorld,
        Topic::Features,
        Topic::CameraTwist,
        Topic::Telemetry,
        Topic::Status,
        Topic::Gains,
        Topic::Object,
        Topic::CellMode,
    ];

    /// The last part of the service name.
    pub fn name(self) -> &'static str {
        match self {
            Topic::JointState => "joint_state",
            Topic::JointCommand => "joint_command",
            Topic::SimWorld => "sim_world",
            Topic::Features => "features",
            Topic::CameraTwist => "camera_twist",
            Topic::Telemetry => "telemetry",
            Topic::Status => "status",
            Topic::Gains => "gains",
            Topic::Object => "object",
            Topic::CellMode => "cell_mode",
        }
    }

    /// The payload's type name as iceoryx2 checks it.
    pub fn type_name(self) -> &'static str {
        match self {
            Topic::JointState => "vservo::JointState",
            Topic::JointCommand => "vservo::JointCommand",
            Topic::SimWorld => "vservo::SimWorld",
            Topic::Features => "vservo::Features",
            Topic::CameraTwist => "vservo::CameraTwist",
            Topic::Telemetry => "vservo::Telemetry",
            Topic::Status => "vservo::DaemonStatus",
            Topic::Gains => "vservo::Gains",
            Topic::Object => "vservo::Object",
            Topic::CellMode => "vservo::CellMode",
        }
    }

    /// The service's sizing.
    pub fn settings(self) -> TopicSettings {
        let (max_publishers, max_subscribers, history_size, subscriber_max_buffer_size) = match self {
            // one writer per stream (docs/PROTOCOL.md, "One writer per stream"); telemetry: one per node
            Topic::JointState => (1, 8, 1, 64),
            Topic::JointCommand => (1, 8, 0, 64),
            Topic::SimWorld => (1, 8, 1, 64),
            Topic::Features => (1, 8, 1, 32),
            Topic::CameraTwist => (1, 8, 1, 32),
            Topic::Telemetry => (TELEMETRY_WRITERS, 8, 1, 64),
            Topic::Status => (1, 8, 1, 8),
            Topic::Gains => (1, 8, 1, 8),
            Topic::Object => (1, 8, 1, 8),
            Topic::CellMode => (1, 8, 1, 8),
        };
        TopicSettings { max_publishers, max_subscribers, history_size, subscriber_max_buffer_size }
    }

    /// The full service name for an instance: `vservo/<instance>/<name>`.
    pub fn service_name(self, instance: &str) -> String {
        format!("vservo/{instance}/{}", self.name())
    }
}

/// What went wrong talking to iceoryx2, with the service it concerned.
#[derive(Debug, thiserror::Error)]
pub enum ProtocolError {
    /// The service name is not valid (the instance name has characters iceoryx2 refuses).
    #[error("service name {name:?}: {reason}")]
    Name {
        /// The name.
        name: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// Opening or creating the service, or a port on it, failed.
    #[error("{what} on {service:?}: {reason}")]
    Port {
        /// Which operation.
        what: &'static str,
        /// The service.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The instance's runtime directory could not be found or trusted.
    #[error(transparent)]
    Instance(#[from] InstanceDirError),
    /// Every slot of this kind of port on the service is held: for a stream's one writer, another process
    /// holds it (docs/PROTOCOL.md, "One writer per stream").
    #[error("every {port} slot of {service:?} is held (by another process, if this is its one writer)")]
    SlotTaken {
        /// The kind of port: publisher, subscriber, notifier, listener, server.
        port: &'static str,
        /// The service.
        service: String,
    },
    /// A service exists with other sizes than vservo's: another process created it.
    #[error("{service:?} exists with {what} {found}, not vservo's {expected}: another process created it")]
    Sized {
        /// The service.
        service: String,
        /// Which size.
        what: &'static str,
        /// The size it has.
        found: usize,
        /// vservo's.
        expected: usize,
    },
}

impl ProtocolError {
    /// Whether this is a port refused because its slots are held ([`ProtocolError::SlotTaken`]).
    pub fn is_slot_taken(&self) -> bool {
        matches!(self, ProtocolError::SlotTaken { .. })
    }
}

fn service_name(topic: Topic, instance: &str) -> Result<(String, ServiceName), ProtocolError> {
    named(&topic.service_name(instance))
}

/// A service name as iceoryx2 takes it, with the text for messages.
pub(crate) fn named(name: &str) -> Result<(String, ServiceName), ProtocolError> {
    let service = ServiceName::new(name)
        .map_err(|e| ProtocolError::Name { name: name.to_string(), reason: format!("{e:?}") })?;
    Ok((name.to_string(), service))
}

/// An iceoryx2 refusal on `service`, saying what was being done.
pub(crate) fn port_error(what: &'static str, service: &str) -> impl FnOnce(String) -> ProtocolError {
    let service = service.to_string();
    move |reason| ProtocolError::Port { what, service, reason }
}

/// Whether opening a service may create it. The daemon's processes create; clients only open, so that no
/// client can create an instance's service with settings of its own (and stop the daemon from starting).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Opening {
    /// Open the service, or create it with vservo's settings (the daemon and its nodes).
    OpenOrCreate,
    /// Open the service only: it fails when no daemon runs the instance (clients).
    OpenOnly,
}

/// The publish-subscribe service of `topic` for payload `T`, opened or created with the topic's settings.
pub fn open_topic<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, ()>, ProtocolError>
{
    open_topic_as::<T>(node, instance, topic, Opening::OpenOrCreate)
}

/// The publish-subscribe service of `topic`, opened (or, with [`Opening::OpenOrCreate`], created).
pub fn open_topic_as<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
    opening: Opening,
) -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, ()>, ProtocolError>
{
    let (name, service) = service_name(topic, instance)?;
    let s = topic.settings();
    let builder = node
        .service_builder(&service)
        .publish_subscribe::<T>()
        .max_publishers(s.max_publishers)
        .max_subscribers(s.max_subscribers)
        .history_size(s.history_size)
        .subscriber_max_buffer_size(s.subscriber_max_buffer_size)
        .enable_safe_overflow(true);
    match opening {
        Opening::OpenOrCreate => {
            builder.open_or_create().map_err(|e| port_error("opening the service", &name)(e.to_string()))
        }
        Opening::OpenOnly => builder.open().map_err(|e| {
            port_error("opening the service (is a vservod of this instance running?)", &name)(e.to_string())
        }),
    }
}

/// A client's subscriber on `topic`: the service must exist (a daemon runs the instance).
pub fn client_subscriber<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> Result<Subscriber<ipc::Service, T, ()>, ProtocolError> {
    let service = open_topic_as::<T>(node, instance, topic, Opening::OpenOnly)?;
    service
        .subscriber_builder()
        .buffer_size(topic.settings().subscriber_max_buffer_size)
        .create()
        .map_err(|e| subscriber_error(e, &topic.service_name(instance)))
}

/// A publisher on `topic`.
pub fn publisher<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> Result<Publisher<ipc::Service, T, ()>, ProtocolError> {
    let service = open_topic::<T>(node, instance, topic)?;
    writer_slot(node, || service.publisher_builder().create()).map_err(|e| match e {
        PublisherCreateError::ExceedsMaxSupportedPublishers => {
            ProtocolError::SlotTaken { port: "publisher", service: topic.service_name(instance) }
        }
        e => port_error("creating a publisher", &topic.service_name(instance))(e.to_string()),
    })
}

/// A stream's writer port: `create` it, and when its one slot is held, clean up dead processes' leftovers
/// (a writer that died — a crashed node, a killed driver — holds its slot until then) and try once more.
pub(crate) fn writer_slot<P, E: SlotsHeld>(
    node: &Node<ipc::Service>,
    create: impl Fn() -> Result<P, E>,
) -> Result<P, E> {
    match create() {
        Err(e) if e.slots_held() => {
            cleanup_dead_nodes(node);
            create()
        }
        created => created,
    }
}

/// A port refusal that says every slot is held.
trait SlotsHeld {
    fn slots_held(&self) -> bool;
}

impl SlotsHeld for PublisherCreateError {
    fn slots_held(&self) -> bool {
        *self == PublisherCreateError::ExceedsMaxSupportedPublishers
    }
}

impl SlotsHeld for NotifierCreateError {
    fn slots_held(&self) -> bool {
        *self == NotifierCreateError::ExceedsMaxSupportedNotifiers
    }
}

/// A subscriber on `topic` with the largest buffer the topic allows.
pub fn subscriber<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> Result<Subscriber<ipc::Service, T, ()>, ProtocolError> {
    let service = open_topic::<T>(node, instance, topic)?;
    service
        .subscriber_builder()
        .buffer_size(topic.settings().subscriber_max_buffer_size)
        .create()
        .map_err(|e| subscriber_error(e, &topic.service_name(instance)))
}

pub(crate) fn subscriber_error(error: SubscriberCreateError, service: &str) -> ProtocolError {
    match error {
        SubscriberCreateError::ExceedsMaxSupportedSubscribers => {
            ProtocolError::SlotTaken { port: "subscriber", service: service.to_string() }
        }
        e => port_error("creating a subscriber", service)(e.to_string()),
    }
}

pub(crate) fn notifier_error(error: NotifierCreateError, service: &str) -> ProtocolError {
    match error {
        NotifierCreateError::ExceedsMaxSupportedNotifiers => {
            ProtocolError::SlotTaken { port: "notifier", service: service.to_string() }
        }
        e => port_error("creating a notifier", service)(e.to_string()),
    }
}

pub(crate) fn listener_error(error: ListenerCreateError, service: &str) -> ProtocolError {
    match error {
        ListenerCreateError::ExceedsMaxSupportedListeners => {
            ProtocolError::SlotTaken { port: "listener", service: service.to_string() }
        }
        e => port_error("creating a listener", service)(e.to_string()),
    }
}

fn open_event(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> Result<(String, iceoryx2::service::port_factory::event::PortFactory<ipc::Service>), ProtocolError> {
    open_event_named(node, &topic.service_name(instance))
}

pub(crate) fn open_event_named(
    node: &Node<ipc::Service>,
    name: &str,
) -> Result<(String, iceoryx2::service::port_factory::event::PortFactory<ipc::Service>), ProtocolError> {
    let (name, service) = named(name)?;
    let factory = node
        .service_builder(&service)
        .event()
        .max_notifiers(EVENT_NOTIFIERS)
        .max_listeners(EVENT_LISTENERS)
        .open_or_create()
        .map_err(|e| port_error("opening the event service", &name)(e.to_string()))?;
    Ok((name, factory))
}

/// The notifier that wakes `topic`'s consumer (same name as the data service).
pub fn notifier(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> Result<Notifier<ipc::Service>, ProtocolError> {
    let (name, factory) = open_event(node, instance, topic)?;
    writer_slot(node, || factory.notifier_builder().create()).map_err(|e| notifier_error(e, &name))
}

/// The listener `topic`'s consumer waits on.
pub fn listener(
    node: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> Result<Listener<ipc::Service>, ProtocolError> {
    let (name, factory) = open_event(node, instance, topic)?;
    factory.listener_builder().create().map_err(|e| listener_error(e, &name))
}

/// Removes what dead nodes of the instance left behind (shared memory, sockets, registrations).
/// Returns how many dead nodes were cleaned up.
pub fn cleanup_dead_nodes(node: &Node<ipc::Service>) -> u64 {
    node.try_cleanup_dead_nodes().cleanups
}

/// The request-response service `vservo/<instance>/command` ([`CommandMsg`] → [`CommandReplyMsg`]).
pub const COMMAND_SERVICE: &str = "command";

/// The command service, opened or created with vservo's sizes (the daemon); clients pass
/// [`Opening::OpenOnly`].
pub fn open_command_service(
    node: &Node<ipc::Service>,
    instance: &str,
    opening: Opening,
) -> Result<
    iceoryx2::service::port_factory::request_response::PortFactory<
        ipc::Service,
        CommandMsg,
        (),
        CommandReplyMsg,
        (),
    >,
    ProtocolError,
> {
    let (name, service) = named(&format!("vservo/{instance}/{COMMAND_SERVICE}"))?;
    let builder = node
        .service_builder(&service)
        .request_response::<CommandMsg, CommandReplyMsg>()
        .max_servers(COMMAND_SERVERS)
        .max_clients(COMMAND_SLOTS)
        .max_nodes(64)
        .max_active_requests_per_client(4)
        .max_response_buffer_size(4);
    match opening {
        Opening::OpenOrCreate => builder
            .open_or_create()
            .map_err(|e| port_error("opening the command service", &name)(e.to_string())),
        Opening::OpenOnly => builder.open().map_err(|e| {
            port_error("opening the command service (is a vservod of this instance running?)", &name)(
                e.to_string(),
            )
        }),
    }
}

/// Clients that may have a command in flight at once (a client holds a slot only while it waits for its
/// answer).
pub const COMMAND_SLOTS: usize = 16;

/// The node name of a vservo process: `vservo/<instance>/<role>`.
pub fn node_name(instance: &str, role: &str) -> String {
    format!("vservo/{instance}/{role}")
}

/// The iceoryx2 configuration of an instance: the defaults with the root path and prefix of its runtime
/// directory ([`InstanceDir::locate`]).
pub fn iceoryx2_config(instance: &str) -> Result<Config, ProtocolError> {
    Ok(InstanceDir::locate(instance)?.iceoryx2_config()?)
}

/// A node with vservo's settings: the configuration of the instance's runtime directory (found with
/// [`InstanceDir::locate`]), named, and without iceoryx2's own signal handling (the processes handle SIGTERM
/// and SIGINT themselves).
pub fn create_node(instance: &str, role: &str) -> Result<Node<ipc::Service>, ProtocolError> {
    create_node_in(&InstanceDir::locate(instance)?, role)
}

/// [`create_node`] in a known runtime directory (the daemon's own, from its [`InstanceClaim`]).
pub fn create_node_in(dir: &InstanceDir, role: &str) -> Result<Node<ipc::Service>, ProtocolError> {
    let name = node_name(&dir.instance, role);
    let node_name = NodeName::new(&name)
        .map_err(|e| ProtocolError::Name { name: name.clone(), reason: format!("{e:?}") })?;
    NodeBuilder::new()
        .name(&node_name)
        .config(&dir.iceoryx2_config()?)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| port_error("creating the node", &name)(e.to_string()))
}
