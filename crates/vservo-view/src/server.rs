//! The live view's server: Foxglove's WebSocket protocol (subprotocol `foxglove.sdk.v1`, the SDK's name of
//! `foxglove.websocket.v1`, which is accepted as well; spec: <https://github.com/foxglove/ws-protocol>,
//! docs/spec.md) with a gate the SDK's server has no hook for. A connection must give the view's token in
//! its URL ([`crate::token`]) or it gets an HTTP error and nothing else: 401 without a token, 403 with
//! a wrong one, 503 when `max_viewers` are already connected. What a viewer is told is the protocol's
//! minimum: `serverInfo`, `advertise` (each channel with its schema), and the messages of the channels it
//! subscribed to (`0x01 | u32 subscription id | u64 log time ns | payload`, little-endian).
//!
//! Threads, no async: one accepts, one per connection does the handshake and then serves its viewer. The
//! bridge hands each message to [`Hub::publish`], which copies it into each subscribed viewer's bounded
//! queue, dropping the oldest data when a viewer is behind: a slow viewer never slows the bridge.

use std::collections::{HashMap, VecDeque};
use std::io::ErrorKind;
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use base64::Engine as _;
use serde::Deserialize;
use tungstenite::handshake::server::{ErrorResponse, Request, Response};
use tungstenite::http::{HeaderValue, StatusCode};
use tungstenite::protocol::WebSocketConfig;
use tungstenite::{Message, WebSocket};

use crate::ChannelSpec;
use crate::ViewError;
use crate::token::{ViewToken, token_in_query};

/// The subprotocols a viewer may ask for, the one preferred first (both are the same protocol).
pub const SUBPROTOCOLS: [&str; 2] = ["foxglove.sdk.v1", "foxglove.websocket.v1"];
/// The opcode of a message-data frame.
const MESSAGE_DATA: u8 = 0x01;
/// A viewer's queue drops its oldest data beyond this many bytes …
const QUEUE_BYTES: usize = 16 << 20;
/// … or this many messages.
const QUEUE_MESSAGES: usize = 4096;
/// At most this many connections between accept and the end of their handshake (others are closed at once).
const MAX_HANDSHAKES: usize = 16;
/// A handshake not done within this is dropped.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(3);
/// How long a viewer's thread waits for the viewer's own messages before it sends what is queued.
const POLL: Duration = Duration::from_millis(5);
/// How long one write to a viewer may block before the thread goes back to reading (the rest is sent later).
const WRITE_TIMEOUT: Duration = Duration::from_millis(100);
/// The largest message a viewer may send (its subscriptions).
const MAX_VIEWER_MESSAGE_BYTES: usize = 1 << 20;

/// Why a connection was refused, with the HTTP status it gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// No `token=` in the URL.
    #[error("the live view needs its token: ws://host:port/?token=… (`vservoctl view --url` prints it)")]
    NoToken,
    /// A token that is not the view's.
    #[error("wrong token")]
    WrongToken,
    /// `max_viewers` are connected.
    #[error("the live view serves at most {0} viewers at once")]
    Full(usize),
    /// None of [`SUBPROTOCOLS`] was offered.
    #[error("missing expected sec-websocket-protocol header (foxglove.sdk.v1)")]
    NoSubprotocol,
}

impl Refusal {
    /// The HTTP status of the refusal.
    pub fn status(self) -> StatusCode {
        match self {
            Self::NoToken => StatusCode::UNAUTHORIZED,
            Self::WrongToken => StatusCode::FORBIDDEN,
            Self::Full(_) => StatusCode::SERVICE_UNAVAILABLE,
            Self::NoSubprotocol => StatusCode::BAD_REQUEST,
        }
    }

    fn response(self) -> ErrorResponse {
        let mut response = ErrorResponse::new(Some(format!("{self}\n")));
        *response.status_mut() = self.status();
        response
    }
}

/// An advertised channel.
struct Channel {
    id: u64,
    /// Its entry of an `advertise` message.
    advertised: serde_json::Value,
}

/// What the server shares between the bridge and the viewers' threads.
pub struct Hub {
    /// `serverInfo`, as sent to each viewer.
    server_info: String,
    token: ViewToken,
    max_viewers: usize,
    channels: Mutex<Vec<Channel>>,
    viewers: Mutex<Vec<Arc<Viewer>>>,
    /// Viewers admitted (handshake passed the gate, not yet gone).
    admitted: AtomicUsize,
    /// Connections in their handshake.
    handshakes: AtomicUsize,
}

