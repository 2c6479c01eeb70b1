//! The validated sections of a [`crate::Config`], one type each, every value in range (the checks are in
//! `validate/`, one module per section).

use std::time::Duration;

use nalgebra::Vector3;
use vservo_arm::JointVector;
use vservo_scene::{FeatureVector, IsometryMatrix3, MarkDepths};
use vservo_settings::{
    control::ControlLaw,
    weights::{InputWeight, StateWeight},
};

/// `[viewer]`: vservod serves the running cell live to Foxglove over its WebSocket protocol (a
/// `vservoctl view` process it starts and stops; a client of the instance like any other). Optional in the
/// file: off, and on localhost only, by default.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Viewer {
    /// Whether vservod starts the viewer.
    pub enabled: bool,
    /// The address it serves on (an IP address; `127.0.0.1` by default, reached from another machine over
    /// SSH: `ssh -L 8765:localhost:8765 host`).
    pub address: String,
    /// The TCP port.
    pub port: u16,
    /// The most viewers connected at once (each one more is refused with HTTP 503).
    pub max_clients: u32,
}

/// `[ros2]`: vservod starts `vservo-ros2`, the bridge to a ROS 2 graph over DDS (docs/ROS2.md), a client of
/// the instance like any other. Optional in the file: off by default; on, it publishes but takes nothing that
/// moves the arm unless `allow_motion`.
#[derive(Debug, Clone, PartialEq)]
pub struct Ros2 {
    /// Whether vservod starts the bridge.
    pub enabled: bool,
    /// The DDS domain (ROS_DOMAIN_ID), 0–232.
    pub domain_id: u16,
    /// The ROS namespace of the bridge's topics and services: empty (none) or `/name[/name…]`.
    pub namespace: String,
    /// The one interface DDS uses, by its IP address (`127.0.0.1`: this machine only); `None`: every
    /// interface.
    pub interface: Option<std::net::IpAddr>,
    /// What the bridge publishes.
    pub publish: Vec<Ros2Topic>,
    /// The camera's images: every n-th frame (1: all).
    pub image_every: u32,
    /// `joint_states` and the arm's `tf` at most this often (Hz; the driver's rate at most).
    pub joint_state_rate_hz: f64,
    /// The arm's joint names in ROS (a URDF's, for `robot_state_publisher`), from the base outwards; empty:
    /// `joint1` … `jointN`.
    pub joint_names: Vec<String>,
    /// Whether the ROS graph may move the arm (`resume`, targets); `safe_stop` is always taken.
    pub allow_motion: bool,
    /// The arm and the camera vservo takes from the ROS 2 graph (`[robot] driver = "ros2"`, `[camera] source =
    /// "ros2"`): `vservo-ros2-driver`, which vservod starts.
    pub driver: Ros2Driver,
    /// The topics whose QoS is written (`[ros2.qos.<topic>]`), each once.
    pub qos: Vec<(Ros2Topic, TopicQos)>,
}

impl Ros2 {
    /// What is written of `topic`'s QoS (nothing: the bridge's default).
    pub fn qos_of(&self, topic: Ros2Topic) -> TopicQos {
        self.qos.iter().find(|(t, _)| *t == topic).map_or(TopicQos::default(), |(_, qos)| *qos)
    }
}

/// `[ros2.driver]`: a ros2_control arm and a ROS camera as vservo's robot and camera drivers (docs/ROS2.md,
/// "ROS 2 as the driver"). The topics are absolute ROS names (a relative one in the file is resolved in
/// `[ros2] namespace`).
#[derive(Debug, Clone, PartialEq)]
pub struct Ros2Driver {
    /// The arm's `sensor_msgs/JointState` (its `joint_state_broadcaster`'s).
    pub joint_states_topic: String,
    /// The `std_msgs/Float64MultiArray` a forward velocity or position controller takes, in `joint_names` order.
    pub command_topic: String,
    /// The camera's `sensor_msgs/Image`.
    pub image_topic: String,
    /// No valid command from vservo for this long (s): the driver commands rest (zero velocities, or the
    /// position where holding began) and reports itself holding; also when no joint state comes.
    pub hold_after_s: f64,
    /// A header stamp more than this (s) in the future of its arrival on this machine's clock is replaced by
    /// the arrival; one older than this is kept and flagged (late data, or the hosts' clocks not in step).
    pub clock_tolerance_s: f64,
}

