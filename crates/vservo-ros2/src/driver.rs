//! `vservo-ros2-driver`: a ros2_control arm (`[robot] driver = "ros2"`) and a ROS camera (`[camera] source =
//! "ros2"`) as the instance's robot and camera drivers (docs/ROS2.md, "ROS 2 as the driver"; the contract is
//! docs/DRIVERS.md's). vservod starts it when either is configured and restarts it if it ends.
//!
//! Each of the arm's joint states, as it arrives: the rmrc's newest command is taken (it answers the state
//! before), sent to the arm's forward controller, and the state is published on `joint_state` and its event
//! (`vservo_ros2::arm_driver` has the rules). Each of the camera's images is published on `camera_image`,
//! stamped with its header's exposure. Nothing here is on the 1 ms path: the rmrc answers the state this
//! process publishes, as it answers any driver's.

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::Context as _;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher as IoxPublisher;
use iceoryx2::port::subscriber::Subscriber as IoxSubscriber;
use iceoryx2::prelude::ipc;
use ros2_client::{MessageTypeName, Name, Node, Publisher, QosProfile, Subscription};
use rustdds::mio1::{Events, Interest, Poll, Token};
use vservo_config::Config;
use vservo_protocol::inbox::TakeMessages;
use vservo_protocol::seal::SealKey;
use vservo_protocol::{CameraImageHeader, CellModeMsg, JointCommandMsg, JointStateMsg, Topic};
use vservo_ros2::arm_driver::{ArmFollower, ArmSettings};
use vservo_ros2::convert::StampClock;
use vservo_ros2::msg::{Float64MultiArray, Image, JointState, RosType};
use vservo_ros2::{image_in, qos};
use vservo_time::monotonic_ns;

const ARM: Token = Token(0);
const CAMERA: Token = Token(1);

/// The longest wait for a message before the watchdog, the stop flag and the clocks are looked at.
const WAKE_EVERY: Duration = Duration::from_millis(1);

/// The most messages of one topic taken in one look: the other topic and the watchdog are looked at between,
/// whatever comes (a failed take consumes its sample, so the loops end, but a flood must not starve the rest).
const MAX_TAKES_PER_LOOK: usize = 64;

/// How often the counts are logged.
const REPORT_EVERY_NS: u64 = 10_000_000_000;

/// How many times the hold command is sent at the end (the controller's reliable reader gets one of them).
const HOLDS_AT_EXIT: usize = 3;

/// Whether this driver is the arm's (`[robot] driver = "ros2"`).
fn drives_arm(config: &Config) -> bool {
    config.cell.robot.driver == vservo_config::RobotDriver::Ros2
}

/// Whether this driver is the camera's (`[camera] source = "ros2"`).
fn drives_camera(config: &Config) -> bool {
    config.cell.vision.source == vservo_config::VisionSource::Ros2
}

/// Runs until `stop` is set.
pub fn run(config: &Config, key: Option<SealKey>, stop: &AtomicBool) -> anyhow::Result<()> {
    let settings = &config.ros2;
    anyhow::ensure!(
        config.runs_ros2_driver(),
        "{}: neither [robot] driver nor [camera] source is \"ros2\": there is nothing for the ROS 2 driver to do",
        config.origin
    );
    let mut ros = RosSide::open(config)?;
    let stopped = || vservo_protocol::signals::stopped(stop);
    let waiting = |why: &_| tracing::info!("instance {:?}: {why}; waiting for vservod", config.instance);
    let Some(dir) = vservo_protocol::InstanceDir::locate_until(&config.instance, stopped, waiting)? else {
        return Ok(());
    };
    let mut cell = CellSide::connect(config, &dir)?;
    let mut driver = Driver::new(config, key);
    let mut poll = Poll::new().context("mio")?;
    ros.register(&poll)?;
    let mut events = Events::with_capacity(8);
    tracing::info!(
        arm = %ros.arm.as_ref().map_or("-", |a| a.topics.as_str()),
        camera = %if drives_camera(config) { config.ros2.driver.image_topic.as_str() } else { "-" },
        "driving the instance {:?} from ROS 2 (domain {})",
        config.instance,
        settings.domain_id
    );
    while !vservo_protocol::signals::stopped(stop) {
        if let Err(error) = poll.poll(&mut events, Some(WAKE_EVERY))
            && error.kind() != std::io::ErrorKind::Interrupted
        {
            return Err(error).context("waiting for ROS 2 messages");
        }
        driver.look(&ros, &mut cell);
    }
    driver.finish(&ros);
    Ok(())
}

