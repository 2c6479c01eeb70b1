//! `vservoctl record`: every service of a running instance into an MCAP file (JSON messages with a JSON
//! schema per channel), which Foxglove Studio and the `mcap` tools open.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use clap::Args;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ZeroCopySend, ipc};
use serde_json::Value;
use vservo_protocol::{
    CameraTwistMsg, DaemonStatusMsg, FeaturesMsg, GainsMsg, JointCommandMsg, JointStateMsg, ObjectMsg,
    SimWorldMsg, TelemetryMsg, Topic,
};

use crate::instance::{Connection, InstanceArg};
use crate::json_messages as json;

/// Arguments of `vservoctl record`.
#[derive(Args, Debug)]
pub struct RecordArgs {
    /// The MCAP file to write.
    #[arg(long)]
    out: PathBuf,
    /// Stop after this long (s); otherwise at Ctrl-C or SIGTERM.
    #[arg(long)]
    duration_s: Option<f64>,
    #[command(flatten)]
    instance: InstanceArg,
}

/// One channel of the file.
struct Channel {
    id: u16,
    sequence: u32,
}

type McapWriter = mcap::Writer<BufWriter<File>>;

fn wall_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

fn drain<T: Copy + std::fmt::Debug + ZeroCopySend>(
    subscriber: &Subscriber<ipc::Service, T, ()>,
    render: fn(&T) -> Value,
    stamp_ns: fn(&T) -> u64,
    channel: &mut Channel,
    writer: &mut McapWriter,
) -> anyhow::Result<u64> {
    let mut written = 0;
    while let Some(sample) = subscriber.receive()? {
        let message = *sample;
        channel.sequence += 1;
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence: channel.sequence,
            log_time: wall_ns(),
            publish_time: stamp_ns(&message),
        };
        writer.write_to_known_channel(&header, render(&message).to_string().as_bytes())?;
        written += 1;
    }
    Ok(written)
}

/// SIGINT and SIGTERM end the recording cleanly (the file gets its summary).
fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    use nix::sys::signal::{SigSet, Signal};
    let stop = Arc::new(AtomicBool::new(false));
    let mut signals = SigSet::empty();
    signals.add(Signal::SIGINT);
    signals.add(Signal::SIGTERM);
    signals.thread_block().context("blocking SIGINT and SIGTERM")?;
    let flag = stop.clone();
    std::thread::spawn(move || {
        if signals.wait().is_ok() {
            flag.store(true, Ordering::Relaxed);
        }
    });
    Ok(stop)
}

pub fn run(args: &RecordArgs) -> anyhow::Result<()> {
    let stop = stop_flag()?;
    let connection = Connection::open(&args.instance)?;
    let file = File::create(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut writer = mcap::WriteOptions::new()
        .profile("")
        .library(concat!("vservoctl ", env!("CARGO_PKG_VERSION")))
        .create(BufWriter::new(file))?;
    let mut channels = BTreeMap::new();
    for topic in Topic::ALL {
        let schema = serde_json::json!({"type": "object", "title": topic.type_name()}).to_string();
        let schema_id = writer.add_schema(topic.type_name(), "jsonschema", schema.as_bytes())?;
        let metadata = BTreeMap::from([
            ("type_name".to_string(), topic.type_name().to_string()),
            ("schema_version".to_string(), vservo_protocol::SCHEMA_VERSION.to_string()),
            (
                "publish_time".to_string(),
                "the message's stamp_ns: CLOCK_MONOTONIC of the host (0: none)".to_string(),
            ),
        ]);
        let id =
            writer.add_channel(schema_id, &topic.service_name(&connection.instance), "json", &metadata)?;
        channels.insert(topic.name(), Channel { id, sequence: 0 });
    }
    let joint_state = connection.subscriber::<JointStateMsg>(Topic::JointState)?;
    let joint_command = connection.subscriber::<JointCommandMsg>(Topic::JointCommand)?;
    let sim_world = connection.subscriber::<SimWorldMsg>(Topic::SimWorld)?;
    let features = connection.subscriber::<FeaturesMsg>(Topic::Features)?;
    let twist = connection.subscriber::<CameraTwistMsg>(Topic::CameraTwist)?;
    let telemetry = connection.subscriber::<TelemetryMsg>(Topic::Telemetry)?;
    let status = connection.subscriber::<DaemonStatusMsg>(Topic::Status)?;
    let gains = connection.subscriber::<GainsMsg>(Topic::Gains)?;
    let object = connection.subscriber::<ObjectMsg>(Topic::Object)?;
    let until = args.duration_s.map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
    let mut written = 0;
    while !stop.load(Ordering::Relaxed) && until.is_none_or(|u| Instant::now() < u) {
        let c = &mut channels;
        written +=
            drain(&joint_state, json::joint_state, |m| m.stamp_ns, get(c, "joint_state")?, &mut writer)?;
        written += drain(
            &joint_command,
            json::joint_command,
            |m| m.stamp_ns,
            get(c, "joint_command")?,
            &mut writer,
        )?;
        written += drain(&sim_world, json::sim_world, |_| 0, get(c, "sim_world")?, &mut writer)?;
        written += drain(&features, json::features, |m| m.stamp_ns, get(c, "features")?, &mut writer)?;
        written += drain(&twist, json::camera_twist, |m| m.stamp_ns, get(c, "camera_twist")?, &mut writer)?;
        written += drain(&telemetry, json::telemetry, |m| m.stamp_ns, get(c, "telemetry")?, &mut writer)?;
        written += drain(&status, json::status, |m| m.stamp_ns, get(c, "status")?, &mut writer)?;
        written += drain(&gains, json::gains, |_| 0, get(c, "gains")?, &mut writer)?;
        written += drain(&object, json::object, |_| 0, get(c, "object")?, &mut writer)?;
        std::thread::sleep(Duration::from_micros(500));
    }
    writer.finish()?;
    eprintln!("vservoctl: recorded {written} messages to {}", args.out.display());
    Ok(())
}

fn get<'a>(channels: &'a mut BTreeMap<&'static str, Channel>, name: &str) -> anyhow::Result<&'a mut Channel> {
    channels.get_mut(name).with_context(|| format!("no channel {name}"))
}
