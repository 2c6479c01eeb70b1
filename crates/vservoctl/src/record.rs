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

/// Where a recording goes: written to a file of its own beside the name asked for (made new, mode 0600, never
/// through a symbolic link: `O_CREAT | O_EXCL | O_NOFOLLOW`), and moved to the name once finished
/// ([`Output::publish`]): a symbolic link or a file another user planted at the name, in a shared folder, is
/// replaced, never written through or into. A recording that does not finish leaves nothing behind.
pub struct Output {
    partial: PathBuf,
    target: PathBuf,
    published: bool,
}

impl Output {
    /// Flushes the finished MCAP file to disk and moves it to its name.
    pub fn publish(mut self, writer: mcap::Writer<BufWriter<File>>) -> anyhow::Result<()> {
        let file = writer.into_inner().into_inner().map_err(|e| e.into_error())?;
        file.sync_all().with_context(|| format!("writing {}", self.partial.display()))?;
        std::fs::rename(&self.partial, &self.target)
            .with_context(|| format!("moving the recording to {}", self.target.display()))?;
        self.published = true;
        Ok(())
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if !self.published {
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

/// The MCAP file (zstd-compressed chunks) and where it goes once finished ([`Output`]).
pub fn create(
    path: &std::path::Path,
    profile: &str,
) -> anyhow::Result<(mcap::Writer<BufWriter<File>>, Output)> {
    let name = path.file_name().with_context(|| format!("{}: not a file name", path.display()))?;
    let partial = path.with_file_name(format!(".{}.{}.partial", name.to_string_lossy(), std::process::id()));
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .custom_flags(nix::libc::O_NOFOLLOW)
        .open(&partial)
        .with_context(|| format!("creating {}", partial.display()))?;
    let output = Output { partial, target: path.to_path_buf(), published: false };
    let writer = mcap::WriteOptions::new()
        .profile(profile)
        .library(concat!("vservoctl ", env!("CARGO_PKG_VERSION")))
        .compression(Some(mcap::Compression::Zstd))
        .create(BufWriter::new(file))?;
    Ok((writer, output))
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
    let (writer, output) = create(&args.out, "")?;
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
