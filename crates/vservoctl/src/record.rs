//! `vservoctl record`: every service of a running instance, and the cell as Foxglove shows it
//! (`crate::bridge`), into an MCAP file with zstd-compressed chunks; with `--ros2`, the cell as the ROS 2
//! bridge publishes it instead (`crate::record_ros2`: ROS 2 message schemas and CDR, for `ros2 bag` and
//! `rosbags`). The file is created with mode 0600: a recording holds everything the cell saw and did, for
//! the daemon's user only.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;

use crate::bridge::{Bridge, ChannelSpec, Sink};
use crate::instance::{Connection, InstanceArg};
use vservo_config::new_file::NewFile;

/// Arguments of `vservoctl record`.
#[derive(Args, Debug)]
pub struct RecordArgs {
    /// The MCAP file to write (a new name: a link or another user's file there is refused, one's own file
    /// too unless --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace one's own file at --out.
    #[arg(long)]
    pub force: bool,
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

/// Where a recording goes once finished: its name (`vservo_config::new_file`: a link, another user's file or, without
/// `--force`, one's own file at the name is refused before anything is recorded).
pub struct Output(NewFile);

impl Output {
    /// Flushes the finished MCAP file to disk and moves it to its name.
    pub fn publish(self, writer: mcap::Writer<BufWriter<File>>) -> anyhow::Result<()> {
        let file = writer.into_inner().into_inner().map_err(|e| e.into_error())?;
        Ok(self.0.publish(file)?)
    }
}

/// The MCAP file (zstd-compressed chunks) and where it goes once finished ([`Output`]): mode 0600.
pub fn create(
    path: &std::path::Path,
    force: bool,
    profile: &str,
) -> anyhow::Result<(mcap::Writer<BufWriter<File>>, Output)> {
    let (file, new) = NewFile::create(path, force, 0o600)?;
    let writer = mcap::WriteOptions::new()
        .profile(profile)
        .library(concat!("vservoctl ", env!("CARGO_PKG_VERSION")))
        .compression(Some(mcap::Compression::Zstd))
        .create(BufWriter::new(file))?;
    Ok((writer, Output(new)))
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
    let (writer, output) = create(&args.out, args.force, "")?;
    let sink = McapSink { writer, channels: BTreeMap::new() };
    let mut bridge = Bridge::new(sink, &connection, &args.instance, args.image_every)?;
    bridge.run(&connection, over)?;
    let written = bridge.written;
    let mut writer = bridge.sink.writer;
    writer.finish()?;
    output.publish(writer)?;
    eprintln!("vservoctl: recorded {written} messages to {}", args.out.display());
    Ok(())
}