/// A topic the ROS 2 bridge can publish (`[ros2] publish`), by its name in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ros2Topic {
    /// `joint_states` (`sensor_msgs/JointState`).
    JointStates,
    /// `tf` (`tf2_msgs/TFMessage`): the arm's moving links and the target as seen.
    Tf,
    /// `tf_static` (`tf2_msgs/TFMessage`, transient local): what does not move, the tool on the last link and
    /// the camera's optical frame on the tool.
    TfStatic,
    /// `camera/image_raw` (`sensor_msgs/Image`).
    Image,
    /// `camera/camera_info` (`sensor_msgs/CameraInfo`).
    CameraInfo,
    /// `vservo/features` (`std_msgs/Float64MultiArray`).
    Features,
    /// `vservo/camera_twist` (`geometry_msgs/TwistStamped`).
    CameraTwist,
    /// `diagnostics` (`diagnostic_msgs/DiagnosticArray`).
    Diagnostics,
    /// `vservo/obstacles` (`visualization_msgs/MarkerArray`, transient local): the collision guard's obstacles
    /// and workspace box, once.
    Obstacles,
}

/// A topic's reliability (`[ros2.qos.<topic>] reliability`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QosReliability {
    /// Reliable: heard by reliable and best-effort subscribers (the bridge never blocks on a slow one).
    Reliable,
    /// Best effort: heard by best-effort subscribers only.
    BestEffort,
}

/// A topic's durability (`[ros2.qos.<topic>] durability`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QosDurability {
    /// Only what is sent while a subscriber is there.
    Volatile,
    /// A subscriber that joins later gets the last `depth` samples.
    TransientLocal,
}

/// `[ros2.qos.<topic>]`: a topic's QoS where it differs from the bridge's default (docs/ROS2.md); what is not
/// written is the default's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TopicQos {
    /// Reliable or best effort.
    pub reliability: Option<QosReliability>,
    /// Volatile or transient local.
    pub durability: Option<QosDurability>,
    /// The history kept (the last `depth` samples), 1–1000.
    pub depth: Option<u32>,
}

impl Ros2Topic {
    /// Its name in the file (`[ros2] publish`, `[ros2.qos.<name>]`).
    pub fn name(self) -> &'static str {
        match self {
            Ros2Topic::JointStates => "joint_states",
            Ros2Topic::Tf => "tf",
            Ros2Topic::TfStatic => "tf_static",
            Ros2Topic::Image => "image",
            Ros2Topic::CameraInfo => "camera_info",
            Ros2Topic::Features => "features",
            Ros2Topic::CameraTwist => "camera_twist",
            Ros2Topic::Diagnostics => "diagnostics",
            Ros2Topic::Obstacles => "obstacles",
        }
    }

    /// Every topic, the default.
    pub const ALL: [Ros2Topic; 9] = [
        Ros2Topic::JointStates,
        Ros2Topic::Tf,
        Ros2Topic::TfStatic,
        Ros2Topic::Image,
        Ros2Topic::CameraInfo,
        Ros2Topic::Features,
        Ros2Topic::CameraTwist,
        Ros2Topic::Diagnostics,
        Ros2Topic::Obstacles,
    ];
}

/// `[reacquire]`: with fewer than three marks seen, the servo steers the camera back to its pose when it last
/// saw all four, proportionally with speed caps. Optional in the file (the defaults below apply); read at
/// start (a reload that changes it is refused).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reacquire {
    /// The proportional gain (1/s): the twist is this times the pose error, translation and rotation.
    pub gain_per_s: f64,
    /// The fastest the camera moves while reacquiring (m/s).
    pub max_speed_m_s: f64,
    /// The fastest the camera turns while reacquiring (rad/s).
    pub max_rotation_rad_s: f64,
}