/// The arm's topics: its joint states in, its controller's commands out.
struct ArmTopics {
    joint_states: Subscription<JointState>,
    commands: Publisher<Float64MultiArray>,
    /// The joint states' topic, and both, for the log.
    joint_states_topic: String,
    topics: String,
}

/// The driver's node in the ROS 2 graph.
struct RosSide {
    arm: Option<ArmTopics>,
    images: Option<Subscription<Image>>,
    _node: Node,
    _context: ros2_client::Context,
}

impl RosSide {
    fn open(config: &Config) -> anyhow::Result<Self> {
        let settings = &config.ros2;
        let (context, mut node) = vservo_ros2::domain::node(settings, "vservo_driver")?;
        let driver = &settings.driver;
        let arm = if drives_arm(config) {
            Some(ArmTopics {
                joint_states: subscription(&mut node, &driver.joint_states_topic, qos::SENSOR_DATA)?,
                commands: publisher(&mut node, &driver.command_topic, qos::COMMANDS)?,
                joint_states_topic: driver.joint_states_topic.clone(),
                topics: format!("{} → {}", driver.joint_states_topic, driver.command_topic),
            })
        } else {
            None
        };
        let images = drives_camera(config)
            .then(|| subscription(&mut node, &driver.image_topic, qos::SENSOR_DATA))
            .transpose()?;
        Ok(Self { arm, images, _node: node, _context: context })
    }

    /// Wakes `poll` when a joint state or an image arrives.
    fn register(&mut self, poll: &Poll) -> anyhow::Result<()> {
        if let Some(arm) = &mut self.arm {
            poll.registry().register(&mut arm.joint_states, ARM, Interest::READABLE).context("mio")?;
        }
        if let Some(images) = &mut self.images {
            poll.registry().register(images, CAMERA, Interest::READABLE).context("mio")?;
        }
        Ok(())
    }
}

fn ros_name(absolute: &str) -> anyhow::Result<Name> {
    Name::parse(absolute).map_err(|e| anyhow::anyhow!("the ROS name {absolute:?}: {e:?}"))
}

fn subscription<T: RosType + serde::de::DeserializeOwned + 'static>(
    node: &mut Node,
    absolute: &str,
    qos: QosProfile,
) -> anyhow::Result<Subscription<T>> {
    let topic = node
        .create_topic(&ros_name(absolute)?, MessageTypeName::new(T::PACKAGE, T::NAME), &qos)
        .map_err(|e| anyhow::anyhow!("the topic {absolute}: {e:?}"))?;
    node.create_subscription::<T>(&topic, None)
        .map_err(|e| anyhow::anyhow!("subscribing to {absolute}: {e:?}"))
}

fn publisher<T: RosType>(node: &mut Node, absolute: &str, qos: QosProfile) -> anyhow::Result<Publisher<T>> {
    let topic = node
        .create_topic(&ros_name(absolute)?, MessageTypeName::new(T::PACKAGE, T::NAME), &qos)
        .map_err(|e| anyhow::anyhow!("the topic {absolute}: {e:?}"))?;
    node.create_publisher::<T>(&topic, None).map_err(|e| anyhow::anyhow!("publishing on {absolute}: {e:?}"))
}

/// The instance's side: the robot driver's and the camera driver's streams (their one writer slots).
struct CellSide {
    arm: Option<ArmPorts>,
    camera: Option<CameraPorts>,
    _node: iceoryx2::node::Node<ipc::Service>,
}

struct ArmPorts {
    states: IoxPublisher<ipc::Service, JointStateMsg, ()>,
    wake: Notifier<ipc::Service>,
    commands: IoxSubscriber<ipc::Service, JointCommandMsg, ()>,
    modes: IoxSubscriber<ipc::Service, CellModeMsg, ()>,
}

