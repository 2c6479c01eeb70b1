//! The connection to one robot: Connect with version 10 over TCP, the UDP state stream, and commands.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use crate::errors::RobotErrors;
use crate::tcp_channel::{TcpChannel, TcpError};
use crate::udp_channel::{RecvStateError, SendCommandError, StateChannel};
use crate::wire::command::JointVelocityCommand;
use crate::wire::modes::{ControllerMode, MotionGeneratorMode, RobotMode};
use crate::wire::state::RobotState;
use crate::wire::tcp::{Command, ConnectResponse, ConnectStatus, encode_connect_request};
use crate::wire::{DecodeError, PROTOCOL_VERSION};

/// The robot's TCP command port (`kCommandPort`).
pub const FCI_PORT: u16 = 1337;

/// Connecting failed or was refused.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// The UDP socket could not be bound.
    #[error("binding the UDP state socket on {local} failed: {source}")]
    BindUdp {
        /// The address tried.
        local: SocketAddr,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The TCP connection could not be made.
    #[error("TCP connect to the robot at {robot} failed: {source}")]
    TcpConnect {
        /// The robot's address.
        robot: SocketAddr,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The Connect exchange failed on the TCP channel.
    #[error("Connect: {0}")]
    Tcp(#[from] TcpError),
    /// The Connect response could not be decoded.
    #[error("Connect response from {robot}: {source}")]
    Malformed {
        /// The robot's address.
        robot: SocketAddr,
        /// What was wrong.
        #[source]
        source: DecodeError,
    },
    /// The robot refused the client's version (`kIncompatibleLibraryVersion`).
    #[error("the robot at {robot} refused protocol version {client}: it speaks version {server}")]
    IncompatibleVersion {
        /// The robot's address.
        robot: SocketAddr,
        /// The robot's protocol version.
        server: u16,
        /// This client's protocol version.
        client: u16,
    },
    /// The first state did not arrive or was malformed.
    #[error("waiting for the first robot state after Connect: {0}")]
    FirstState(#[source] RecvStateError),
}

/// `now + timeout`, saturating (a huge timeout must not overflow `Instant` and panic).
pub(crate) fn deadline_after(timeout: Duration) -> Instant {
    let now = Instant::now();
    now.checked_add(timeout).or_else(|| now.checked_add(Duration::from_secs(1 << 32))).unwrap_or(now)
}

/// What the connection last heard about the robot (libfranka's `updateState`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LastState {
    pub(crate) robot_mode: RobotMode,
    pub(crate) motion_generator_mode: MotionGeneratorMode,
    pub(crate) controller_mode: ControllerMode,
    pub(crate) errors: RobotErrors,
    pub(crate) reflex_reason: RobotErrors,
}

impl LastState {
    fn of(state: &RobotState) -> Self {
        LastState {
            robot_mode: state.robot_mode,
            motion_generator_mode: state.motion_generator_mode,
            controller_mode: state.controller_mode,
            errors: state.errors,
            reflex_reason: state.reflex_reason,
        }
    }
}

/// The running Move, until its final response has been read.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ActiveMotion {
    pub(crate) move_command_id: u32,
}

/// A connection to one robot (or franka-sim) speaking protocol version 10.
///
/// Not thread-safe by design: one control thread owns it. Every blocking call takes a timeout.
#[derive(Debug)]
pub struct Connection {
    pub(crate) tcp: TcpChannel,
    pub(crate) udp: StateChannel,
    server_version: u16,
    first_state: RobotState,
    pub(crate) last: LastState,
    pub(crate) motion: Option<ActiveMotion>,
}

impl Connection {
    /// Connects to the robot at `robot` (normally port [`FCI_PORT`]): makes the TCP connection, binds a UDP socket
    /// on the interface that reaches the robot, sends Connect with version 10 and the UDP port, takes the robot's
    /// answer as libfranka does (a refusal of the version is an error naming both; a success is taken, whatever
    /// version it reports: [`Connection::server_version`]), and waits for the first state. Each step waits at most
    /// `timeout`.
    pub fn connect(robot: SocketAddr, timeout: Duration) -> Result<Self, ConnectError> {
        let mut tcp = TcpChannel::connect(robot, timeout)
            .map_err(|source| ConnectError::TcpConnect { robot, source })?;
        let interface = tcp.local_ip().map_err(|source| ConnectError::BindUdp { local: robot, source })?;
        let mut udp = StateChannel::bind(interface, robot.ip())
            .map_err(|(local, source)| ConnectError::BindUdp { local, source })?;
        let id = tcp.take_command_id();
        tcp.send(&encode_connect_request(id, udp.port()))?;
        let body = tcp.wait(Command::Connect, id, timeout)?;
        let response =
            ConnectResponse::decode(&body).map_err(|source| ConnectError::Malformed { robot, source })?;
        match response.status {
            ConnectStatus::IncompatibleLibraryVersion => {
                return Err(ConnectError::IncompatibleVersion {
                    robot,
                    server: response.version,
                    client: PROTOCOL_VERSION,
                });
            }
            // as libfranka: a robot that takes the client's version says so; the version it reports beside a
            // success is not compared (franky-sim lays it out as a u16 at byte 2, read here as 2560). A server of
            // another version in truth sends states of another size, which are dropped and named.
            ConnectStatus::Success => {}
        }
        let first_state = udp.recv_newest(timeout).map_err(ConnectError::FirstState)?;
        Ok(Connection {
            tcp,
            udp,
            server_version: response.version,
            last: LastState::of(&first_state),
            first_state,
            motion: None,
        })
    }

    /// The protocol version the robot reported with its success (10 from a robot; a server that lays its reply out
    /// otherwise, as franky-sim, reports another number: the driver says so).
    pub fn server_version(&self) -> u16 {
        self.server_version
    }

    /// Whether the robot closed the command channel (it, or its server, went away): looked at without waiting. A
    /// robot gone without a word (a cable pulled) is not seen here, only by its silence.
    pub fn closed(&mut self) -> bool {
        self.tcp.closed()
    }

    /// Gives the connection up (a robot gone without a word): its TCP connection shut both ways, so that the
    /// robot, back, takes a new one. Every call on it fails from then on.
    pub fn give_up(&mut self) {
        self.tcp.shut_down();
    }

    /// The robot's TCP address.
    pub fn robot_addr(&self) -> SocketAddr {
        self.tcp.peer()
    }

    /// The local UDP port the robot sends states to.
    pub fn udp_port(&self) -> u16 {
        self.udp.port()
    }

    /// The local UDP address (bound on the interface that reaches the robot only).
    pub fn udp_local(&self) -> SocketAddr {
        self.udp.local()
    }

    /// The datagrams dropped so far: not from the robot, not a state, or a `message_id` jump
    /// ([`crate::admission`]).
    pub fn dropped(&self) -> &crate::admission::DroppedCounts {
        self.udp.dropped()
    }

    /// The state received right after Connect.
    pub fn first_state(&self) -> &RobotState {
        &self.first_state
    }

    /// True while a Move started by this connection has not been answered with its final status.
    pub fn motion_active(&self) -> bool {
        self.motion.is_some()
    }

    /// The newest state with a `message_id` above the last one received: drains the states already queued
    /// (keeping the newest, as libfranka does), else waits up to `timeout` for the next. A datagram that is not
    /// the robot's 1377-byte v10 state, or whose `message_id` jumps, is dropped and counted ([`Connection::dropped`];
    /// a timeout names the last one).
    pub fn recv_state(&mut self, timeout: Duration) -> Result<RobotState, RecvStateError> {
        let state = self.udp.recv_newest(timeout)?;
        self.last = LastState::of(&state);
        Ok(state)
    }

    /// Answers `state` — which must be the newest received — with `command`, echoing its `message_id`.
    /// Refused when no motion runs or a velocity is not finite. Returns the time from the state's receipt
    /// to the command's send (the client's state → command latency).
    pub fn send_command(
        &mut self,
        state: &RobotState,
        command: &JointVelocityCommand,
    ) -> Result<Duration, SendCommandError> {
        if self.motion.is_none() {
            return Err(SendCommandError::NoActiveMotion);
        }
        self.send_unchecked(state, command)
    }

    /// [`Connection::send_command`] without the active-motion check (the finishing loop uses it).
    pub(crate) fn send_unchecked(
        &mut self,
        state: &RobotState,
        command: &JointVelocityCommand,
    ) -> Result<Duration, SendCommandError> {
        let newest = self.udp.last_message_id();
        if state.message_id != newest {
            return Err(SendCommandError::StaleState { answered: state.message_id, newest });
        }
        if let Some(joint) = command.first_non_finite() {
            let value = command.dq_c.get(joint).copied().unwrap_or(f64::NAN);
            return Err(SendCommandError::NonFinite { joint, value });
        }
        self.udp.send(&command.encode(state.message_id))
    }
}