impl Default for Reacquire {
    fn default() -> Self {
        Self { gain_per_s: 1.5, max_speed_m_s: 0.1, max_rotation_rad_s: 0.5 }
    }
}

/// `[faults]`: the fault reaction of the real-time shell. Optional in the file (the defaults below apply).
/// A position or velocity limit, a driver fault, a torque saturation that lasts, lost marks that stay lost
/// a stalled external driver and a camera that sends no frame each end in a safe stop: the arm ramps to rest
/// at the acceleration limits and is held until the cell resumes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Faults {
    /// Marks missing (the servo cannot servo) for longer than this is a lost target (`faults.target_lost_s`).
    pub target_lost: Duration,
    /// A joint's torque cut to its limit for longer than this is a fault (`faults.saturation_s`); a moment's
    /// saturation while accelerating is not.
    pub saturation: Duration,
    /// How the cell resumes after a safe stop.
    pub resume: ResumePolicy,
    /// With [`ResumePolicy::Automatic`]: how long the fault's cause must have been gone
    /// (`faults.resume_after_s`).
    pub resume_after: Duration,
    /// A camera that sends no frame for this many vision periods is stalled, a fault (`camera_stalled`;
    /// `faults.camera_timeout_periods`). See [`Faults::camera_timeout`].
    pub camera_timeout_periods: u32,
}

impl Faults {
    /// How long a camera may send no frame before it is stalled: `camera_timeout_periods` vision periods.
    pub fn camera_timeout(&self, vision_period_s: f64) -> Duration {
        Duration::from_secs_f64(vision_period_s * f64::from(self.camera_timeout_periods))
    }
}

/// How the cell resumes after a safe stop (`faults.resume`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ResumePolicy {
    /// On a command only (`vservoctl resume`), the default.
    Command,
    /// By itself once the cause has been gone for `faults.resume_after_s` (a WARN line says so), or on a
    /// command.
    Automatic,
}

impl ResumePolicy {
    /// The name in the file.
    pub fn name(self) -> &'static str {
        match self {
            ResumePolicy::Command => "command",
            ResumePolicy::Automatic => "automatic",
        }
    }
}

/// `[robot]`: which process drives the arm and how it is commanded. Optional in the file: the simulated
/// PUMA 560 by default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Robot {
    /// Who publishes `joint_state` and applies `joint_command`.
    pub driver: RobotDriver,
    /// Whether the cell comes up held (a safe stop `start_held`, ended by `vservoctl resume`) rather than
    /// servoing at once: `robot.start`, "held" by default for an external driver, a real arm's first motion.
    pub start_held: bool,
    /// The command an external driver takes ([`crate::CellConfig::command_interface`] gives the one in force: the
    /// simulated driver's follows from `plant.mode`).
    pub command: CommandInterface,
    /// The driver's period (s): a joint state comes this often, and the interpolator steps by it.
    pub period_s: f64,
    /// No joint state for this many periods is a stalled driver: no motion is commanded until it is back.
    pub state_timeout_periods: u32,
    /// A camera twist faster than this (m/s, the linear part's norm) is refused by the rmrc.
    pub max_camera_speed_m_s: f64,
    /// A camera twist turning faster than this (rad/s, the angular part's norm) is refused by the rmrc.
    pub max_camera_rotation_rad_s: f64,
}

impl Robot {
    /// The stall deadline (s).
    pub fn state_timeout_s(&self) -> f64 {
        self.period_s * f64::from(self.state_timeout_periods)
    }
}

