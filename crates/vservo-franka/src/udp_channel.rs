//! The UDP stream: states from the robot (newest one wins, as in libfranka's `receiveRobotState`; which datagrams
//! are the robot's states is [`crate::admission`]'s rule) and commands back to the robot's address.

use std::io::ErrorKind;
use std::net::{IpAddr, SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use crate::admission::{DroppedCounts, StateAdmission};
use crate::wire::command::ROBOT_COMMAND_SIZE;
use crate::wire::state::RobotState;

/// Receive buffer size: the largest UDP payload, so an oversized datagram is reported at its true size.
const MAX_DATAGRAM: usize = 65_507;

/// Receiving a robot state failed.
#[derive(Debug, thiserror::Error)]
pub enum RecvStateError {
    /// No state newer than the last one arrived in time (what was dropped meanwhile is named).
    #[error(
        "no robot state newer than message_id {last_message_id} on UDP {local} within {waited:?}{}",
        dropped_text(dropped)
    )]
    Timeout {
        /// The client's UDP address.
        local: SocketAddr,
        /// The id of the newest state received so far (0: none).
        last_message_id: u64,
        /// How long it was waited for.
        waited: Duration,
        /// The datagrams dropped so far on this connection (boxed: an error's size, on the error path only).
        dropped: Box<DroppedCounts>,
    },
    /// A socket call failed.
    #[error("UDP {op} on {local} failed: {source}")]
    Io {
        /// The call.
        op: &'static str,
        /// The client's UDP address.
        local: SocketAddr,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

/// "; dropped N datagrams, the last: …" when any was dropped.
fn dropped_text(dropped: &DroppedCounts) -> String {
    match dropped.last {
        Some(last) => format!("; {} datagram(s) dropped, the last: {last}", dropped.total()),
        None => String::new(),
    }
}

/// Sending a command failed or was refused.
#[derive(Debug, thiserror::Error)]
pub enum SendCommandError {
    /// No motion is running: the robot would ignore the command.
    #[error("refused to send a command: no motion is running (start one first)")]
    NoActiveMotion,
    /// The state answered is not the newest received: its cycle is over and the robot would not count it.
    #[error("refused to answer state {answered}: the newest state received is {newest}")]
    StaleState {
        /// The `message_id` of the state passed.
        answered: u64,
        /// The `message_id` of the newest state received.
        newest: u64,
    },
    /// A commanded velocity is NaN or infinite.
    #[error("refused to send dq_c[{joint}] = {value}: not a finite velocity")]
    NonFinite {
        /// The joint (0-based).
        joint: usize,
        /// Its value.
        value: f64,
    },
    /// The robot's UDP address is not known yet (no state received).
    #[error("no robot UDP address known yet: no state has been received")]
    NoRobotAddress,
    /// The socket call failed.
    #[error("UDP send of a RobotCommand to {to} failed: {source}")]
    Io {
        /// The robot's UDP address.
        to: SocketAddr,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The datagram went out truncated.
    #[error("UDP send to {to} wrote {sent} of {expected} bytes")]
    Truncated {
        /// The robot's UDP address.
        to: SocketAddr,
        /// Bytes sent.
        sent: usize,
        /// Bytes of the command.
        expected: usize,
    },
}

/// The client's UDP socket.
#[derive(Debug)]
pub(crate) struct StateChannel {
    socket: UdpSocket,
    local: SocketAddr,
    buf: Vec<u8>,
    admission: StateAdmission,
    last_message_id: u64,
    received_at: Option<Instant>,
    nonblocking: bool,
    read_timeout: Option<Duration>,
}

impl StateChannel {
    /// Binds an ephemeral port on `interface` (the local address of the TCP connection to the robot: the
    /// interface that reaches it, not every interface), for the robot on `robot_host`.
    pub(crate) fn bind(interface: IpAddr, robot_host: IpAddr) -> Result<Self, (SocketAddr, std::io::Error)> {
        let at = SocketAddr::new(interface, 0);
        let socket = UdpSocket::bind(at).map_err(|e| (at, e))?;
        let local = socket.local_addr().map_err(|e| (at, e))?;
        Ok(StateChannel {
            socket,
            local,
            buf: vec![0; MAX_DATAGRAM],
            admission: StateAdmission::new(robot_host),
            last_message_id: 0,
            received_at: None,
            nonblocking: false,
            read_timeout: None,
        })
    }

    /// The local UDP port (announced in Connect).
    pub(crate) fn port(&self) -> u16 {
        self.local.port()
    }

    /// The local UDP address.
    pub(crate) fn local(&self) -> SocketAddr {
        self.local
    }

    /// The datagrams dropped so far (not the robot's, not a state, an id jump).
    pub(crate) fn dropped(&self) -> &DroppedCounts {
        self.admission.dropped()
    }

    /// The `message_id` of the newest state received (0 before the first).
    pub(crate) fn last_message_id(&self) -> u64 {
        self.last_message_id
    }

    fn io(&self, op: &'static str) -> impl FnOnce(std::io::Error) -> RecvStateError {
        let local = self.local;
        move |source| RecvStateError::Io { op, local, source }
    }

    fn set_nonblocking(&mut self, nonblocking: bool) -> Result<(), RecvStateError> {
        if self.nonblocking != nonblocking {
            self.socket.set_nonblocking(nonblocking).map_err(self.io("set_nonblocking"))?;
            self.nonblocking = nonblocking;
        }
        Ok(())
    }

    /// The newest state with a `message_id` above the last one: first everything already queued (older
    /// ones dropped), else the next to arrive within `timeout`.
    pub(crate) fn recv_newest(&mut self, timeout: Duration) -> Result<RobotState, RecvStateError> {
        let mut best: Option<(RobotState, Instant)> = None;
        self.set_nonblocking(true)?;
        loop {
            match self.socket.recv_from(&mut self.buf) {
                Ok((n, from)) => self.consider(n, from, &mut best),
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io("recv_from")(e)),
            }
        }
        let deadline = crate::client::deadline_after(timeout);
        while best.is_none() {
            let remaining = deadline.saturating_duration_since(Instant::now());
            if remaining.is_zero() {
                return Err(self.timeout(timeout));
            }
            self.set_nonblocking(false)?;
            // Set once per distinct timeout (a syscall), not per cycle; the deadline bounds the wait.
            if self.read_timeout != Some(timeout) {
                self.socket.set_read_timeout(Some(timeout)).map_err(self.io("set_read_timeout"))?;
                self.read_timeout = Some(timeout);
            }
            match self.socket.recv_from(&mut self.buf) {
                Ok((n, from)) => self.consider(n, from, &mut best),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return Err(self.timeout(timeout));
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io("recv_from")(e)),
            }
        }
        match best {
            Some((state, at)) => {
                self.last_message_id = state.message_id;
                self.received_at = Some(at);
                self.admission.taken(state.message_id, at);
                Ok(state)
            }
            None => Err(self.timeout(timeout)),
        }
    }

    fn timeout(&self, waited: Duration) -> RecvStateError {
        let dropped = Box::new(*self.admission.dropped());
        RecvStateError::Timeout { local: self.local, last_message_id: self.last_message_id, waited, dropped }
    }

    /// The datagram of `n` bytes in the buffer: kept if the robot's state and the newest so far, else dropped
    /// (counted by the admission rule).
    fn consider(&mut self, n: usize, from: SocketAddr, best: &mut Option<(RobotState, Instant)>) {
        let at = Instant::now();
        let bytes = self.buf.get(..n).unwrap_or(&[]);
        let Some(state) = self.admission.admit(bytes, from, at) else { return };
        let newest_so_far = best.as_ref().map_or(self.last_message_id, |(s, _)| s.message_id);
        if state.message_id > newest_so_far {
            *best = Some((state, at));
        }
    }

    /// Sends a 371-byte command to the robot; returns the time since the newest state was received.
    pub(crate) fn send(&mut self, command: &[u8; ROBOT_COMMAND_SIZE]) -> Result<Duration, SendCommandError> {
        let to = self.admission.robot().ok_or(SendCommandError::NoRobotAddress)?;
        let sent = self.socket.send_to(command, to).map_err(|source| SendCommandError::Io { to, source })?;
        let latency = self.received_at.map_or(Duration::ZERO, |at| at.elapsed());
        if sent != ROBOT_COMMAND_SIZE {
            return Err(SendCommandError::Truncated { to, sent, expected: ROBOT_COMMAND_SIZE });
        }
        Ok(latency)
    }
}
