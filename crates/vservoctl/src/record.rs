//! `vservoctl record`: every service of a running instance, and the cell as Foxglove shows it
//! (`crate::bridge`), into an MCAP file with zstd-compressed chunks; with `--ros2`, the cell as the ROS 2
//! bridge publishes it instead (`crate::record_ros2`: ROS 2 message schemas and CDR, for `ros2 bag` and
//! `rosbags`). The file is created with mode 0600: a recording holds everything the cell saw and did, for
//! the daemon's user only.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::BufWriter;
use std::os::unix::fs::OpenOptionsExt;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;

use crate::bridge::{Bridge, ChannelSpec, Sink};
use crate::instance::{Connection, InstanceArg};

/// Arguments of `vservoctl record`.
#[derive(Args, Debug)]
pub struct RecordArgs {
    /// The MCAP file to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Stop after this long (s); otherwise at Ctrl-C or SIGTERM.
    #[arg(long, value_parser = crate::seconds_arg::seconds)]
    duration_s: Option<f64>,
    /// Record every n-th camera image (1: every one; 0: none).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub image_every: u64,
    /// Write the ROS 2 messages of the bridge (docs/ROS2.md) — joint_states, tf, the camera's image and
    /// camera info, the features, the twist, diagnostics — with their ROS 2 schemas and CDR, as `ros2 bag`
    /// records them, instead of vservo's own messages.
    #[arg(long)]
    pub ros2: bool,
    #[command(flatten)]
    pub instance: InstanceArg,
}

/// An MCAP file as the bridge's sink.
struct McapSink {
    writer: mcap::Writer<BufWriter<File>>,
    /// channel id and last sequence number, by topic
    channels: BTreeMap<String, (u16, u32)>,
}

impl Sink for McapSink {
    fn add_channel(&mut self, spec: ChannelSpec<'_>) -> anyhow::Result<()> {
        let schema_id = self.writer.add_schema(spec.schema_name, spec.schema_encoding, spec.schema)?;
        let id = self.writer.add_channel(schema_id, spec.topic, spec.message_encoding, &spec.metadata)?;
        self.channels.insert(spec.topic.to_string(), (id, 0));
        Ok(())
    }

    fn write(&mut self, topic: &str, bytes: &[u8], log_ns: u64, publish_ns: u64) -> anyhow::Result<()> {
        let (id, sequence) = self.channels.get_mut(topic).with_context(|| format!("no channel {topic}"))?;
        *sequence += 1;
        let header = mcap::records::MessageHeader {
            channel_id: *id,
            sequence: *sequence,
            log_time: log_ns,
            publish_time: publish_ns,
        };
        self.writer.write_to_known_channel(&header, bytes)?;
        Ok(())
    }
}

/// The MCAP file: created with mode 0600 (given at creation, no chmod after: no moment at which others could
/// open it; a file that exists already is overwritten and keeps its mode), zstd-compressed chunks.
pub fn create(path: &std::path::Path, profile: &str) -> anyhow::Result<mcap::Writer<BufWriter<File>>> {
    let file = OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)
        .with_context(|| format!("creating {}", path.display()))?;
    Ok(mcap::WriteOptions::new()
        .profile(profile)
        .library(concat!("vservoctl ", env!("CARGO_PKG_VERSION")))
        .compression(Some(mcap::Compression::Zstd))
        .create(BufWriter::new(file))?)
}

pub fn run(args: &RecordArgs) -> anyhow::Result<()> {
    // SIGINT and SIGTERM end the recording cleanly (the file gets its summary)
    let stop = vservo_protocol::signals::stop_flag()?;
    let until = args.duration_s.map(|s| Instant::now() + Duration::from_secs_f64(s));
    let over = || stop.load(Ordering::Relaxed) || until.is_some_and(|u| Instant::now() >= u);
    if args.ros2 {
        return crate::record_ros2::run(args, over);
    }
    // started before the daemon, it waits for the instance (within its duration)
    let connection = Connection::open_when_there(&args.instance, over)?;
    let writer = create(&args.out, "")?;
    let sink = McapSink { writer, channels: BTreeMap::new() };
    let mut bridge = Bridge::new(sink, &connection, &args.instance, args.image_every)?;
    bridge.run(&connection, over)?;
    bridge.sink.writer.finish()?;
    eprintln!("vservoctl: recorded {} messages to {}", bridge.written, args.out.display());
    Ok(())
}