/// `[franka]`: the Franka driver (`vservo-franka`, which vservod starts with `robot.driver = "franka"`): the
/// robot's FCI address and how the driver guards the robot's limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Franka {
    /// The robot's (or franka-sim's) FCI address.
    pub address: std::net::SocketAddr,
    /// A simulator (franka-sim), not a robot: the simulated camera may then render the board from the measured
    /// joints (`camera.source = "simulated"`).
    pub simulator: bool,
    /// The driver's last guard (libfranka's `limit_rate`): each command's acceleration and jerk kept within the
    /// arm's limits, whatever the rmrc's timing (a late answer repeats a sample).
    pub limit_rate: bool,
    /// How long after a robot state the driver waits for the rmrc's answer before sending (s).
    pub answer_within_s: f64,
    /// No valid command from the rmrc for this long: the driver brings the arm to rest and holds (s).
    pub hold_after_s: f64,
}

/// Who drives the arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RobotDriver {
    /// vservod's own plant node: the simulated PUMA 560 (`[plant]`).
    Simulated,
    /// A process of the user's (a real arm's driver, or another simulator), behind docs/DRIVERS.md, which the
    /// user starts: vservod never starts it.
    External,
    /// The ROS 2 driver (`vservo-ros2-driver`: a ros2_control arm, `[ros2.driver]`), which vservod starts.
    Ros2,
    /// The Franka driver (`vservo-franka`, `[franka]`), which vservod starts.
    Franka,
}

impl RobotDriver {
    /// Whether the arm is vservod's own simulated plant (else a driver process: the user's or one vservod
    /// starts).
    pub fn is_simulated(self) -> bool {
        self == RobotDriver::Simulated
    }

    /// The name in `robot.driver`.
    pub fn name(self) -> &'static str {
        match self {
            RobotDriver::Simulated => "simulated",
            RobotDriver::External => "external",
            RobotDriver::Ros2 => "ros2",
            RobotDriver::Franka => "franka",
        }
    }
}

/// The command a robot driver takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CommandInterface {
    /// Joint torques: the rmrc runs the joint servo.
    Torque,
    /// Joint velocities: the interpolator's q̇ reference.
    Velocity,
    /// Joint positions: the interpolator's q reference.
    Position,
}

impl CommandInterface {
    /// The name in the file.
    pub fn name(self) -> &'static str {
        match self {
            CommandInterface::Torque => "torque",
            CommandInterface::Velocity => "velocity",
            CommandInterface::Position => "position",
        }
    }
}

/// `[runtime]`: scheduling, memory locking and supervision of the real-time shell. Optional in the file
/// (the defaults below apply). A scheduling request the system does not permit is a warning at start, not
/// an error.
#[derive(Debug, Clone, PartialEq)]
pub struct Runtime {
    /// mlockall(MCL_CURRENT | MCL_FUTURE) in every node.
    pub lock_memory: bool,
    /// The timer slack of the periodic threads (ns): the kernel's default 50 µs adds that much lateness.
    pub timer_slack_ns: u64,
    /// How often every node publishes telemetry (`runtime.telemetry_period_s`).
    pub telemetry_period: Duration,
    /// The first restart of a crashed node waits this long (`runtime.restart_backoff_initial_s`); each
    /// further one twice as long.
    pub restart_backoff_initial: Duration,
    /// The longest wait before a restart (`runtime.restart_backoff_max_s`).
    pub restart_backoff_max: Duration,
    /// After this many ticks without an answer from the rmrc the plant holds the arm (brakes).
    pub hold_after_missed_ticks: u32,
    /// On SIGTERM, how long the arm may take to ramp to rest before the nodes are stopped anyway
    /// (`runtime.stop_timeout_s`).
    pub stop_timeout: Duration,
    /// A node whose loop shows no progress (no telemetry; the plant: no new tick) for this long is hung: it is
    /// killed and restarted like a crashed one (`runtime.hang_timeout_s`).
    pub hang_timeout: Duration,
    /// Per node, indexed by role name: plant, rmrc, servo, vision.
    pub plant: NodeRealtime,
    /// The rmrc's.
    pub rmrc: NodeRealtime,
    /// The servo's.
    pub servo: NodeRealtime,
    /// The vision node's.
    pub vision: NodeRealtime,
}

