//! # vservo-client — talk to a running vservo instance from Rust
//!
//! This crate owns the client side of vservo's shared-memory protocol (docs/PROTOCOL.md): commands (targets,
//! object motion, reload, safe stop and resume) over the `command` request-response service, each answered with
//! whether it was accepted and why not, the safe stop on the instance's safe-stop path, which no client can
//! crowd out ([`safe_stop`]), and reading the instance's status and loop messages.
//!
//! [`Client::connect`] finds the instance (`vservo_protocol::InstanceDir::locate`, its `schema` checked).
//! A command port is held only for one request; when every slot is taken the command is
//! [`ClientError::Busy`]. The commands: targets (features, a pose, teach), object motion, reload, safe stop,
//! resume, a joint move (`move_joints`) and its end (`servo`). [`Client::subscribe`] reads any topic.
//! [`status::StatusView`] is the user's view of an instance: the daemon's status joined with each node's
//! telemetry, incl. the robot driver's state, used by `vservoctl status` and `top` and the daemon's one-line
//! status.
//!
//! ```no_run
//! let mut client = vservo_client::Client::connect("default")?;
//! let reply = client.set_target_features([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0])?;
//! if !reply.accepted {
//!     eprintln!("refused: {}", reply.reason);
//! }
//! let status = client.status(std::time::Duration::from_secs(1))?;
//! println!("gains version {}", status.gains_version);
//! # Ok::<(), vservo_client::ClientError>(())
//! ```

pub mod safe_stop;
pub mod status;

pub use safe_stop::{SafeStopped, safe_stop};
pub use status::{FaultView, NodeView, StatusView, TimingUs};

/// The words an accepted reload's reply ends with when the nodes that read the camera (its lens and mount)
/// restart with it, the cell held meanwhile (vservod writes them; `vservoctl calibrate --apply` waits for those
/// nodes when it reads them).
pub const RELOAD_RESTARTS_NODES: &str =
    "the servo, vision and rmrc nodes restart with it while the cell is held";

use std::time::{Duration, Instant};

use iceoryx2::port::client::Client as IceoryxClient;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{Node, ZeroCopySend, ipc};
use vservo_protocol::Opening;
pub use vservo_protocol::{
    CameraTwistMsg, CommandKind, CommandMsg, CommandReplyMsg, DaemonStatusMsg, FEATURES, FeaturesMsg,
    JointStateMsg, SCHEMA_VERSION, TelemetryMsg, Topic,
};

/// What can go wrong talking to an instance.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// iceoryx2 refused a node, service or port.
    #[error(transparent)]
    Protocol(#[from] vservo_protocol::ProtocolError),
    /// Sending a request or reading its answer failed.
    #[error("{what}: {reason}")]
    Transport {
        /// What was being done.
        what: &'static str,
        /// iceoryx2's reason.
        reason: String,
    },
    /// Every command slot of the instance is taken (by other clients sending at this moment): nothing was
    /// sent; try again.
    #[error(
        "instance {instance:?} is busy: all {slots} command slots are taken by other clients; nothing was sent, try again"
    )]
    Busy {
        /// The instance.
        instance: String,
        /// Its command slots.
        slots: usize,
    },
    /// More joint values than the protocol carries: nothing was sent.
    #[error("{given} joint values; the protocol carries {carried} at most")]
    TooManyJoints {
        /// The values given.
        given: usize,
        /// What a command carries.
        carried: usize,
    },
    /// The safe-stop path refused the request (no daemon reads it, or it is not there).
    #[error(transparent)]
    SafeStopPath(#[from] vservo_protocol::stop_path::SafeStopPathError),
    /// The safe stop was asked for, but the status did not confirm it.
    #[error(
        "a safe stop was asked for on {path}, but the status of instance {instance:?} did not confirm it within {waited:?}: {why}"
    )]
    SafeStopNotConfirmed {
        /// The instance.
        instance: String,
        /// The safe-stop path written to.
        path: std::path::PathBuf,
        /// How long was waited.
        waited: Duration,
        /// What was (not) seen.
        why: String,
    },
    /// No answer within the time allowed: no daemon runs this instance, or it runs as another user.
    #[error(
        "no answer from vservod of instance {instance:?} within {waited:?} (is it running, as the same user?)"
    )]
    NoAnswer {
        /// The instance.
        instance: String,
        /// How long was waited.
        waited: Duration,
    },
}

/// The daemon's answer to a command.
#[derive(Debug, Clone, PartialEq)]
pub struct Reply {
    /// Whether the command was accepted.
    pub accepted: bool,
    /// Why it was refused, or what was done.
    pub reason: String,
    /// The gains version in force after it.
    pub gains_version: u64,
    /// ξ_d in force after it (px).
    pub target_features_px: [f64; FEATURES],
}

/// A connection to one instance. It holds none of the instance's command slots while idle: each command
/// opens the service, sends, waits for its answer and lets go, so clients that are idle or gone never lock
/// others out.
pub struct Client {
    instance: String,
    node: Node<ipc::Service>,
    next_id: u64,
    /// How long a command waits for its answer (2 s unless changed).
    pub timeout: Duration,
}

