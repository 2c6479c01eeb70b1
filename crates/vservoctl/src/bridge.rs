//! From an instance's services to a sink of channels (an MCAP file for `vservoctl record`, the live
//! view's WebSocket server for `vservoctl view`): every service as JSON with a JSON schema, and the cell as
//! Foxglove shows it ([`vservo_view::drawing`]): the camera's images, the marks on them, the frames of the arm,
//! the camera and the board, and the collision guard's obstacles coloured by the status's nearest pair
//! ([`vservo_view::obstacles`]). A bridge only opens services (it never creates them) and reads them with
//! iceoryx2's safe overflow: a slow bridge loses its oldest samples, it never slows the loop.

use std::collections::BTreeMap;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ZeroCopySend, ipc};
use serde_json::Value;
use vservo_protocol::{
    CameraImageHeader, CameraTwistMsg, CellModeMsg, DaemonStatusMsg, FeaturesMsg, GainsMsg, JointCommandMsg,
    JointStateMsg, ObjectMsg, SimWorldMsg, TelemetryMsg, Topic, WireField,
};

use crate::instance::{Connection, InstanceArg};
pub use vservo_view::ChannelSpec;
use vservo_view::drawing;
use vservo_view::obstacles::{GuardedScene, Nearest, OBSTACLES_TOPIC};

/// Where the bridge's messages go.
pub trait Sink {
    /// Declares a channel; messages are then written by its topic.
    fn add_channel(&mut self, spec: ChannelSpec<'_>) -> anyhow::Result<()>;
    /// One message: its bytes, the wall-clock time it was received (ns since 1970) and its own stamp.
    fn write(&mut self, topic: &str, bytes: &[u8], log_ns: u64, publish_ns: u64) -> anyhow::Result<()>;
}

/// Transforms of the arm at most this often (the joint states come every ms).
const TRANSFORMS_EVERY_NS: u64 = 20_000_000;
/// The obstacles again at least this often (for a viewer that joins late), and whenever their colours change.
const OBSTACLES_EVERY_NS: u64 = vservo_time::NANOS_PER_SECOND;

fn wall_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

/// The bridge's state: the sink, and what the Foxglove view of a message needs from earlier ones.
pub struct Bridge<S: Sink> {
    pub sink: S,
    pub written: u64,
    /// ξ_d, from the latest `gains`.
    desired_px: Option<[f64; 8]>,
    /// The arm configured and where the camera sits on its hand, from the instance's configuration file
    /// (no arm is drawn when it could not be read: any other would be drawn wrongly).
    drawing: Option<CellDrawing>,
    last_transforms_ns: u64,
    last_state_stamp_ns: u64,
    /// When the obstacles were last written (status stamp, ns) and how near each was then.
    last_obstacles: Option<(u64, Vec<vservo_view::obstacles::Nearness>)>,
    image_every: u64,
}

impl<S: Sink> Bridge<S> {
    /// A bridge of the instance's services into `sink`, which gets every channel now.
    pub fn new(
        mut sink: S,
        connection: &Connection,
        instance: &InstanceArg,
        image_every: u64,
    ) -> anyhow::Result<Self> {
        for topic in Topic::ALL {
            let schema = serde_json::json!({"type": "object", "title": topic.type_name()}).to_string();
            let metadata = BTreeMap::from([
                ("type_name".to_string(), topic.type_name().to_string()),
                ("schema_version".to_string(), vservo_protocol::SCHEMA_VERSION.to_string()),
                (
                    "publish_time".to_string(),
                    "the message's stamp_ns: CLOCK_MONOTONIC of the host (0: none)".to_string(),
                ),
            ]);
            sink.add_channel(ChannelSpec {
                topic: &topic.service_name(&connection.instance),
                schema_name: topic.type_name(),
                schema_encoding: "jsonschema",
                schema: schema.as_bytes(),
                message_encoding: "json",
                metadata,
            })?;
        }
        let mut bridge = Self {
            sink,
            written: 0,
            desired_px: None,
            drawing: cell_drawing(instance, &connection.instance)
                .inspect_err(|why| eprintln!("vservoctl: the arm is not drawn: {why:#}"))
                .ok(),
            last_transforms_ns: 0,
            last_state_stamp_ns: 0,
            last_obstacles: None,
            image_every,
        };
        bridge.add_foxglove_channel::<foxglove::messages::RawImage>(drawing::IMAGE_TOPIC)?;
        bridge.add_foxglove_channel::<foxglove::messages::ImageAnnotations>(drawing::ANNOTATIONS_TOPIC)?;
        bridge.add_foxglove_channel::<foxglove::messages::FrameTransforms>(drawing::TRANSFORMS_TOPIC)?;
        if let Some(scene) = bridge.drawing.as_ref().and_then(|d| d.scene.as_ref()) {
            let update = scene.update(None, 0);
            bridge.add_foxglove_channel::<foxglove::messages::SceneUpdate>(OBSTACLES_TOPIC)?;
            bridge.write_foxglove(OBSTACLES_TOPIC, &update, 0)?;
        }
        Ok(bridge)
    }

