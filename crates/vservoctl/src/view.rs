//! `vservoctl view`: the running cell live in Foxglove. Serves the Foxglove WebSocket protocol through the
//! official Foxglove SDK with what `vservoctl record` writes (`crate::bridge`): the camera's images with the
//! marks on them, the arm's, camera's and board's frames, and every service as plottable JSON. It is a
//! client of the instance like any other, reading with iceoryx2's safe overflow: a slow or absent viewer
//! never slows the loop. vservod starts it when `[viewer] enabled = true`.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::Ordering;

use anyhow::Context as _;
use clap::Args;
use foxglove::{ChannelBuilder, Context, PartialMetadata, RawChannel, Schema, WebSocketServer};

use crate::bridge::{Bridge, ChannelSpec, Sink};
use crate::instance::{Connection, InstanceArg};

/// Arguments of `vservoctl view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// The address to serve on (`0.0.0.0` for every interface; mind who can reach it).
    #[arg(long, default_value = "127.0.0.1")]
    address: String,
    /// The port to serve on (0: any free one, printed).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Send every n-th camera image (1: every one; 0: none).
    #[arg(long, default_value_t = 1, value_name = "N")]
    image_every: u64,
    #[command(flatten)]
    instance: InstanceArg,
}

/// Foxglove's channels of one context as the bridge's sink: the WebSocket server sends what is logged on
/// them to each connected client that subscribed.
struct LiveSink {
    context: Arc<Context>,
    channels: BTreeMap<String, Arc<RawChannel>>,
}

impl Sink for LiveSink {
    fn add_channel(&mut self, spec: ChannelSpec<'_>) -> anyhow::Result<()> {
        let channel = ChannelBuilder::new(spec.topic)
            .context(&self.context)
            .schema(Schema::new(spec.schema_name, spec.schema_encoding, spec.schema.to_vec()))
            .message_encoding(spec.message_encoding)
            .metadata(spec.metadata)
            .build_raw()
            .with_context(|| format!("the channel {}", spec.topic))?;
        self.channels.insert(spec.topic.to_string(), channel);
        Ok(())
    }

    fn write(&mut self, topic: &str, bytes: &[u8], log_ns: u64, _publish_ns: u64) -> anyhow::Result<()> {
        let channel = self.channels.get(topic).with_context(|| format!("no channel {topic}"))?;
        channel.log_with_meta(bytes, PartialMetadata { log_time: Some(log_ns) });
        Ok(())
    }
}

pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    // SIGINT and SIGTERM end it cleanly
    let stop = crate::stop::stop_flag()?;
    // started before the daemon (or by it), it waits for the instance
    let connection = Connection::open_when_there(&args.instance, || stop.load(Ordering::Relaxed))?;
    let context = Context::new();
    let server = WebSocketServer::new()
        .name(format!("vservo {}", connection.instance))
        .bind(args.address.clone(), args.port)
        .context(&context)
        .start_blocking()
        .with_context(|| {
            format!("serving Foxglove's WebSocket protocol on {}:{}", args.address, args.port)
        })?;
    // one line a script (or a test) can wait for
    println!("vservoctl view: ws://{}:{} (instance {})", args.address, server.port(), connection.instance);
    let sink = LiveSink { context: context.clone(), channels: BTreeMap::new() };
    let mut bridge = Bridge::new(sink, &connection, &args.instance, args.image_every)?;
    let result = bridge.run(&connection, || stop.load(Ordering::Relaxed));
    drop(server.stop());
    result
}