struct CameraPorts {
    images: IoxPublisher<ipc::Service, [u8], CameraImageHeader>,
    wake: Notifier<ipc::Service>,
}

impl CellSide {
    fn connect(config: &Config, dir: &vservo_protocol::InstanceDir) -> anyhow::Result<Self> {
        let instance = config.instance.as_str();
        let node = vservo_protocol::create_node_in(dir, "ros2-driver")?;
        let arm = if drives_arm(config) {
            Some(ArmPorts {
                states: vservo_protocol::publisher(&node, instance, Topic::JointState)
                    .context("the joint_state stream (is another robot driver running?)")?,
                wake: vservo_protocol::notifier(&node, instance, Topic::JointState)?,
                commands: vservo_protocol::subscriber(&node, instance, Topic::JointCommand)?,
                modes: vservo_protocol::subscriber(&node, instance, Topic::CellMode)?,
            })
        } else {
            None
        };
        let camera = if drives_camera(config) {
            Some(CameraPorts {
                images: vservo_protocol::camera_image_publisher(&node, instance)
                    .context("the camera_image stream (is another camera driver running?)")?,
                wake: vservo_protocol::camera_image_notifier(&node, instance)?,
            })
        } else {
            None
        };
        Ok(Self { arm, camera, _node: node })
    }
}

/// What the driver logs: each kind of refusal once (then counted), the counts now and then.
#[derive(Default)]
struct Report {
    said: std::collections::BTreeSet<String>,
    last_ns: u64,
    images: u64,
    images_refused: u64,
    restamped: u64,
    late: u64,
    publish_failed: u64,
    /// Header stamp → arrival here, since the last report: the DDS hop of a joint state; an image's
    /// exposure → arrival (its readout or rendering, and the hop).
    state_age: Ages,
    image_age: Ages,
}

/// The two streams the driver takes.
#[derive(Clone, Copy)]
enum Stream {
    JointStates,
    Images,
}

/// How old messages were when they arrived: count, mean and largest.
#[derive(Default, Clone, Copy)]
struct Ages {
    count: u64,
    sum_ns: i128,
    max_ns: i128,
}

impl Ages {
    fn add(&mut self, age_ns: i128) {
        self.count += 1;
        self.sum_ns += age_ns;
        self.max_ns = if self.count == 1 { age_ns } else { self.max_ns.max(age_ns) };
    }

    /// "mean/max ms", or "-" with none.
    fn text(&self) -> String {
        match self.count {
            0 => "-".to_string(),
            n => format!("{:.2}/{:.2}", self.sum_ns as f64 / n as f64 / 1e6, self.max_ns as f64 / 1e6),
        }
    }
}

impl Report {
    /// A message's stamp: its age counted with its stream's, a replaced or a late stamp counted and said once
    /// per topic.
    fn stamps(&mut self, arrival: &vservo_ros2::convert::Arrival, stream: Stream, topic: &str) {
        match stream {
            Stream::JointStates => self.state_age.add(arrival.age_ns),
            Stream::Images => self.image_age.add(arrival.age_ns),
        }
        let age_s = vservo_time::signed_seconds(arrival.age_ns);
        if arrival.restamped {
            self.restamped += 1;
            self.once(&format!("restamped {topic}"), || {
                format!(
                    "{topic}: a header stamp that is zero, or {:.3} s in the future of its arrival \
                     (ros2.driver.clock_tolerance_s): is the sender's clock ahead of this machine's (chrony, PTP)? \
                     Such messages are stamped with their arrival",
                    -age_s
                )
            });
        } else if arrival.late {
            self.late += 1;
            self.once(&format!("late {topic}"), || {
                format!(
                    "{topic}: a header stamp {age_s:.3} s before its arrival (ros2.driver.clock_tolerance_s): late \
                     data, or the sender's clock behind this machine's (chrony, PTP)? The stamp is kept: an image \
                     this old is dropped by the vision node as stale"
                )
            });
        }
    }

    /// A WARN line the first time something of `kind` happens (`what` says it), then only counted.
    fn once(&mut self, kind: &str, what: impl FnOnce() -> String) {
        if self.said.insert(kind.to_string()) {
            tracing::warn!("{} (said once; counted from now on)", what());
        }
    }
}

