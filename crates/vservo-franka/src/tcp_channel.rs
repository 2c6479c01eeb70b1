//! The TCP command channel: numbered requests, responses framed by their header's size and filed by
//! `command_id` (responses to different requests may interleave; one Move gets two responses).

use std::collections::{HashMap, VecDeque};
use std::io::{self, ErrorKind, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use crate::wire::DecodeError;
use crate::wire::tcp::{Command, HEADER_SIZE, Header};

/// The TCP command channel failed.
#[derive(Debug, thiserror::Error)]
pub enum TcpError {
    /// A socket call failed.
    #[error("TCP {op} on the command channel to {peer} failed: {source}")]
    Io {
        /// The call (`write`, `read`, `set_nonblocking`, …).
        op: &'static str,
        /// The robot's address.
        peer: SocketAddr,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The robot closed the connection.
    #[error("the robot at {peer} closed the TCP command channel")]
    Closed {
        /// The robot's address.
        peer: SocketAddr,
    },
    /// No response came in time.
    #[error("no {command} response (command id {command_id}) from {peer} within {waited:?}")]
    Timeout {
        /// The request.
        command: Command,
        /// Its id.
        command_id: u32,
        /// The robot's address.
        peer: SocketAddr,
        /// How long it was waited for.
        waited: Duration,
    },
    /// A frame could not be parsed (the stream cannot be resynchronised after this).
    #[error("malformed TCP frame from {peer}: {source}")]
    Malformed {
        /// The robot's address.
        peer: SocketAddr,
        /// What was wrong.
        #[source]
        source: DecodeError,
    },
    /// The response filed under a request's id is for another command.
    #[error(
        "response with command id {command_id} from {peer} is for command {got}, the request was {expected}"
    )]
    WrongCommand {
        /// The id.
        command_id: u32,
        /// The robot's address.
        peer: SocketAddr,
        /// The command of the request.
        expected: Command,
        /// The command number in the response.
        got: u32,
    },
}

/// What one `read` gave.
#[derive(Debug, PartialEq, Eq)]
enum ReadOutcome {
    /// Bytes (or an interrupted call worth retrying at once).
    Data,
    /// Nothing before the timeout / nothing pending.
    Nothing,
}

/// A received response: its command number and the bytes after the header.
#[derive(Debug)]
struct Response {
    command: u32,
    body: Vec<u8>,
}

/// The command channel to one robot.
#[derive(Debug)]
pub(crate) struct TcpChannel {
    stream: TcpStream,
    peer: SocketAddr,
    next_command_id: u32,
    rx: Vec<u8>,
    mailbox: HashMap<u32, VecDeque<Response>>,
    nonblocking: bool,
}

impl TcpChannel {
    /// Connects to `peer` within `timeout`.
    pub(crate) fn connect(peer: SocketAddr, timeout: Duration) -> Result<Self, std::io::Error> {
        let stream = TcpStream::connect_timeout(&peer, timeout)?;
        stream.set_nodelay(true)?;
        stream.set_write_timeout(Some(timeout))?;
        Ok(TcpChannel {
            stream,
            peer,
            next_command_id: 0,
            rx: Vec::with_capacity(4096),
            mailbox: HashMap::new(),
            nonblocking: false,
        })
    }