/// Locks a mutex; a thread that panicked while holding it left data that is still whole (queues and maps).
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Hub {
    /// A hub of no channel yet, whose viewers must give `token`.
    pub fn new(name: &str, token: ViewToken, max_viewers: usize) -> Arc<Self> {
        let session_ms = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_millis());
        let server_info = serde_json::json!({
            "op": "serverInfo",
            "name": name,
            "capabilities": [],
            "metadata": {"library": concat!("vservoctl ", env!("CARGO_PKG_VERSION"))},
            "sessionId": session_ms.to_string(),
        });
        Arc::new(Self {
            server_info: server_info.to_string(),
            token,
            max_viewers,
            channels: Mutex::new(Vec::new()),
            viewers: Mutex::new(Vec::new()),
            admitted: AtomicUsize::new(0),
            handshakes: AtomicUsize::new(0),
        })
    }

    /// Adds a channel and advertises it to the viewers connected; returns its id.
    pub fn add_channel(&self, spec: &ChannelSpec<'_>) -> Result<u64, ViewError> {
        let mut channels = lock(&self.channels);
        let id = channels.len() as u64 + 1;
        let advertised = advertised_channel(id, spec)?;
        let message = advertise(std::slice::from_ref(&advertised));
        for viewer in lock(&self.viewers).iter() {
            viewer.push_control(message.clone());
        }
        channels.push(Channel { id, advertised });
        Ok(id)
    }

    /// One message on channel `channel_id`, to each viewer that subscribed to it.
    pub fn publish(&self, channel_id: u64, log_time_ns: u64, payload: &[u8]) {
        for viewer in lock(&self.viewers).iter() {
            let subscription = lock(&viewer.subscriptions).get(&channel_id).copied();
            if let Some(subscription_id) = subscription {
                viewer.push_data(message_data(subscription_id, log_time_ns, payload));
            }
        }
    }

    /// The gate: the token, then the number of viewers, then the subprotocol.
    fn admit(self: &Arc<Self>, request: &Request) -> Result<(Slot, &'static str), Refusal> {
        let given = token_in_query(request.uri().query()).ok_or(Refusal::NoToken)?;
        if !self.token.matches(given) {
            return Err(Refusal::WrongToken);
        }
        let slot = Slot::take(self).ok_or(Refusal::Full(self.max_viewers))?;
        let subprotocol = chosen_subprotocol(request).ok_or(Refusal::NoSubprotocol)?;
        Ok((slot, subprotocol))
    }

    /// Registers a viewer: it gets every channel so far, then each one added.
    fn register(&self, viewer: &Arc<Viewer>) {
        let channels = lock(&self.channels);
        let entries: Vec<serde_json::Value> = channels.iter().map(|c| c.advertised.clone()).collect();
        if !entries.is_empty() {
            viewer.push_control(advertise(&entries));
        }
        lock(&self.viewers).push(viewer.clone());
    }

    fn unregister(&self, viewer: &Arc<Viewer>) {
        lock(&self.viewers).retain(|v| !Arc::ptr_eq(v, viewer));
    }

    fn has_channel(&self, channel_id: u64) -> bool {
        lock(&self.channels).iter().any(|c| c.id == channel_id)
    }
}

/// A viewer's place among the `max_viewers`, given back when dropped.
struct Slot(Arc<Hub>);

impl Slot {
    fn take(hub: &Arc<Hub>) -> Option<Self> {
        let max = hub.max_viewers;
        hub.admitted
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| (n < max).then_some(n + 1))
            .ok()?;
        Some(Self(hub.clone()))
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.admitted.fetch_sub(1, Ordering::AcqRel);
    }
}

/// A connection in its handshake, counted against [`MAX_HANDSHAKES`].
struct Handshaking(Arc<Hub>);

impl Handshaking {
    fn start(hub: &Arc<Hub>) -> Option<Self> {
        hub.handshakes
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| (n < MAX_HANDSHAKES).then_some(n + 1))
            .ok()?;
        Some(Self(hub.clone()))
    }
}

impl Drop for Handshaking {
    fn drop(&mut self) {
        self.0.handshakes.fetch_sub(1, Ordering::AcqRel);
    }
}

/// The newest of [`SUBPROTOCOLS`] the request offers.
fn chosen_subprotocol(request: &Request) -> Option<&'static str> {
    let offered: Vec<&str> = request
        .headers()
        .get_all("sec-websocket-protocol")
        .iter()
        .flat_map(|header| header.to_str().unwrap_or_default().split(','))
        .map(str::trim)
        .collect();
    SUBPROTOCOLS.into_iter().find(|ours| offered.contains(ours))
}

