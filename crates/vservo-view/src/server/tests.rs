//! Unit tests of `live_server`.

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
                .schema(foxglove::Schema::new(spec.schema_name, spec.schema_encoding, spec.schema.to_vec()))
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
        let sdk_frame =
            first_frame(&mut sdk_client, subscription_id, || sdk_channel.log_with_meta(payload, metadata));
        let our_frame =
            first_frame(&mut our_client, subscription_id, || hub.publish(ours_ids[n], log_time_ns, payload));
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