/// The driver's state: the arm's rules, the camera's frame counter and buffer, the clocks.
struct Driver {
    arm: Option<ArmFollower>,
    /// When the last joint state came, and the last hold was sent for their absence (ns).
    last_state_ns: u64,
    last_silent_hold_ns: u64,
    hold_after_ns: u64,
    tolerance_ns: u64,
    /// The camera's topic, its image size, and the gray image (made once).
    image_topic: String,
    width: u32,
    height: u32,
    gray: Vec<u8>,
    frame: u64,
    clock: StampClock,
    clock_read_ns: u64,
    report: Report,
}

impl Driver {
    fn new(config: &Config, key: Option<SealKey>) -> Self {
        let now = monotonic_ns();
        let driver = &config.ros2.driver;
        let (width, height) = (config.cell.camera.width_px(), config.cell.camera.height_px());
        Self {
            arm: drives_arm(config).then(|| ArmFollower::new(ArmSettings::of(config), now, key)),
            last_state_ns: now,
            last_silent_hold_ns: 0,
            hold_after_ns: vservo_time::nanos(driver.hold_after_s),
            tolerance_ns: vservo_time::nanos(driver.clock_tolerance_s),
            image_topic: driver.image_topic.clone(),
            width,
            height,
            gray: vec![0; width as usize * height as usize],
            frame: 0,
            clock: StampClock::now(),
            clock_read_ns: now,
            report: Report { last_ns: now, ..Report::default() },
        }
    }

    /// Everything that arrived, passed on; the watchdog; the clocks and the log.
    fn look(&mut self, ros: &RosSide, cell: &mut CellSide) {
        if let (Some(topics), Some(ports)) = (&ros.arm, &cell.arm) {
            self.joint_states(topics, ports);
        }
        if let (Some(images), Some(ports)) = (&ros.images, &cell.camera) {
            self.images(images, ports);
        }
        let now = monotonic_ns();
        if now - self.clock_read_ns > vservo_time::NANOS_PER_SECOND {
            (self.clock, self.clock_read_ns) = (StampClock::now(), now);
        }
        if now - self.report.last_ns > REPORT_EVERY_NS {
            self.log_counts("running");
            self.report.last_ns = now;
            (self.report.state_age, self.report.image_age) = (Ages::default(), Ages::default());
        }
    }

    /// Each joint state: the newest command to the controller, the state to vservo. With none for the hold
    /// time: rest to the controller (the arm's driver may have stalled, and its controller holds the last
    /// command for ever).
    fn joint_states(&mut self, topics: &ArmTopics, ports: &ArmPorts) {
        let Some(arm) = &mut self.arm else { return };
        for _ in 0..MAX_TAKES_PER_LOOK {
            let (message, _info) = match topics.joint_states.take() {
                Ok(Some(taken)) => taken,
                Ok(None) => break,
                Err(error) => {
                    self.report
                        .once("unreadable state", || format!("a joint state could not be read: {error:?}"));
                    continue;
                }
            };
            let now = monotonic_ns();
            let mut other_schema = 0;
            if let Some(mode) = ports.modes.newest_message(&mut other_schema) {
                arm.cell_mode(&mode);
            }
            let report = &mut self.report;
            let other_schema = ports.commands.each_message(|command| {
                if let Some(refused) = arm.take_command(&command, now) {
                    report.once(refused.kind(), || format!("a joint_command refused: {refused}"));
                }
            });
            if other_schema > 0 {
                arm.counts.commands_refused += other_schema;
                self.report.once("command of another schema", || {
                    "a joint_command of another schema (another build of vservo?) was refused".to_string()
                });
            }
            let arrival = self.clock.arrival(&message.header.stamp, now, self.tolerance_ns);
            self.report.stamps(&arrival, Stream::JointStates, &topics.joint_states_topic);
            match arm.on_joint_state(&message, arrival.stamp_ns, now) {
                Ok(step) => {
                    if let Some(median_ns) = arm.period_mismatch_ns() {
                        self.report.once("period", || {
                            format!(
                                "{}: the arm's joint states come every {:.3} ms (median), not every [robot] \
                                 period_s = {:.3} ms: the driver reports a fault and holds the arm; set period_s \
                                 to the arm's period",
                                topics.topics,
                                median_ns as f64 / 1e6,
                                arm.period_ns() as f64 / 1e6
                            )
                        });
                    }
                    if topics.commands.publish(command_message(step.command)).is_err() {
                        self.report.publish_failed += 1;
                    }
                    let _ = ports.states.send_copy(step.state);
                    let _ = ports.wake.notify();
                    self.last_state_ns = now;
                }
                Err(refused) => {
                    self.report
                        .once(refused.kind(), || format!("a joint state of {} {refused}", topics.topics));
                }
            }
        }
        let now = monotonic_ns();
        let silent = now - self.last_state_ns > self.hold_after_ns;
        if silent && now - self.last_silent_hold_ns > self.hold_after_ns {
            send_rest(arm, topics);
            self.last_silent_hold_ns = now;
        }
    }