/// A channel as the `advertise` message lists it (as the SDK does: a binary schema in base64, a text
/// schema as it is; metadata only when there is some).
fn advertised_channel(id: u64, spec: &ChannelSpec<'_>) -> Result<serde_json::Value, ViewError> {
    let schema = if matches!(spec.schema_encoding, "protobuf" | "flatbuffer") {
        base64::engine::general_purpose::STANDARD.encode(spec.schema)
    } else {
        String::from_utf8(spec.schema.to_vec())
            .map_err(|_| ViewError::SchemaNotText { topic: spec.topic.to_string() })?
    };
    let mut entry = serde_json::json!({
        "id": id,
        "topic": spec.topic,
        "encoding": spec.message_encoding,
        "schemaName": spec.schema_name,
        "schemaEncoding": spec.schema_encoding,
        "schema": schema,
    });
    if !spec.metadata.is_empty() {
        entry["metadata"] = serde_json::json!(spec.metadata);
    }
    Ok(entry)
}

fn advertise(channels: &[serde_json::Value]) -> String {
    serde_json::json!({"op": "advertise", "channels": channels}).to_string()
}

/// A message-data frame: `0x01 | u32 subscription id | u64 log time ns | payload`, little-endian.
pub fn message_data(subscription_id: u32, log_time_ns: u64, payload: &[u8]) -> Vec<u8> {
    let mut frame = Vec::with_capacity(13 + payload.len());
    frame.push(MESSAGE_DATA);
    frame.extend_from_slice(&subscription_id.to_le_bytes());
    frame.extend_from_slice(&log_time_ns.to_le_bytes());
    frame.extend_from_slice(payload);
    frame
}

/// What is waiting to be sent to a viewer.
enum Outgoing {
    /// A protocol message (never dropped).
    Control(String),
    /// A message-data frame (the oldest go first when the viewer is behind).
    Data(Vec<u8>),
}

/// A viewer's bounded queue.
#[derive(Default)]
struct Queue {
    items: VecDeque<Outgoing>,
    data_bytes: usize,
    /// Data frames dropped because the viewer was behind.
    dropped: u64,
}

impl Queue {
    fn push_data(&mut self, frame: Vec<u8>) {
        self.data_bytes += frame.len();
        self.items.push_back(Outgoing::Data(frame));
        while self.data_bytes > QUEUE_BYTES || self.items.len() > QUEUE_MESSAGES {
            let Some(oldest) = self.items.iter().position(|item| matches!(item, Outgoing::Data(_))) else {
                break;
            };
            if let Some(Outgoing::Data(frame)) = self.items.remove(oldest) {
                self.data_bytes -= frame.len();
                self.dropped += 1;
            }
        }
    }

    fn pop(&mut self) -> Option<Outgoing> {
        let item = self.items.pop_front()?;
        if let Outgoing::Data(frame) = &item {
            self.data_bytes -= frame.len();
        }
        Some(item)
    }
}

/// A connected viewer, as the bridge and its thread share it.
#[derive(Default)]
struct Viewer {
    queue: Mutex<Queue>,
    /// Subscription id by channel id.
    subscriptions: Mutex<HashMap<u64, u32>>,
}

impl Viewer {
    fn push_control(&self, text: String) {
        lock(&self.queue).items.push_back(Outgoing::Control(text));
    }

    fn push_data(&self, frame: Vec<u8>) {
        lock(&self.queue).push_data(frame);
    }

    fn pop(&self) -> Option<Outgoing> {
        lock(&self.queue).pop()
    }
}

/// What a viewer may ask (anything else is ignored).
#[derive(Deserialize)]
#[serde(tag = "op", rename_all = "camelCase")]
enum ViewerRequest {
    Subscribe {
        subscriptions: Vec<Subscription>,
    },
    #[serde(rename_all = "camelCase")]
    Unsubscribe {
        subscription_ids: Vec<u32>,
    },
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Subscription {
    id: u32,
    channel_id: u64,
}

/// Serves viewers on `listener` until the process ends (a thread of its own, as is each viewer's).
pub fn serve(listener: TcpListener, hub: Arc<Hub>) {
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(stream) = stream else { continue };
            // a flood of connections that never finish their handshake cannot pile up threads
            let Some(handshaking) = Handshaking::start(&hub) else { continue };
            let hub = hub.clone();
            std::thread::spawn(move || connection(stream, &hub, handshaking));
        }
    });
}

