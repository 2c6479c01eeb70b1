//! `vservoctl record`: every service of a running instance into an MCAP file (JSON messages with a JSON
//! schema per channel), which Foxglove Studio and the `mcap` tools open.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use clap::Args;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ZeroCopySend, ipc};
use serde_json::Value;
use vservo_protocol::{
    CameraTwistMsg, CellModeMsg, DaemonStatusMsg, FeaturesMsg, GainsMsg, JointCommandMsg, JointStateMsg,
    ObjectMsg, SimWorldMsg, TelemetryMsg, Topic,
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
    #[arg(long, value_parser = crate::seconds_arg::seconds)]
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

pub fn run(args: &RecordArgs) -> anyhow::Result<()> {
    // SIGINT and SIGTERM end the recording cleanly (the file gets its summary)
    let stop = crate::stop::stop_flag()?;
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
    // a recorder only opens services (it never creates them); what is not there yet (a daemon still
    // starting, a node not up) is looked for again every 0.1 s, and a service the cell does not have (the
    // simulation's sim_world with an external robot) is simply never heard
    let mut taps: Vec<Box<dyn Tapped>> = vec![
        Tap::<JointStateMsg>::boxed(Topic::JointState, json::joint_state, |m| m.stamp_ns),
        Tap::<JointCommandMsg>::boxed(Topic::JointCommand, json::joint_command, |m| m.stamp_ns),
        Tap::<SimWorldMsg>::boxed(Topic::SimWorld, json::sim_world, |_| 0),
        Tap::<FeaturesMsg>::boxed(Topic::Features, json::features, |m| m.stamp_ns),
        Tap::<CameraTwistMsg>::boxed(Topic::CameraTwist, json::camera_twist, |m| m.stamp_ns),
        Tap::<TelemetryMsg>::boxed(Topic::Telemetry, json::telemetry, |m| m.stamp_ns),
        Tap::<DaemonStatusMsg>::boxed(Topic::Status, json::status, |m| m.stamp_ns),
        Tap::<GainsMsg>::boxed(Topic::Gains, json::gains, |_| 0),
        Tap::<ObjectMsg>::boxed(Topic::Object, json::object, |_| 0),
        Tap::<CellModeMsg>::boxed(Topic::CellMode, json::cell_mode, |m| m.stamp_ns),
    ];
    let until = args.duration_s.map(|s| Instant::now() + Duration::from_secs_f64(s));
    let mut written = 0;
    let mut next_look = Instant::now();
    while !stop.load(Ordering::Relaxed) && until.is_none_or(|u| Instant::now() < u) {
        let look = Instant::now() >= next_look;
        if look {
            next_look = Instant::now() + Duration::from_millis(100);
        }
        for tap in &mut taps {
            if look {
                tap.open(&connection);
            }
            written += tap.drain(&mut channels, &mut writer)?;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    writer.finish()?;
    eprintln!("vservoctl: recorded {written} messages to {}", args.out.display());
    Ok(())
}

/// One topic of the recording: its subscriber once the service exists.
struct Tap<T: std::fmt::Debug + ZeroCopySend + 'static> {
    topic: Topic,
    subscriber: Option<Subscriber<ipc::Service, T, ()>>,
    render: fn(&T) -> Value,
    stamp_ns: fn(&T) -> u64,
}

impl<T: Copy + std::fmt::Debug + ZeroCopySend + 'static> Tap<T> {
    fn boxed(topic: Topic, render: fn(&T) -> Value, stamp_ns: fn(&T) -> u64) -> Box<dyn Tapped> {
        Box::new(Self { topic, subscriber: None, render, stamp_ns })
    }
}

/// What the recording loop does with each topic, whatever its payload.
trait Tapped {
    /// Opens the service if it exists now and is not open yet.
    fn open(&mut self, connection: &Connection);
    /// Writes what arrived since the last call.
    fn drain(
        &mut self,
        channels: &mut BTreeMap<&'static str, Channel>,
        writer: &mut McapWriter,
    ) -> anyhow::Result<u64>;
}

impl<T: Copy + std::fmt::Debug + ZeroCopySend + 'static> Tapped for Tap<T> {
    fn open(&mut self, connection: &Connection) {
        if self.subscriber.is_none() {
            self.subscriber = connection.subscriber::<T>(self.topic).ok();
        }
    }

    fn drain(
        &mut self,
        channels: &mut BTreeMap<&'static str, Channel>,
        writer: &mut McapWriter,
    ) -> anyhow::Result<u64> {
        match &self.subscriber {
            Some(subscriber) => {
                drain(subscriber, self.render, self.stamp_ns, get(channels, self.topic.name())?, writer)
            }
            None => Ok(0),
        }
    }
}

fn get<'a>(channels: &'a mut BTreeMap<&'static str, Channel>, name: &str) -> anyhow::Result<&'a mut Channel> {
    channels.get_mut(name).with_context(|| format!("no channel {name}"))
}