/// One node's scheduling.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeRealtime {
    /// SCHED_FIFO priority 1–99; 0 keeps the normal scheduler.
    pub fifo_priority: u8,
    /// CPUs the node may run on; empty: any.
    pub cpus: Vec<usize>,
}

/// The simulated arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantSettings {
    /// Dynamic or kinematic.
    pub mode: vservo_settings::simulation::PlantMode,
    /// RK4 steps per control period.
    pub rk4_substeps: u32,
    /// How the kinematic plant's joints follow the reference.
    pub kinematic: vservo_settings::simulation::KinematicResponse,
}

/// The joint servo's law and gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointServoSettings {
    /// Computed torque or PD plus gravity.
    pub law: vservo_settings::simulation::JointServoLaw,
    /// Position gains.
    pub kp: JointVector,
    /// Velocity gains.
    pub kv: JointVector,
}

/// What the simulated cell does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scenario {
    /// How long a simulation runs (s).
    pub duration_s: f64,
    /// The camera's starting offset from its desired pose, in the desired camera frame (m).
    pub initial_camera_translation_m: Vector3<f64>,
    /// …and its starting rotation about its own axes (rotation vector, rad).
    pub initial_camera_rotation: Vector3<f64>,
    /// How the board moves.
    pub object: vservo_settings::simulation::ObjectMotion,
    /// Marks the simulated camera does not see for a while (`scenario.occlusions`; none by default), at
    /// most [`MAX_OCCLUSIONS`].
    pub occlusions: [Option<Occlusion>; MAX_OCCLUSIONS],
}

/// The most occlusions a scenario may hold.
pub const MAX_OCCLUSIONS: usize = 8;

/// A mark hidden from the simulated camera for a while, as if something covered it (`scenario.occlusions`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Occlusion {
    /// The mark (zero-based).
    pub mark: usize,
    /// From this time (s)…
    pub from_s: f64,
    /// …until this one (s).
    pub until_s: f64,
}

impl Scenario {
    /// The marks hidden at time `t_s` (bit m for mark m).
    pub fn hidden_marks(&self, t_s: f64) -> u8 {
        self.occlusions
            .iter()
            .flatten()
            .filter(|o| o.from_s <= t_s && t_s < o.until_s)
            .fold(0, |set, o| set | (1 << o.mark))
    }
}

/// Where images come from, and how features are found in them.
#[derive(Debug, Clone, PartialEq)]
pub struct Vision {
    /// The image source.
    pub source: VisionSource,
    /// Whether the features are undistorted before the law (`vision.undistort`, true by default; false only
    /// to measure what the lens costs a law that ignores it).
    pub undistort: bool,
    /// The extractor's tuning.
    pub extractor: vservo_settings::vision::ExtractorSettings,
    /// The simulated camera's scene.
    pub render: vservo_settings::vision::RenderSettings,
}

/// `[calibration]`: the calibration board (`vservoctl board` prints it) and the poses `vservoctl calibrate`
/// takes around it.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationSettings {
    /// The board's grid of tags.
    pub board: vservo_scene::TagGrid,
    /// How many poses.
    pub poses: usize,
    /// The camera's tilt from the board's normal at the poses (rad); the poses go round the normal.
    pub tilt_rad: f64,
    /// The camera's distance from the board's centre at the poses (m); `None`: the distance at the desired
    /// pose.
    pub distance_m: Option<f64>,
    /// Where the calibration is written (`None`: `calibration.yaml` beside the configuration file).
    pub output_file: Option<String>,
}

/// A camera fixed in the world (`camera.mount = "world"`), the board on the tool.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedCamera {
    /// `camera.base_from_camera`: the camera in the arm's base frame.
    pub base_from_camera: nalgebra::IsometryMatrix3<f64>,
    /// The board on the tool, where the desired pose puts it (`[desired]` read with the camera fixed).
    pub tool_from_board: nalgebra::IsometryMatrix3<f64>,
}