    fn write(&mut self, topic: &str, bytes: &[u8], publish_ns: u64) -> anyhow::Result<()> {
        self.sink.write(topic, bytes, wall_ns(), publish_ns)?;
        self.written += 1;
        Ok(())
    }

    fn write_foxglove<M: foxglove::Encode>(
        &mut self,
        topic: &str,
        message: &M,
        publish_ns: u64,
    ) -> anyhow::Result<()> {
        let mut bytes = Vec::with_capacity(message.encoded_len().unwrap_or(256));
        message.encode(&mut bytes).map_err(|e| anyhow::anyhow!("encoding {topic}: {e}"))?;
        self.write(topic, &bytes, publish_ns)
    }

    fn add_foxglove_channel<M: foxglove::Encode>(&mut self, topic: &str) -> anyhow::Result<()> {
        let schema = M::get_schema().with_context(|| format!("{topic}: no schema"))?;
        self.sink.add_channel(ChannelSpec {
            topic,
            schema_name: &schema.name,
            schema_encoding: &schema.encoding,
            schema: &schema.data,
            message_encoding: &M::get_message_encoding(),
            metadata: BTreeMap::new(),
        })
    }

    /// Runs until `stop()` says so: opens what exists every 0.1 s (a daemon still starting, a node not up;
    /// a service the cell does not have, such as sim_world with an external robot, is simply never heard)
    /// and writes what arrived every 0.5 ms.
    pub fn run(&mut self, connection: &Connection, mut stop: impl FnMut() -> bool) -> anyhow::Result<()> {
        let mut taps: Vec<Box<dyn Tapped<S>>> = vec![
            Tap::<JointStateMsg>::boxed(Topic::JointState, WireField::to_json, |m| m.stamp_ns),
            Tap::<JointCommandMsg>::boxed(Topic::JointCommand, WireField::to_json, |m| m.stamp_ns),
            Tap::<SimWorldMsg>::boxed(Topic::SimWorld, WireField::to_json, |_| 0),
            Tap::<FeaturesMsg>::boxed(Topic::Features, WireField::to_json, |m| m.stamp_ns),
            Tap::<CameraTwistMsg>::boxed(Topic::CameraTwist, WireField::to_json, |m| m.stamp_ns),
            Tap::<TelemetryMsg>::boxed(Topic::Telemetry, WireField::to_json, |m| m.stamp_ns),
            Tap::<DaemonStatusMsg>::boxed(Topic::Status, WireField::to_json, |m| m.stamp_ns),
            Tap::<GainsMsg>::boxed(Topic::Gains, WireField::to_json, |_| 0),
            Tap::<ObjectMsg>::boxed(Topic::Object, WireField::to_json, |_| 0),
            Tap::<CellModeMsg>::boxed(Topic::CellMode, WireField::to_json, |m| m.stamp_ns),
        ];
        if self.image_every > 0 {
            taps.push(Box::new(ImageTap { subscriber: None, every: self.image_every }));
        }
        let mut next_look = Instant::now();
        while !stop() {
            let look = Instant::now() >= next_look;
            if look {
                next_look = Instant::now() + Duration::from_millis(100);
            }
            for tap in &mut taps {
                if look {
                    tap.open(connection);
                }
                tap.drain(self)?;
            }
            std::thread::sleep(Duration::from_micros(500));
        }
        Ok(())
    }
}

/// What the Foxglove view adds for a message of the instance's services.
trait Viewed: Sized {
    fn view<S: Sink>(&self, _bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        Ok(())
    }
}

impl Viewed for JointStateMsg {
    fn view<S: Sink>(&self, bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        bridge.last_state_stamp_ns = self.stamp_ns;
        if self.stamp_ns.saturating_sub(bridge.last_transforms_ns) < TRANSFORMS_EVERY_NS {
            return Ok(());
        }
        bridge.last_transforms_ns = self.stamp_ns;
        let Some(drawing) = &bridge.drawing else { return Ok(()) };
        let transforms = drawing::arm_transforms(&drawing.arm, &drawing.mount, self);
        bridge.write_foxglove(drawing::TRANSFORMS_TOPIC, &transforms, self.stamp_ns)
    }
}

impl Viewed for FeaturesMsg {
    fn view<S: Sink>(&self, bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        let drawn = drawing::annotations(self, bridge.desired_px.as_ref());
        bridge.write_foxglove(drawing::ANNOTATIONS_TOPIC, &drawn, self.stamp_ns)
    }
}

impl Viewed for GainsMsg {
    fn view<S: Sink>(&self, bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        bridge.desired_px = Some(self.desired_features_px);
        Ok(())
    }
}

impl Viewed for SimWorldMsg {
    fn view<S: Sink>(&self, bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        // the board moves slowly if at all: with the arm's transforms
        if bridge.last_transforms_ns != bridge.last_state_stamp_ns {
            return Ok(());
        }
        let board = drawing::board_transform(self, bridge.last_state_stamp_ns);
        bridge.write_foxglove(drawing::TRANSFORMS_TOPIC, &board, bridge.last_state_stamp_ns)
    }
}

impl Viewed for DaemonStatusMsg {
    /// The obstacles, coloured by the nearest pair the status names: when that changes, and every second.
    fn view<S: Sink>(&self, bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        let Some(scene) = bridge.drawing.as_ref().and_then(|d| d.scene.as_ref()) else { return Ok(()) };
        let between = String::from_utf8_lossy(&self.clearance_between).trim_end_matches('\0').to_string();
        let nearest = self
            .clearance_m
            .is_finite()
            .then_some(Nearest { between: &between, distance_m: self.clearance_m });
        // the workspace's colour too (it has no name drawn)
        let key = scene.nearnesses(nearest);
        let due = match &bridge.last_obstacles {
            Some((at_ns, last_key)) => {
                *last_key != key || self.stamp_ns.saturating_sub(*at_ns) >= OBSTACLES_EVERY_NS
            }
            None => true,
        };
        if !due {
            return Ok(());
        }
        bridge.last_obstacles = Some((self.stamp_ns, key));
        let update = scene.update(nearest, self.stamp_ns);
        bridge.write_foxglove(OBSTACLES_TOPIC, &update, self.stamp_ns)
    }
}

impl Viewed for JointCommandMsg {}
impl Viewed for CameraTwistMsg {}
impl Viewed for TelemetryMsg {}
impl Viewed for ObjectMsg {}
impl Viewed for CellModeMsg {}

fn drain<T: Copy + std::fmt::Debug + ZeroCopySend + Viewed, S: Sink>(
    subscriber: &Subscriber<ipc::Service, T, ()>,
    service: &str,
    render: fn(&T) -> Value,
    stamp_ns: fn(&T) -> u64,
    bridge: &mut Bridge<S>,
) -> anyhow::Result<()> {
    while let Some(sample) = subscriber.receive()? {
        let message = *sample;
        bridge.write(service, render(&message).to_string().as_bytes(), stamp_ns(&message))?;
        message.view(bridge)?;
    }
    Ok(())
}

/// What drawing the cell needs from its configuration.
struct CellDrawing {
    /// The arm configured (`[robot.arm]`).
    arm: vservo_arm::SerialArm,
    /// Where the camera is: on the hand, or fixed in the world.
    mount: vservo_scene::CameraMount,
    /// What the collision guard keeps the arm off (`[collision]` given).
    scene: Option<GuardedScene>,
}

/// The arm and camera mount of the instance: from the configuration its daemon runs, else from
/// `--config` (else config/vservo.toml).
fn cell_drawing(instance: &InstanceArg, name: &str) -> anyhow::Result<CellDrawing> {
    let config = instance.configuration_in_force(name)?;
    let mount = config.cell.mount();
    let scene = config.cell.collision.as_ref().map(|collision| GuardedScene {
        obstacles: collision.obstacles.clone(),
        workspace: collision.workspace,
        slowdown_distance_m: collision.slowdown_distance_m,
        stop_distance_m: collision.stop_distance_m,
    });
    Ok(CellDrawing { arm: config.cell.arm, mount, scene })
}

/// One service: its subscriber once the service exists.
struct Tap<T: std::fmt::Debug + ZeroCopySend + 'static> {
    topic: Topic,
    subscriber: Option<Subscriber<ipc::Service, T, ()>>,
    service: String,
    render: fn(&T) -> Value,
    stamp_ns: fn(&T) -> u64,
}

