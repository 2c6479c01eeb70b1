//! `vservoctl echo TOPIC`: prints a running instance's messages as JSON lines.

use std::time::{Duration, Instant};

use clap::Args;
use serde_json::Value;
use vservo_protocol::{
    CameraTwistMsg, CellModeMsg, DaemonStatusMsg, FeaturesMsg, GainsMsg, JointCommandMsg, JointStateMsg,
    ObjectMsg, SimWorldMsg, TelemetryMsg, Topic, WireField,
};

use crate::instance::{Connection, InstanceArg, WAIT_FOR_SERVICE, when_there};
use crate::output::print_stdout;

/// Arguments of `vservoctl echo`.
#[derive(Args, Debug)]
pub struct EchoArgs {
    /// Which service: joint_state, joint_command, sim_world, features, camera_twist, telemetry, status, gains,
    /// object, or camera_image (its header, size and mean gray level; not the pixels). joint_state,
    /// joint_command and sim_world come at the driver's rate: a slow terminal drops samples.
    #[arg(value_parser = service_name)]
    service: Service,
    #[command(flatten)]
    instance: InstanceArg,
    /// Stop after this many messages.
    #[arg(long)]
    count: Option<u64>,
    /// Stop after this long (s).
    #[arg(long, value_parser = crate::seconds_arg::seconds)]
    duration_s: Option<f64>,
}

/// Prints a topic's messages as their declaration's JSON view.
fn echo<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + WireField + 'static>(
    connection: &Connection,
    topic: Topic,
    args: &EchoArgs,
) -> anyhow::Result<()> {
    let until = args.duration_s.map(|s| Instant::now() + Duration::from_secs_f64(s));
    let subscriber = when_there(until, || connection.subscriber::<T>(topic))?;
    print_lines(args, until, || Ok(subscriber.receive()?.map(|sample| sample.to_json())))
}

/// Prints what `next` yields as JSON lines, polling every millisecond, until `--count` lines are out or
/// `until` has passed.
fn print_lines(
    args: &EchoArgs,
    until: Option<Instant>,
    mut next: impl FnMut() -> anyhow::Result<Option<Value>>,
) -> anyhow::Result<()> {
    // SIGINT and SIGTERM end it cleanly: the node's resources go with it
    let stop = vservo_protocol::signals::stop_flag()?;
    let mut printed = 0u64;
    while !vservo_protocol::signals::stopped(&stop) {
        while let Some(line) = next()? {
            print_stdout(&format!("{line}\n"))?;
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
    Ok(())
}

/// A service `echo` prints.
#[derive(Debug, Clone, Copy)]
enum Service {
    /// A topic with a fixed-size payload.
    Topic(Topic),
    /// `camera_image`: a slice with a header.
    CameraImage,
}

fn service_name(name: &str) -> Result<Service, String> {
    if name == vservo_protocol::CAMERA_IMAGE_SERVICE {
        return Ok(Service::CameraImage);
    }
    Topic::ALL.into_iter().find(|t| t.name() == name).map(Service::Topic).ok_or_else(|| {
        let names: Vec<&str> = Topic::ALL.iter().map(|t| t.name()).collect();
        format!("expected one of {}, {}", names.join(", "), vservo_protocol::CAMERA_IMAGE_SERVICE)
    })
}

/// `camera_image`: each frame's header, its size and its mean gray level.
fn echo_images(connection: &Connection, args: &EchoArgs) -> anyhow::Result<()> {
    let subscriber = vservo_protocol::camera_image_subscriber(
        &connection.node,
        &connection.instance,
        vservo_protocol::Opening::OpenOnly,
    )?;
    let until = args.duration_s.map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
    print_lines(args, until, || {
        let Some(sample) = subscriber.receive()? else { return Ok(None) };
        let h = sample.user_header();
        let pixels = sample.payload();
        let mean = pixels.iter().map(|&p| f64::from(p)).sum::<f64>() / pixels.len().max(1) as f64;
        let mut line = h.to_json();
        if let Value::Object(fields) = &mut line {
            fields.insert("bytes".into(), pixels.len().into());
            fields.insert("mean_gray".into(), mean.into());
        }
        Ok(Some(line))
    })
}

pub fn run(args: &EchoArgs) -> anyhow::Result<()> {
    // a daemon still starting may not have made the instance's directory yet
    let give_up =
        Instant::now() + args.duration_s.map_or(WAIT_FOR_SERVICE, |s| Duration::from_secs_f64(s.max(0.0)));
    let connection = Connection::open_when_there(&args.instance, || Instant::now() >= give_up)?;
    let topic = match args.service {
        Service::Topic(topic) => topic,
        Service::CameraImage => return echo_images(&connection, args),
    };
    match topic {
        Topic::JointState => echo::<JointStateMsg>(&connection, topic, args),
        Topic::JointCommand => echo::<JointCommandMsg>(&connection, topic, args),
        Topic::SimWorld => echo::<SimWorldMsg>(&connection, topic, args),
        Topic::Features => echo::<FeaturesMsg>(&connection, topic, args),
        Topic::CameraTwist => echo::<CameraTwistMsg>(&connection, topic, args),
        Topic::Telemetry => echo::<TelemetryMsg>(&connection, topic, args),
        Topic::Status => echo::<DaemonStatusMsg>(&connection, topic, args),
        Topic::Gains => echo::<GainsMsg>(&connection, topic, args),
        Topic::Object => echo::<ObjectMsg>(&connection, topic, args),
        Topic::CellMode => echo::<CellModeMsg>(&connection, topic, args),
    }
}