    /// Each image: as 8-bit gray onto `camera_image`, stamped with its exposure.
    fn images(&mut self, images: &Subscription<Image>, ports: &CameraPorts) {
        for _ in 0..MAX_TAKES_PER_LOOK {
            let image = match images.take() {
                Ok(Some((image, _info))) => image,
                Ok(None) => break,
                Err(error) => {
                    self.report.once("unreadable image", || format!("an image could not be read: {error:?}"));
                    continue;
                }
            };
            let now = monotonic_ns();
            if let Err(refused) = image_in::to_gray8(&image, self.width, self.height, &mut self.gray) {
                self.report.images_refused += 1;
                self.report.once(refused.kind(), || format!("an image {refused}"));
                continue;
            }
            let arrival = self.clock.arrival(&image.header.stamp, now, self.tolerance_ns);
            self.report.stamps(&arrival, Stream::Images, &self.image_topic);
            self.publish_image(ports, arrival.stamp_ns);
        }
    }

    fn publish_image(&mut self, ports: &CameraPorts, capture_stamp_ns: u64) {
        let size = (self.width, self.height);
        // sensor_msgs/Image carries no exposure or gain
        let exposure = vservo_protocol::Exposure::UNKNOWN;
        if !vservo_protocol::publish_mono8(
            &ports.images,
            size,
            &self.gray,
            (self.frame, capture_stamp_ns),
            exposure,
        ) {
            self.report.publish_failed += 1;
            return;
        }
        let _ = ports.wake.notify();
        self.frame += 1;
        self.report.images += 1;
    }

    /// At the end: the arm commanded to rest.
    fn finish(&mut self, ros: &RosSide) {
        if let (Some(arm), Some(topics)) = (&mut self.arm, &ros.arm) {
            for _ in 0..HOLDS_AT_EXIT {
                send_rest(arm, topics);
                std::thread::sleep(Duration::from_millis(2));
            }
        }
        self.log_counts("stopped (SIGINT/SIGTERM); the arm commanded to rest");
    }

    fn log_counts(&self, what: &str) {
        let arm = self.arm.as_ref().map(|a| a.counts).unwrap_or_default();
        tracing::info!(
            states = arm.states,
            states_refused = arm.states_refused,
            commands_taken = arm.commands_taken,
            commands_refused = arm.commands_refused,
            holds = arm.holds,
            images = self.report.images,
            images_refused = self.report.images_refused,
            restamped = self.report.restamped,
            late = self.report.late,
            publish_failed = self.report.publish_failed,
            state_age_ms = %self.report.state_age.text(),
            image_age_ms = %self.report.image_age.text(),
            "{what} (ages: header stamp → arrival, mean/max since the last report)"
        );
    }
}

/// The arm commanded to rest ([`ArmFollower::hold`]), if there is a rest to command.
fn send_rest(arm: &mut ArmFollower, topics: &ArmTopics) {
    if let Some(rest) = arm.hold() {
        let _ = topics.commands.publish(command_message(rest));
    }
}

/// A forward controller's command: the values, in the controller's joint order, with no layout (as
/// `ros2 topic pub` sends one).
fn command_message(data: Vec<f64>) -> Float64MultiArray {
    Float64MultiArray { data, ..Float64MultiArray::default() }
}