impl<T: Copy + std::fmt::Debug + ZeroCopySend + Viewed + 'static> Tap<T> {
    fn boxed<S: Sink>(topic: Topic, render: fn(&T) -> Value, stamp_ns: fn(&T) -> u64) -> Box<dyn Tapped<S>> {
        Box::new(Self { topic, subscriber: None, service: String::new(), render, stamp_ns })
    }
}

/// What the bridge does with each service, whatever its payload.
trait Tapped<S: Sink> {
    /// Opens the service if it exists now and is not open yet.
    fn open(&mut self, connection: &Connection);
    /// Writes what arrived since the last call.
    fn drain(&mut self, bridge: &mut Bridge<S>) -> anyhow::Result<()>;
}

impl<T: Copy + std::fmt::Debug + ZeroCopySend + Viewed + 'static, S: Sink> Tapped<S> for Tap<T> {
    fn open(&mut self, connection: &Connection) {
        if self.subscriber.is_none() {
            self.subscriber = connection.subscriber::<T>(self.topic).ok();
            self.service = self.topic.service_name(&connection.instance);
        }
    }

    fn drain(&mut self, bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        match &self.subscriber {
            Some(subscriber) => drain(subscriber, &self.service, self.render, self.stamp_ns, bridge),
            None => Ok(()),
        }
    }
}

/// The camera's images, every n-th, as `foxglove.RawImage`.
struct ImageTap {
    subscriber: Option<Subscriber<ipc::Service, [u8], CameraImageHeader>>,
    every: u64,
}

impl<S: Sink> Tapped<S> for ImageTap {
    fn open(&mut self, connection: &Connection) {
        if self.subscriber.is_none() {
            self.subscriber = vservo_protocol::camera_image_subscriber(
                &connection.node,
                &connection.instance,
                vservo_protocol::Opening::OpenOnly,
            )
            .ok();
        }
    }

    fn drain(&mut self, bridge: &mut Bridge<S>) -> anyhow::Result<()> {
        let Some(subscriber) = &self.subscriber else { return Ok(()) };
        while let Some(sample) = subscriber.receive()? {
            let header = *sample.user_header();
            if header.frame % self.every == 0 {
                let image = drawing::raw_image(&header, sample.payload());
                bridge.write_foxglove(drawing::IMAGE_TOPIC, &image, header.capture_stamp_ns)?;
            }
        }
        Ok(())
    }
}