/// One connection: the gate in its handshake, then its viewer until either side ends.
fn connection(stream: TcpStream, hub: &Arc<Hub>, handshaking: Handshaking) {
    if stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT)).is_err()
        || stream.set_write_timeout(Some(HANDSHAKE_TIMEOUT)).is_err()
    {
        return;
    }
    let mut admitted = None;
    // the error's type is tungstenite's (its handshake callback's), large as it is
    #[allow(clippy::result_large_err)]
    let gate = |request: &Request, mut response: Response| match hub.admit(request) {
        Ok((slot, subprotocol)) => {
            response.headers_mut().insert("sec-websocket-protocol", HeaderValue::from_static(subprotocol));
            admitted = Some(slot);
            Ok(response)
        }
        Err(refusal) => Err(refusal.response()),
    };
    let config = WebSocketConfig::default()
        .max_message_size(Some(MAX_VIEWER_MESSAGE_BYTES))
        .max_write_buffer_size(QUEUE_BYTES * 2);
    // (an error holds the gate, which holds `admitted`: only the socket is kept)
    let socket = tungstenite::accept_hdr_with_config(stream, gate, Some(config)).ok();
    drop(handshaking);
    let (Some(mut socket), Some(_slot)) = (socket, admitted) else { return };
    if socket.get_ref().set_read_timeout(Some(POLL)).is_err()
        || socket.get_ref().set_write_timeout(Some(WRITE_TIMEOUT)).is_err()
        || socket.send(Message::text(hub.server_info.clone())).is_err()
    {
        return;
    }
    let viewer = Arc::new(Viewer::default());
    hub.register(&viewer);
    let _ = serve_viewer(&mut socket, hub, &viewer);
    hub.unregister(&viewer);
}

/// Whether an I/O error only says "not now" (a timeout of the socket).
fn not_now(error: &tungstenite::Error) -> bool {
    matches!(error, tungstenite::Error::Io(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut))
}

/// Reads the viewer's requests and sends its queue, until the connection ends.
fn serve_viewer(
    socket: &mut WebSocket<TcpStream>,
    hub: &Hub,
    viewer: &Viewer,
) -> Result<(), tungstenite::Error> {
    // frames tungstenite holds that the viewer has not taken yet
    let mut behind = false;
    loop {
        match socket.read() {
            Ok(Message::Text(text)) => handle_request(hub, viewer, &text),
            Ok(_) => {}
            Err(error) if not_now(&error) => {}
            Err(error) => return Err(error),
        }
        if behind {
            match socket.flush() {
                Ok(()) => {}
                Err(error) if not_now(&error) => continue,
                Err(error) => return Err(error),
            }
        }
        behind = send_queue(socket, viewer)?;
    }
}

/// Sends what is queued; true when the viewer is behind (the rest stays queued, where the oldest data
/// goes first if it keeps growing).
fn send_queue(socket: &mut WebSocket<TcpStream>, viewer: &Viewer) -> Result<bool, tungstenite::Error> {
    let mut sent = false;
    while let Some(item) = viewer.pop() {
        let message = match item {
            Outgoing::Control(text) => Message::text(text),
            Outgoing::Data(frame) => Message::binary(frame),
        };
        sent = true;
        match socket.write(message) {
            Ok(()) => {}
            Err(error) if not_now(&error) => return Ok(true),
            Err(error) => return Err(error),
        }
    }
    if !sent {
        return Ok(false);
    }
    match socket.flush() {
        Ok(()) => Ok(false),
        Err(error) if not_now(&error) => Ok(true),
        Err(error) => Err(error),
    }
}

/// A viewer's `subscribe` or `unsubscribe` (a subscription to a channel that does not exist is ignored).
fn handle_request(hub: &Hub, viewer: &Viewer, text: &str) {
    let Ok(request) = serde_json::from_str::<ViewerRequest>(text) else { return };
    match request {
        ViewerRequest::Subscribe { subscriptions: wanted } => {
            // the channels are looked at before the subscriptions are locked (the bridge locks them the
            // other way round)
            let known: Vec<Subscription> =
                wanted.into_iter().filter(|s| hub.has_channel(s.channel_id)).collect();
            let mut subscriptions = lock(&viewer.subscriptions);
            for Subscription { id, channel_id } in known {
                subscriptions.insert(channel_id, id);
            }
        }
        ViewerRequest::Unsubscribe { subscription_ids } => {
            lock(&viewer.subscriptions).retain(|_, id| !subscription_ids.contains(id));
        }
    }
}

#[cfg(test)]
mod tests;
