//! The live view's server: Foxglove's WebSocket protocol (subprotocol `foxglove.sdk.v1`, the SDK's name of
//! `foxglove.websocket.v1`, which is accepted as well; spec: https://github.com/foxglove/ws-protocol,
//! docs/spec.md) with a gate the SDK's server has no hook for. A connection must give the view's token in
//! its URL ([`crate::view_token`]) or it gets an HTTP error and nothing else: 401 without a token, 403 with
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

use crate::bridge::ChannelSpec;
use crate::view_token::{ViewToken, token_in_query};

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
    pub fn add_channel(&self, spec: &ChannelSpec<'_>) -> anyhow::Result<u64> {
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
fn advertised_channel(id: u64, spec: &ChannelSpec<'_>) -> anyhow::Result<serde_json::Value> {
    let schema = if matches!(spec.schema_encoding, "protobuf" | "flatbuffer") {
        base64::engine::general_purpose::STANDARD.encode(spec.schema)
    } else {
        String::from_utf8(spec.schema.to_vec())
            .map_err(|_| anyhow::anyhow!("{}: the schema is not UTF-8 text", spec.topic))?
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
mod tests {
    use std::collections::BTreeMap;
    use std::io::{Read, Write};
    use std::time::Instant;

    use tungstenite::client::IntoClientRequest;

    use super::*;

    const TOPIC: &str = "vservo/t/status";

    fn json_spec(schema: &[u8]) -> ChannelSpec<'_> {
        ChannelSpec {
            topic: TOPIC,
            schema_name: "vservo::DaemonStatus",
            schema_encoding: "jsonschema",
            schema,
            message_encoding: "json",
            metadata: [("type_name".to_string(), "vservo::DaemonStatus".to_string())].into(),
        }
    }

    /// A server of one JSON channel on a free loopback port: its hub, port and token.
    fn server(max_viewers: usize) -> (Arc<Hub>, u16, String) {
        let token = ViewToken::draw().expect("a token");
        let listener = TcpListener::bind("127.0.0.1:0").expect("a port");
        let port = listener.local_addr().expect("bound").port();
        let url = token.url(listener.local_addr().expect("bound"));
        let hub = Hub::new("vservo t", token, max_viewers);
        hub.add_channel(&json_spec(br#"{"type":"object"}"#)).expect("a channel");
        serve(listener, hub.clone());
        let given = url.split("token=").nth(1).expect("a token in the URL").to_string();
        (hub, port, given)
    }

    /// What an HTTP upgrade request to `path` gets within a second: the status and every byte.
    fn raw_upgrade(port: u16, path: &str) -> (u16, Vec<u8>) {
        let mut stream = TcpStream::connect(("127.0.0.1", port)).expect("connects");
        let request = format!(
            "GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
             Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\
             Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
        );
        stream.write_all(request.as_bytes()).expect("sent");
        stream.set_read_timeout(Some(Duration::from_millis(200))).expect("a timeout");
        let mut received = Vec::new();
        let until = Instant::now() + Duration::from_secs(1);
        let mut buffer = [0u8; 4096];
        while Instant::now() < until {
            match stream.read(&mut buffer) {
                Ok(0) => break,
                Ok(n) => received.extend_from_slice(&buffer[..n]),
                Err(_) => {}
            }
        }
        let text = String::from_utf8_lossy(&received);
        let status = text.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
        (status, received)
    }

    type Client = WebSocket<TcpStream>;

    fn connect(port: u16, query: &str) -> Result<Client, u16> {
        let stream = TcpStream::connect(("127.0.0.1", port)).expect("connects");
        let mut request = format!("ws://127.0.0.1:{port}/{query}").into_client_request().expect("a request");
        request.headers_mut().insert("sec-websocket-protocol", HeaderValue::from_static("foxglove.sdk.v1"));
        match tungstenite::client(request, stream) {
            Ok((socket, _)) => {
                socket.get_ref().set_read_timeout(Some(Duration::from_secs(3))).expect("a timeout");
                Ok(socket)
            }
            Err(tungstenite::HandshakeError::Failure(tungstenite::Error::Http(response))) => {
                Err(response.status().as_u16())
            }
            Err(error) => panic!("handshake: {error}"),
        }
    }

    fn next_json(client: &mut Client) -> serde_json::Value {
        match client.read().expect("a message") {
            Message::Text(text) => serde_json::from_str(&text).expect("JSON"),
            other => panic!("not text: {other:?}"),
        }
    }

    /// The first binary frame of subscription `id`, logging on its channel every 10 ms until it comes.
    fn first_frame(client: &mut Client, id: u32, mut log: impl FnMut()) -> Vec<u8> {
        client.get_ref().set_read_timeout(Some(Duration::from_millis(10))).expect("a timeout");
        let until = Instant::now() + Duration::from_secs(5);
        while Instant::now() < until {
            log();
            match client.read() {
                Ok(Message::Binary(frame)) if frame.get(1..5) == Some(&id.to_le_bytes()[..]) => {
                    return frame.to_vec();
                }
                Ok(_) => {}
                Err(error) if not_now(&error) => {}
                Err(error) => panic!("{error}"),
            }
        }
        panic!("no frame");
    }

    #[test]
    fn without_the_token_a_connection_gets_an_http_error_and_nothing_of_the_view() {
        let (_hub, port, token) = server(4);
        let wrong = "0".repeat(32);
        for (path, status) in [("/", 401), ("/?token=", 403), (&format!("/?token={wrong}") as &str, 403)] {
            let (got, bytes) = raw_upgrade(port, path);
            let text = String::from_utf8_lossy(&bytes);
            println!("{path}: HTTP {got}, {} bytes", bytes.len());
            assert_eq!(got, status, "{text}");
            assert!(
                !text.contains("serverInfo") && !text.contains("advertise") && !text.contains(TOPIC),
                "{text}"
            );
        }
        let (got, bytes) = raw_upgrade(port, &format!("/?token={token}"));
        let text = String::from_utf8_lossy(&bytes);
        println!("with the token: HTTP {got}, {} bytes", bytes.len());
        assert_eq!(got, 101, "{text}");
        assert!(text.contains("serverInfo") && text.contains(TOPIC), "{text}");
    }

    #[test]
    fn one_viewer_more_than_the_most_is_refused_with_503_and_a_place_freed_is_taken_again() {
        let (_hub, port, token) = server(2);
        let query = format!("?token={token}");
        let mut first = connect(port, &query).expect("the first viewer");
        let _second = connect(port, &query).expect("the second viewer");
        assert_eq!(next_json(&mut first)["op"], "serverInfo");
        assert_eq!(connect(port, &query).err(), Some(503));
        first.close(None).expect("closing");
        while first.read().is_ok() {}
        drop(first);
        let freed = (0..100).find_map(|_| {
            std::thread::sleep(Duration::from_millis(20));
            connect(port, &query).ok()
        });
        assert!(freed.is_some(), "the place of a viewer gone is given again");
    }

    #[test]
    fn a_viewer_behind_loses_its_oldest_data_never_a_control_message() {
        let mut queue = Queue::default();
        queue.items.push_back(Outgoing::Control("advertise".into()));
        for n in 0..(QUEUE_MESSAGES + 10) {
            queue.push_data(vec![n as u8; 10]);
        }
        assert_eq!(queue.items.len(), QUEUE_MESSAGES);
        assert_eq!(queue.dropped, 11);
        assert!(matches!(queue.pop(), Some(Outgoing::Control(_))));
        assert!(matches!(queue.pop(), Some(Outgoing::Data(frame)) if frame[0] == 11));
        let mut big = Queue::default();
        for _ in 0..5 {
            big.push_data(vec![0; QUEUE_BYTES / 4]);
        }
        assert!(big.data_bytes <= QUEUE_BYTES && big.dropped == 1);
    }

    /// A viewer that subscribed and then stopped reading: the bridge's publishing goes on, that viewer's queue
    /// stays within its bound (its oldest data dropped), and another viewer still gets the newest.
    #[test]
    fn a_viewer_that_stops_reading_never_holds_back_the_bridge_nor_the_others() {
        let (hub, port, token) = server(4);
        let query = format!("?token={token}");
        let mut stalled = connect(port, &query).expect("a viewer");
        let mut reading = connect(port, &query).expect("a viewer");
        for client in [&mut stalled, &mut reading] {
            let channels = advertised(client, 1);
            subscribe(client, 7, &channels, TOPIC);
        }
        // both subscriptions are in before the flood
        let _ = first_frame(&mut stalled, 7, || hub.publish(1, 0, b"first"));
        let _ = first_frame(&mut reading, 7, || hub.publish(1, 0, b"first"));
        let (frames, frame_bytes) = (200u64, 1usize << 20);
        let started = Instant::now();
        let receiver = std::thread::spawn(move || {
            reading.get_ref().set_read_timeout(Some(Duration::from_secs(10))).expect("a timeout");
            let mut last = 0u64;
            while let Ok(message) = reading.read() {
                if let Message::Binary(frame) = message
                    && frame.len() == 13 + frame_bytes
                {
                    last = u64::from_le_bytes(frame[5..13].try_into().expect("8 bytes"));
                    if last == frames {
                        break;
                    }
                }
            }
            last
        });
        for n in 1..=frames {
            hub.publish(1, n, &vec![n as u8; frame_bytes]);
        }
        let published_s = started.elapsed().as_secs_f64();
        let last_received = receiver.join().expect("the reader");
        let (queued_bytes, dropped) = {
            let viewers = lock(&hub.viewers);
            let queues: Vec<(usize, u64)> = viewers
                .iter()
                .map(|v| {
                    let queue = lock(&v.queue);
                    (queue.data_bytes, queue.dropped)
                })
                .collect();
            queues.into_iter().max_by_key(|q| q.1).expect("two viewers")
        };
        println!(
            "{frames} frames of {} KiB published in {published_s:.3} s; the stalled viewer's queue: {} KiB, \
             {dropped} dropped; the reading viewer got up to frame {last_received}",
            frame_bytes >> 10,
            queued_bytes >> 10
        );
        assert_eq!(last_received, frames, "the reading viewer gets the last frame");
        assert!(queued_bytes <= QUEUE_BYTES && dropped > 0, "{queued_bytes} bytes queued, {dropped} dropped");
        drop(stalled);
    }

    /// The same channels and messages through the Foxglove SDK's server and ours: the same `advertise`
    /// entries (ids aside) and byte-for-byte the same message frames, so Foxglove decodes ours as it does
    /// the SDK's.
    #[test]
    fn what_a_viewer_receives_is_what_the_foxglove_sdk_sends() {
        use foxglove::Encode as _;
        let image = foxglove::messages::RawImage {
            width: 2,
            height: 1,
            encoding: "mono8".into(),
            step: 2,
            data: vec![7u8, 9].into(),
            ..Default::default()
        };
        let mut image_bytes = Vec::new();
        image.encode(&mut image_bytes).expect("encoded");
        let image_schema = foxglove::messages::RawImage::get_schema().expect("a schema");
        let image_spec = ChannelSpec {
            topic: "/camera/image",
            schema_name: &image_schema.name,
            schema_encoding: &image_schema.encoding,
            schema: &image_schema.data,
            message_encoding: "protobuf",
            metadata: BTreeMap::new(),
        };
        let json_schema = br#"{"type":"object"}"#;
        let json_payload = br#"{"state":"running"}"#;
        let log_time_ns = 1_234_567_890_123;

        // the SDK's server
        let context = foxglove::Context::new();
        let sdk = foxglove::WebSocketServer::new()
            .name("vservo t")
            .bind("127.0.0.1", 0)
            .context(&context)
            .start_blocking()
            .expect("the SDK's server");
        let mut sdk_channels = Vec::new();
        for spec in [&json_spec(json_schema), &image_spec] {
            sdk_channels.push(
                foxglove::ChannelBuilder::new(spec.topic)
                    .context(&context)
                    .schema(foxglove::Schema::new(
                        spec.schema_name,
                        spec.schema_encoding,
                        spec.schema.to_vec(),
                    ))
                    .message_encoding(spec.message_encoding)
                    .metadata(spec.metadata.clone())
                    .build_raw()
                    .expect("a channel"),
            );
        }
        // ours
        let token = ViewToken::draw().expect("a token");
        let listener = TcpListener::bind("127.0.0.1:0").expect("a port");
        let url = token.url(listener.local_addr().expect("bound"));
        let hub = Hub::new("vservo t", token, 4);
        let ours_ids = [
            hub.add_channel(&json_spec(json_schema)).expect("added"),
            hub.add_channel(&image_spec).expect("added"),
        ];
        serve(listener, hub.clone());

        let mut sdk_client = connect(sdk.port(), "").expect("the SDK's server takes a viewer");
        let mut our_client = connect(url_port(&url), &url[url.find('?').expect("a query")..]).expect("ours");
        let sdk_info = next_json(&mut sdk_client);
        let our_info = next_json(&mut our_client);
        for key in ["op", "name", "capabilities"] {
            assert_eq!(sdk_info[key], our_info[key], "serverInfo {key}");
        }
        let sdk_advertised = advertised(&mut sdk_client, 2);
        let our_advertised = advertised(&mut our_client, 2);
        for topic in [TOPIC, "/camera/image"] {
            let without_id = |entries: &Vec<serde_json::Value>| {
                let mut entry = entries.iter().find(|c| c["topic"] == topic).expect("advertised").clone();
                entry.as_object_mut().expect("an object").remove("id");
                entry
            };
            assert_eq!(without_id(&sdk_advertised), without_id(&our_advertised), "{topic}");
        }
        for (n, (payload, sdk_channel)) in
            [(&json_payload[..], &sdk_channels[0]), (&image_bytes, &sdk_channels[1])].into_iter().enumerate()
        {
            let subscription_id = 40 + n as u32;
            let topic = sdk_channel.topic().to_string();
            subscribe(&mut sdk_client, subscription_id, &sdk_advertised, &topic);
            subscribe(&mut our_client, subscription_id, &our_advertised, &topic);
            let metadata = foxglove::PartialMetadata { log_time: Some(log_time_ns) };
            let sdk_frame = first_frame(&mut sdk_client, subscription_id, || {
                sdk_channel.log_with_meta(payload, metadata)
            });
            let our_frame = first_frame(&mut our_client, subscription_id, || {
                hub.publish(ours_ids[n], log_time_ns, payload)
            });
            assert_eq!(sdk_frame, our_frame, "{topic}");
            assert_eq!(our_frame, message_data(subscription_id, log_time_ns, payload));
            unsubscribe(&mut sdk_client, subscription_id);
            unsubscribe(&mut our_client, subscription_id);
        }
        drop(sdk.stop());
    }

    fn url_port(url: &str) -> u16 {
        let authority = url.trim_start_matches("ws://").split('/').next().expect("an authority");
        authority.rsplit(':').next().and_then(|p| p.parse().ok()).expect("a port")
    }

    /// The channels advertised until `count` are known.
    fn advertised(client: &mut Client, count: usize) -> Vec<serde_json::Value> {
        let mut channels = Vec::new();
        while channels.len() < count {
            let message = next_json(client);
            if message["op"] == "advertise" {
                channels.extend(message["channels"].as_array().expect("channels").iter().cloned());
            }
        }
        channels
    }

    fn subscribe(client: &mut Client, id: u32, channels: &[serde_json::Value], topic: &str) {
        let channel_id = channels.iter().find(|c| c["topic"] == topic).expect("advertised")["id"].clone();
        let request =
            serde_json::json!({"op": "subscribe", "subscriptions": [{"id": id, "channelId": channel_id}]});
        client.send(Message::text(request.to_string())).expect("subscribed");
    }

    fn unsubscribe(client: &mut Client, id: u32) {
        let request = serde_json::json!({"op": "unsubscribe", "subscriptionIds": [id]});
        client.send(Message::text(request.to_string())).expect("unsubscribed");
    }
}
