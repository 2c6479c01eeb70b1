//! `vservoctl echo TOPIC`: prints a running instance's messages as JSON lines.

use std::time::{Duration, Instant};

use clap::Args;
use serde_json::Value;
use vservo_protocol::Topic;

use crate::instance::{Connection, InstanceArg};
use crate::json_messages::{
    camera_twist, features, gains, joint_command, joint_state, object, sim_world, status, telemetry,
};
use crate::output::print_stdout;

/// Arguments of `vservoctl echo`.
#[derive(Args, Debug)]
pub struct EchoArgs {
    /// Which service: joint_state, joint_command, sim_world, features, camera_twist, telemetry, status, gains or object
    /// (joint_state, joint_command and sim_world come at the driver's rate: a slow terminal drops samples).
    #[arg(value_parser = topic_name)]
    topic: Topic,
    #[command(flatten)]
    instance: InstanceArg,
    /// Stop after this many messages.
    #[arg(long)]
    count: Option<u64>,
    /// Stop after this long (s).
    #[arg(long)]
    duration_s: Option<f64>,
}

fn echo<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static>(
    connection: &Connection,
    topic: Topic,
    args: &EchoArgs,
    render: fn(&T) -> Value,
) -> anyhow::Result<()> {
    let subscriber = connection.subscriber::<T>(topic)?;
    let until = args.duration_s.map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
    let mut printed = 0u64;
    loop {
        while let Some(sample) = subscriber.receive()? {
            print_stdout(&format!("{}\n", render(&sample)))?;
            printed += 1;
            if args.count.is_some_and(|n| printed >= n) {
                return Ok(());
            }
        }
        if until.is_some_and(|u| Instant::now() >= u) {
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn topic_name(name: &str) -> Result<Topic, String> {
    Topic::ALL.into_iter().find(|t| t.name() == name).ok_or_else(|| {
        let names: Vec<&str> = Topic::ALL.iter().map(|t| t.name()).collect();
        format!("expected one of {}", names.join(", "))
    })
}

pub fn run(args: &EchoArgs) -> anyhow::Result<()> {
    let connection = Connection::open(&args.instance)?;
    let topic = args.topic;
    match topic {
        Topic::JointState => echo(&connection, topic, args, joint_state),
        Topic::JointCommand => echo(&connection, topic, args, joint_command),
        Topic::SimWorld => echo(&connection, topic, args, sim_world),
        Topic::Features => echo(&connection, topic, args, features),
        Topic::CameraTwist => echo(&connection, topic, args, camera_twist),
        Topic::Telemetry => echo(&connection, topic, args, telemetry),
        Topic::Status => echo(&connection, topic, args, status),
        Topic::Gains => echo(&connection, topic, args, gains),
        Topic::Object => echo(&connection, topic, args, object),
    }
}
