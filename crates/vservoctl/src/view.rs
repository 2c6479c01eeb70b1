//! `vservoctl view`: the running cell live in Foxglove. Serves Foxglove's WebSocket protocol
//! ([`vservo_view::server`]) with what `vservoctl record` writes (`crate::bridge`): the camera's images with the
//! marks on them, the arm's, camera's and board's frames, and every service as plottable JSON. Only a viewer
//! that gives the view's token ([`vservo_view::token`], readable by the daemon's user only) is served, and at
//! most `--max-clients` at once. It is a client of the instance like any other, reading with iceoryx2's
//! safe overflow: a slow or absent viewer never slows the loop. vservod starts it when
//! `[viewer] enabled = true`.

use std::collections::BTreeMap;
use std::net::TcpListener;
use std::sync::Arc;
use std::sync::atomic::Ordering;

use anyhow::Context as _;
use clap::Args;

use crate::bridge::{Bridge, ChannelSpec, Sink};
use crate::instance::{Connection, InstanceArg};
use vservo_view::server::{self, Hub};
use vservo_view::token::{UrlFile, ViewToken, read_url, url_file};

/// Arguments of `vservoctl view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// Print the URL of the instance's running live view, with its token, and end (readable by the
    /// daemon's user only).
    #[arg(long)]
    url: bool,
    /// The address to serve on (`0.0.0.0` for every interface; the token is required all the same).
    #[arg(long, default_value = "127.0.0.1")]
    address: String,
    /// The port to serve on (0: any free one, printed).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// The most viewers at once; one more is refused (HTTP 503).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    max_clients: u32,
    /// Send every n-th camera image (1: every one; 0: none).
    #[arg(long, default_value_t = 1, value_name = "N")]
    image_every: u64,
    #[command(flatten)]
    instance: InstanceArg,
}

/// The live server's channels as the bridge's sink: what is written on a channel goes to each viewer that
/// subscribed to it.
struct LiveSink {
    hub: Arc<Hub>,
    /// Channel id by topic.
    channels: BTreeMap<String, u64>,
}

impl Sink for LiveSink {
    fn add_channel(&mut self, spec: ChannelSpec<'_>) -> anyhow::Result<()> {
        let id = self.hub.add_channel(&spec).with_context(|| format!("the channel {}", spec.topic))?;
        self.channels.insert(spec.topic.to_string(), id);
        Ok(())
    }

    fn write(&mut self, topic: &str, bytes: &[u8], log_ns: u64, _publish_ns: u64) -> anyhow::Result<()> {
        let id = self.channels.get(topic).with_context(|| format!("no channel {topic}"))?;
        self.hub.publish(*id, log_ns, bytes);
        Ok(())
    }
}

pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    if args.url {
        return print_url(&args.instance);
    }
    // SIGINT and SIGTERM end it cleanly
    let stop = vservo_protocol::signals::stop_flag()?;
    // started before the daemon (or by it), it waits for the instance
    let connection = Connection::open_when_there(&args.instance, || stop.load(Ordering::Relaxed))?;
    let instance_dir = vservo_protocol::InstanceDir::locate(&connection.instance)?;
    let listener = TcpListener::bind((args.address.as_str(), args.port)).with_context(|| {
        format!("serving Foxglove's WebSocket protocol on {}:{}", args.address, args.port)
    })?;
    let bound = listener.local_addr().context("the address served")?;
    let token = ViewToken::draw()?;
    let _url_file = UrlFile::write(url_file(&instance_dir.path), token.url(bound))?;
    let hub = Hub::new(&format!("vservo {}", connection.instance), token, args.max_clients as usize);
    server::serve(listener, hub.clone());
    // one line a script (or a test) can wait for; without the token, since this output goes to the
    // daemon's log (the journal), which other users may be allowed to read
    println!(
        "vservoctl view: ws://{bound} (instance {}; the URL with its token: vservoctl view --url --instance {})",
        connection.instance, connection.instance
    );
    let sink = LiveSink { hub, channels: BTreeMap::new() };
    let mut bridge = Bridge::new(sink, &connection, &args.instance, args.image_every)?;
    bridge.run(&connection, || stop.load(Ordering::Relaxed))
}

/// `--url`: the URL the instance's viewer wrote, with its token.
fn print_url(instance: &InstanceArg) -> anyhow::Result<()> {
    let name = instance.name()?;
    let dir = vservo_protocol::InstanceDir::locate(&name)?;
    println!("{}", read_url(&dir.path, &name)?);
    Ok(())
}