    /// Whether the robot closed the connection (or it broke): a look at the stream without taking from it, which
    /// waits for nothing. A connection whose peer went away without a word (a cable pulled) still looks open.
    pub(crate) fn closed(&mut self) -> bool {
        if self.set_nonblocking(true).is_err() {
            return true;
        }
        match self.stream.peek(&mut [0u8; 1]) {
            Ok(0) => true,
            Ok(_) => false,
            Err(e) => !matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted),
        }
    }

    /// Gives the connection up: both directions shut, so that a robot that comes back sees it closed.
    pub(crate) fn shut_down(&mut self) {
        let _ = self.stream.shutdown(std::net::Shutdown::Both);
    }

    /// The robot's address.
    pub(crate) fn peer(&self) -> SocketAddr {
        self.peer
    }

    /// The local address of the connection: the interface that reaches the robot.
    pub(crate) fn local_ip(&self) -> Result<std::net::IpAddr, std::io::Error> {
        Ok(self.stream.local_addr()?.ip())
    }

    /// The id the next request gets (libfranka counts from 0).
    pub(crate) fn take_command_id(&mut self) -> u32 {
        let id = self.next_command_id;
        self.next_command_id = self.next_command_id.wrapping_add(1);
        id
    }

    fn io(&self, op: &'static str) -> impl FnOnce(std::io::Error) -> TcpError {
        let peer = self.peer;
        move |source| TcpError::Io { op, peer, source }
    }

    fn set_nonblocking(&mut self, nonblocking: bool) -> Result<(), TcpError> {
        if self.nonblocking != nonblocking {
            self.stream.set_nonblocking(nonblocking).map_err(self.io("set_nonblocking"))?;
            self.nonblocking = nonblocking;
        }
        Ok(())
    }

    /// Sends a whole request frame.
    pub(crate) fn send(&mut self, frame: &[u8]) -> Result<(), TcpError> {
        self.set_nonblocking(false)?;
        self.stream.write_all(frame).map_err(self.io("write"))
    }

    /// The response to request `command_id` if it has arrived; never blocks.
    pub(crate) fn poll(&mut self, command: Command, command_id: u32) -> Result<Option<Vec<u8>>, TcpError> {
        if let Some(body) = self.take(command, command_id)? {
            return Ok(Some(body));
        }
        self.set_nonblocking(true)?;
        while self.read_some()? == ReadOutcome::Data {}
        self.take(command, command_id)
    }

    /// Waits up to `timeout` for the response to request `command_id`.
    pub(crate) fn wait(
        &mut self,
        command: Command,
        command_id: u32,
        timeout: Duration,
    ) -> Result<Vec<u8>, TcpError> {
        let deadline = crate::client::deadline_after(timeout);
        loop {
            if let Some(body) = self.take(command, command_id)? {
                return Ok(body);
            }
            let remaining = deadline.saturating_duration_since(Instant::now());
            if remaining.is_zero() {
                return Err(TcpError::Timeout { command, command_id, peer: self.peer, waited: timeout });
            }
            self.set_nonblocking(false)?;
            self.stream.set_read_timeout(Some(remaining)).map_err(self.io("set_read_timeout"))?;
            self.read_some()?;
        }
    }

    /// One `read` into the receive buffer, then files every complete frame.
    fn read_some(&mut self) -> Result<ReadOutcome, TcpError> {
        let mut chunk = [0u8; 4096];
        match io::Read::read(&mut self.stream, &mut chunk) {
            Ok(0) => Err(TcpError::Closed { peer: self.peer }),
            Ok(n) => {
                self.rx.extend_from_slice(chunk.get(..n).unwrap_or(&[]));
                self.file_frames().map_err(|source| TcpError::Malformed { peer: self.peer, source })?;
                Ok(ReadOutcome::Data)
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                Ok(ReadOutcome::Nothing)
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => Ok(ReadOutcome::Data),
            Err(e) => Err(self.io("read")(e)),
        }
    }

    /// Moves every complete frame from the receive buffer to the mailbox.
    fn file_frames(&mut self) -> Result<(), DecodeError> {
        while let Some(header) = Header::peek(&self.rx)? {
            let size = usize::try_from(header.size).unwrap_or(usize::MAX);
            let Some(frame) = self.rx.get(HEADER_SIZE..size) else { break };
            let response = Response { command: header.command, body: frame.to_vec() };
            self.mailbox.entry(header.command_id).or_default().push_back(response);
            self.rx.drain(..size);
        }
        Ok(())
    }

    /// Takes the oldest filed response to `command_id`, checking it answers `command`.
    fn take(&mut self, command: Command, command_id: u32) -> Result<Option<Vec<u8>>, TcpError> {
        let Some(queue) = self.mailbox.get_mut(&command_id) else { return Ok(None) };
        let Some(response) = queue.pop_front() else { return Ok(None) };
        if queue.is_empty() {
            self.mailbox.remove(&command_id);
        }
        if response.command != command.to_wire() {
            return Err(TcpError::WrongCommand {
                command_id,
                peer: self.peer,
                expected: command,
                got: response.command,
            });
        }
        Ok(Some(response.body))
    }
}