fn transport(what: &'static str) -> impl Fn(String) -> ClientError {
    move |reason| ClientError::Transport { what, reason }
}

impl Client {
    /// Connects to the instance named `instance` (its `[instance] name`).
    pub fn connect(instance: &str) -> Result<Self, ClientError> {
        let node = vservo_protocol::create_node(instance, &format!("client-{}", std::process::id()))?;
        // the daemon's service must be there: a client never creates it
        drop(vservo_protocol::open_command_service(&node, instance, Opening::OpenOnly)?);
        Ok(Self {
            instance: instance.to_string(),
            node,
            next_id: u64::from(std::process::id()) << 32,
            timeout: Duration::from_secs(2),
        })
    }

    /// The instance.
    pub fn instance(&self) -> &str {
        &self.instance
    }

    /// Sends a command (its `id` is set here) and waits for the answer.
    pub fn request(&mut self, mut command: CommandMsg) -> Result<Reply, ClientError> {
        self.next_id += 1;
        command.id = self.next_id;
        command.schema = SCHEMA_VERSION;
        let commands = self.command_port()?;
        let pending =
            commands.send_copy(command).map_err(|e| transport("sending the command")(e.to_string()))?;
        let started = Instant::now();
        loop {
            if let Some(response) =
                pending.receive().map_err(|e| transport("receiving the answer")(e.to_string()))?
                && response.id == command.id
            {
                return Ok(Reply {
                    accepted: response.accepted == 1,
                    reason: response.reason(),
                    gains_version: response.gains_version,
                    target_features_px: response.target_features_px,
                });
            }
            if started.elapsed() >= self.timeout {
                return Err(ClientError::NoAnswer { instance: self.instance.clone(), waited: self.timeout });
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// A command port for one request; [`ClientError::Busy`] when every slot is taken.
    fn command_port(
        &self,
    ) -> Result<IceoryxClient<ipc::Service, CommandMsg, (), vservo_protocol::CommandReplyMsg, ()>, ClientError>
    {
        use iceoryx2::service::port_factory::client::ClientCreateError;
        let service = vservo_protocol::open_command_service(&self.node, &self.instance, Opening::OpenOnly)?;
        service.client_builder().create().map_err(|e| match e {
            ClientCreateError::ExceedsMaxSupportedClients => {
                ClientError::Busy { instance: self.instance.clone(), slots: vservo_protocol::COMMAND_SLOTS }
            }
            other => transport("creating the command client")(other.to_string()),
        })
    }

    /// ξ_d = `features_px` ([x₁ y₁ … x₄ y₄], px).
    pub fn set_target_features(&mut self, features_px: [f64; FEATURES]) -> Result<Reply, ClientError> {
        let mut command = CommandMsg::new(CommandKind::TargetFeatures, 0);
        command.features_px = features_px;
        self.request(command)
    }

    /// The camera's desired pose relative to the board: the board at `translation_m` in the desired camera
    /// frame, turned by roll–pitch–yaw `rotation_rpy_rad` (R = Rz·Ry·Rx).
    pub fn set_target_pose(
        &mut self,
        translation_m: [f64; 3],
        rotation_rpy_rad: [f64; 3],
    ) -> Result<Reply, ClientError> {
        let mut command = CommandMsg::new(CommandKind::TargetPose, 0);
        command.translation_m = translation_m;
        command.rotation_rpy_rad = rotation_rpy_rad;
        self.request(command)
    }

    /// The current features and pose become the target.
    pub fn teach(&mut self) -> Result<Reply, ClientError> {
        self.request(CommandMsg::new(CommandKind::TargetTeach, 0))
    }

    /// The simulated board stops where it is.
    pub fn object_hold(&mut self) -> Result<Reply, ClientError> {
        self.request(CommandMsg::new(CommandKind::ObjectHold, 0))
    }

    /// The simulated board jumps by `translation_m` (desired camera frame).
    pub fn object_step(&mut self, translation_m: [f64; 3]) -> Result<Reply, ClientError> {
        let mut command = CommandMsg::new(CommandKind::ObjectStep, 0);
        command.translation_m = translation_m;
        self.request(command)
    }

    /// The simulated board circles in the desired camera frame's y–z plane from where it is.
    pub fn object_circle(&mut self, radius_m: f64, rev_per_min: f64) -> Result<Reply, ClientError> {
        let mut command = CommandMsg::new(CommandKind::ObjectCircle, 0);
        command.radius_m = radius_m;
        command.rev_per_min = rev_per_min;
        self.request(command)
    }

    /// Reloads the daemon's configuration file (as SIGHUP does) and says what came of it.
    pub fn reload(&mut self) -> Result<Reply, ClientError> {
        self.request(CommandMsg::new(CommandKind::Reload, 0))
    }

    /// Servo again after a safe stop; refused, naming each cause, while a fault's cause is still there.
    pub fn resume(&mut self) -> Result<Reply, ClientError> {
        self.request(CommandMsg::new(CommandKind::Resume, 0))
    }

    /// Bring the arm to rest and hold it (a safe stop; [`Client::resume`] ends it), asked for over the
    /// `command` service and acknowledged by the daemon; it needs a free command slot ([`ClientError::Busy`]
    /// otherwise): [`safe_stop`] (the safe-stop path) needs none.
    pub fn safe_stop_command(&mut self) -> Result<Reply, ClientError> {
        self.request(CommandMsg::new(CommandKind::SafeStop, 0))
    }

    /// Moves the arm's joints to `joints_rad` (the arm's joint count of values, at most
    /// [`vservo_protocol::MAX_JOINTS`]) at up to `speed_fraction` (0–1] of their speed limits, and holds them
    /// there instead of servoing, until [`Client::servo`]; the daemon refuses it in a safe stop (a `target_lost` one it ends), outside the
    /// joint limits or with values for joints the arm does not have. The reply comes at once: the joint states
    /// say when the arm is there.
    pub fn move_joints(&mut self, joints_rad: &[f64], speed_fraction: f64) -> Result<Reply, ClientError> {
        self.move_joints_with(joints_rad, speed_fraction, 0)
    }

    /// [`Client::move_joints`] that also ends a cell held by the user (`start_held`, `requested`) into the move:
    /// the user's own first motion of a held cell (a calibration's planned, slow moves).
    pub fn move_joints_out_of_hold(
        &mut self,
        joints_rad: &[f64],
        speed_fraction: f64,
    ) -> Result<Reply, ClientError> {
        self.move_joints_with(joints_rad, speed_fraction, vservo_protocol::MOVE_OUT_OF_HOLD)
    }

    fn move_joints_with(
        &mut self,
        joints_rad: &[f64],
        speed_fraction: f64,
        flags: u32,
    ) -> Result<Reply, ClientError> {
        let mut command = CommandMsg::new(CommandKind::MoveJoints, 0);
        command.flags = flags;
        if joints_rad.len() > command.joints_rad.len() {
            return Err(ClientError::TooManyJoints {
                given: joints_rad.len(),
                carried: command.joints_rad.len(),
            });
        }
        command.joints_rad[..joints_rad.len()].copy_from_slice(joints_rad);
        command.joint_count = joints_rad.len() as u32;
        command.speed_fraction = speed_fraction;
        self.request(command)
    }

    /// Ends a joint move: the cell servos again from where the arm is.
    pub fn servo(&mut self) -> Result<Reply, ClientError> {
        self.request(CommandMsg::new(CommandKind::Servo, 0))
    }

    /// Sets the dynamics override to `speed_scale` (0–1]: every path of the reference keeps that share of the
    /// joints' speed, acceleration and jerk limits and of the tool's caps. Lowering it is always taken; raising
    /// it only while the cell is held, or `while_moving`.
    pub fn set_speed_scale(&mut self, speed_scale: f64, while_moving: bool) -> Result<Reply, ClientError> {
        let mut command = CommandMsg::new(CommandKind::Speed, 0);
        command.speed_fraction = speed_scale;
        command.flags = if while_moving { vservo_protocol::SPEED_WHILE_MOVING } else { 0 };
        self.request(command)
    }

    /// A subscriber to one of the instance's topics (payload type as in docs/PROTOCOL.md).
    pub fn subscribe<T: std::fmt::Debug + ZeroCopySend + 'static>(
        &self,
        topic: Topic,
    ) -> Result<Subscriber<ipc::Service, T, ()>, ClientError> {
        Ok(vservo_protocol::client_subscriber::<T>(&self.node, &self.instance, topic)?)
    }

    /// A subscriber to the instance's camera images (`camera_image`: the pixels with a
    /// [`vservo_protocol::CameraImageHeader`]).
    pub fn subscribe_camera_images(
        &self,
    ) -> Result<Subscriber<ipc::Service, [u8], vservo_protocol::CameraImageHeader>, ClientError> {
        Ok(vservo_protocol::camera_image_subscriber(&self.node, &self.instance, Opening::OpenOnly)?)
    }

    /// The daemon's latest status, waiting up to `timeout` for it.
    pub fn status(&self, timeout: Duration) -> Result<DaemonStatusMsg, ClientError> {
        let subscriber = self.subscribe::<DaemonStatusMsg>(Topic::Status)?;
        let started = Instant::now();
        loop {
            let mut latest = None;
            while let Some(sample) =
                subscriber.receive().map_err(|e| transport("reading the status")(e.to_string()))?
            {
                if let Ok(status) = vservo_protocol::inbox::accept(*sample) {
                    latest = Some(status);
                }
            }
            if let Some(status) = latest {
                return Ok(status);
            }
            if started.elapsed() >= timeout {
                return Err(ClientError::NoAnswer { instance: self.instance.clone(), waited: timeout });
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}
