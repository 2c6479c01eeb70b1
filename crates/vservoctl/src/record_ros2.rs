//! `vservoctl record --ros2`: the cell as the ROS 2 bridge publishes it (`vservo_ros2::translate`), into an
//! MCAP file of ROS 2's profile — each topic with its message's `ros2msg` schema and CDR messages, as
//! `ros2 bag record` writes them — so that `ros2 bag` and the Python `rosbags` library read it
//! (docs/ROS2.md, "Recordings").

use std::collections::BTreeMap;
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::Context;
use vservo_config::Ros2Topic;
use vservo_ros2::cell::Cell;
use vservo_ros2::translate::{LOOK_EVERY, Looks, RosMessage, Selection, Translator};

use crate::record::RecordArgs;

/// Records until `over()` says so.
pub fn run(args: &RecordArgs, mut over: impl FnMut() -> bool) -> anyhow::Result<()> {
    let name = args.instance.name()?;
    // started before the daemon, it waits for the instance (within its duration)
    let Some(mut cell) = Cell::connect(&name, &mut over)? else { return Ok(()) };
    let config = args.instance.configuration_in_force(&name)?;
    let topics: Vec<Ros2Topic> =
        Ros2Topic::ALL.into_iter().filter(|t| args.image_every > 0 || *t != Ros2Topic::Image).collect();
    let selection = Selection {
        topics: topics.clone(),
        image_every: args.image_every,
        joint_state_rate_hz: config.ros2.joint_state_rate_hz,
    };
    let mut recording = Recording::create(args, &config.ros2.namespace, &topics)?;
    let mut translator = Translator::new(&config, selection);
    let mut looks = Looks::default();
    while !over() {
        let mut write = |message: RosMessage| recording.write(&message);
        translator.look(&mut cell, looks.slow(), |_| Vec::new(), &mut write)?;
        recording.failed()?;
        std::thread::sleep(LOOK_EVERY);
    }
    recording.writer.finish()?;
    let Recording { writer, output, .. } = recording;
    output.publish(writer)?;
    eprintln!("vservoctl: recorded {} ROS 2 messages to {}", recording.written, &args.out.display());
    Ok(())
}

/// The MCAP file and its channels.
struct Recording {
    writer: mcap::Writer<std::io::BufWriter<std::fs::File>>,
    /// Where it goes once finished.
    output: crate::record::Output,
    /// channel id and last sequence number, by topic
    channels: BTreeMap<Ros2Topic, (u16, u32)>,
    written: u64,
    /// The first write that failed.
    error: Option<anyhow::Error>,
}

impl Recording {
    fn create(args: &RecordArgs, namespace: &str, topics: &[Ros2Topic]) -> anyhow::Result<Self> {
        let (mut writer, output) = crate::record::create(&args.out, args.force, "ros2")?;
        let mut channels = BTreeMap::new();
        for topic in topics {
            let (schema_name, schema_text) = vservo_ros2::schema::of_topic(*topic);
            let schema_id = writer.add_schema(&schema_name, "ros2msg", schema_text.as_bytes())?;
            let name = vservo_ros2::names::absolute(namespace, vservo_ros2::names::topic(*topic));
            let id = writer.add_channel(schema_id, &name, "cdr", &BTreeMap::new())?;
            channels.insert(*topic, (id, 0));
        }
        Ok(Self { writer, output, channels, written: 0, error: None })
    }

    /// Writes a message, logged now and published at its stamp; keeps the first error.
    fn write(&mut self, message: &RosMessage) {
        if self.error.is_some() {
            return;
        }
        if let Err(error) = self.write_one(message) {
            self.error = Some(error);
        }
    }

    fn write_one(&mut self, message: &RosMessage) -> anyhow::Result<()> {
        let topic = message.topic();
        let (id, sequence) =
            self.channels.get_mut(&topic).with_context(|| format!("no channel for {topic:?}"))?;
        *sequence += 1;
        let log_time = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64);
        let publish_time = message
            .stamp()
            .filter(|t| t.sec >= 0)
            .map_or(log_time, |t| vservo_time::Nanos::from_parts(t.sec as u64, t.nanosec).get());
        let header =
            mcap::records::MessageHeader { channel_id: *id, sequence: *sequence, log_time, publish_time };
        let bytes = message.cdr().with_context(|| format!("encoding {topic:?}"))?;
        self.writer.write_to_known_channel(&header, &bytes)?;
        self.written += 1;
        Ok(())
    }

    /// The first write that failed, if one did.
    fn failed(&mut self) -> anyhow::Result<()> {
        self.error.take().map_or(Ok(()), Err)
    }
}