/// The simulated camera as it really is (`[camera.truth]`): what a calibration of the simulated cell should
/// find, apart from what the configuration believes the camera to be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraTruth {
    /// Its intrinsics and lens.
    pub intrinsics: vservo_scene::CameraIntrinsics,
    /// Where it sits on the hand.
    pub tool_from_camera: nalgebra::IsometryMatrix3<f64>,
    /// A fixed camera's pose in the base, where `[camera.truth] base_from_camera` says it differs from the
    /// believed one.
    pub base_from_camera: Option<nalgebra::IsometryMatrix3<f64>>,
}

/// `[camera.gstreamer]`: the GStreamer camera driver's pipeline and controls (docs/DRIVERS.md, "A real
/// camera through GStreamer"). Read by `vservo-gst-camera` only, at its start (vservod starts it with
/// `camera.source = "gstreamer"`).
#[derive(Debug, Clone, PartialEq)]
pub struct GstreamerCamera {
    /// `gst-launch-1.0` syntax, ending in 8-bit gray frames of the camera's size (the driver adds the
    /// appsink unless the pipeline has an element named [`GstreamerCamera::appsink`]).
    pub pipeline: String,
    /// The name of the appsink the frames are taken from (`vservo` unless given).
    pub appsink: String,
    /// The exposure time to set on the source (µs), if given.
    pub exposure_us: Option<f64>,
    /// The analogue gain to set on the source (dB), if given.
    pub gain_db: Option<f64>,
    /// No frame for this many vision periods: the pipeline is logged as stalled.
    pub stall_periods: u32,
}

/// Where images come from (`camera.source`).
#[derive(Debug, Clone, PartialEq)]
pub enum VisionSource {
    /// The simulated hand camera renders the board.
    Simulated,
    /// Frames published on `camera_image` by a camera driver the user starts (vservod never starts it).
    External,
    /// Frames of a ROS camera, through the ROS 2 driver (`vservo-ros2-driver`), which vservod starts.
    Ros2,
    /// Frames of the GStreamer camera driver (`vservo-gst-camera`, `[camera.gstreamer]`), which vservod starts.
    Gstreamer,
    /// Recorded images in a directory.
    Directory(std::path::PathBuf),
}

impl VisionSource {
    /// Whether the frames come from a camera driver, a process publishing on `camera_image` (the user's or one
    /// vservod starts).
    pub fn from_camera_driver(&self) -> bool {
        matches!(self, VisionSource::External | VisionSource::Ros2 | VisionSource::Gstreamer)
    }

    /// The name in `camera.source`.
    pub fn name(&self) -> &'static str {
        match self {
            VisionSource::Simulated => "simulated",
            VisionSource::External => "external",
            VisionSource::Ros2 => "ros2",
            VisionSource::Gstreamer => "gstreamer",
            VisionSource::Directory(_) => "directory",
        }
    }
}

/// Periods and delays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// The vision period T (s).
    pub vision_period_s: f64,
    /// Frames between an image's capture and its features reaching the servo.
    pub pipeline_delay_frames: usize,
    /// The interpolator's period (s).
    pub control_period_s: f64,
    /// Control periods per vision frame (a whole number: 85 by default).
    pub control_ticks_per_frame: u32,
}

/// The desired pose and the image there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Desired {
    /// q_d (rad), inside the joint limits.
    pub joints: JointVector,
    /// The board in the camera frame at the desired pose.
    pub camera_from_board: IsometryMatrix3<f64>,
    /// ξ_d: the marks' images there (px), all inside the image.
    pub features: FeatureVector,
    /// Z_d: the marks' depths there (m), all positive.
    pub depths: MarkDepths,
}

/// The controller's law and weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controller {
    /// Which law runs.
    pub law: ControlLaw,
    /// Q.
    pub q: StateWeight,
    /// R, with its unit.
    pub r: InputWeight,
    /// What the law does beyond the paper's (`interaction`, `border_margin_px`, `feedforward`).
    pub options: vservo_settings::control::LawOptions,
}
