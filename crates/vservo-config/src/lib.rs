//! # vservo-config — the configuration file
//!
//! This crate owns vservo's TOML schema (see `config/vservo.toml`, the default, for every key and its
//! meaning) and turns a file into a [`Config`] whose parts cannot hold invalid values: a positive-definite
//! R, a vision period that is a whole number of control periods, a desired pose inside the joint limits
//! with all four marks in front of the camera and inside the image. The rest of vservo never re-checks.
//!
//! Errors name the file, the key and the value ([`ConfigError`]). Unknown keys are errors.
//!
//! A file may be an overlay: `extends = "../vservo.toml"` (relative to the file) merges it over its base, its
//! own keys winning, tables key by key ([`Config::load`]); an error names the file in which the bad key was
//! written. [`resolve`] and [`Config::load_with_text`] give the merged text, a whole configuration that
//! [`Config::from_toml`] takes as it is (the text vservod hands its nodes). The scenario files in
//! `config/scenarios/` are such overlays of `config/vservo.toml`.
//!
//! ```
//! let text = include_str!("../../../config/vservo.toml");
//! let config = vservo_config::Config::from_toml(text, "vservo.toml").expect("the default config is valid");
//! assert_eq!(config.timing.control_ticks_per_frame, 85);
//! ```

mod error;
mod layers;
mod raw;
mod validate;

use std::path::Path;
use std::time::Duration;

pub use error::ConfigError;
use layers::Layers;
use nalgebra::Vector3;
use vservo_arm::JointVector;
use vservo_control::{ControlLaw, GainsSpec, InputWeight, StateWeight};
use vservo_scene::{Board, CameraIntrinsics, FeatureVector, IsometryMatrix3, MarkDepths};

/// A validated configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Where it came from (a path, or a name for text given directly), for messages.
    pub origin: String,
    /// The instance name: shared-memory services live under `vservo/<name>/`.
    pub instance: String,
    /// Periods and delays.
    pub timing: Timing,
    /// The camera's intrinsics.
    pub camera: CameraIntrinsics,
    /// Where the camera sits on the hand: camera = tool · `tool_from_camera`.
    pub tool_from_camera: IsometryMatrix3<f64>,
    /// The object.
    pub board: Board,
    /// The desired pose and what the camera sees there.
    pub desired: Desired,
    /// The controller's law and weights.
    pub controller: Controller,
    /// The image source and the feature extractor.
    pub vision: Vision,
    /// The simulated arm.
    pub plant: PlantSettings,
    /// The resolved-motion-rate interpolator.
    pub interpolator: vservo_sim::interpolator::InterpolatorSettings,
    /// The joint servo.
    pub joint_servo: JointServoSettings,
    /// What the simulated cell does.
    pub scenario: Scenario,
    /// `[runtime]`: how the real-time shell runs the nodes.
    pub runtime: Runtime,
    /// `[robot]`: the robot driver and the command it takes.
    pub robot: Robot,
    /// `[robot.arm]`: the arm's model (the PUMA 560 by default; a custom arm's DH table and limits).
    pub arm: vservo_arm::SerialArm,
    /// `[faults]`: when a fault stops the cell, and how it resumes.
    pub faults: Faults,
    /// `[reacquire]`: how the servo steers back to lost marks.
    pub reacquire: Reacquire,
    /// `[viewer]`: the live view in Foxglove.
    pub viewer: Viewer,
}

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
/// and a stalled external driver each end in a safe stop: the arm ramps to rest at the acceleration limits
/// and is held until the cell resumes.
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
    /// The command an external driver takes ([`Config::command_interface`] gives the one in force: the
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

/// Who drives the arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RobotDriver {
    /// vservod's own plant node: the simulated PUMA 560 (`[plant]`).
    Simulated,
    /// A process of the user's (a real arm's driver, or another simulator), behind docs/DRIVERS.md.
    External,
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

    /// From the name in the file.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Torque, Self::Velocity, Self::Position].into_iter().find(|c| c.name() == name)
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
    pub mode: vservo_sim::plant::PlantMode,
    /// RK4 steps per control period.
    pub rk4_substeps: u32,
}

/// The joint servo's law and gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointServoSettings {
    /// Computed torque or PD plus gravity.
    pub law: vservo_sim::joint_servo::JointServoLaw,
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
    pub object: vservo_sim::world::ObjectMotion,
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
    /// The extractor's tuning.
    pub extractor: vservo_vision::ExtractorSettings,
    /// The simulated camera's scene.
    pub render: vservo_vision::RenderSettings,
}

/// Where images come from (`camera.source`).
#[derive(Debug, Clone, PartialEq)]
pub enum VisionSource {
    /// The simulated hand camera renders the board.
    Simulated,
    /// Frames published on `camera_image` by another process (a camera driver).
    External,
    /// Recorded images in a directory.
    Directory(std::path::PathBuf),
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
    pub options: vservo_control::LawOptions,
}

impl Config {
    /// Reads and validates a configuration file, merged over the bases it `extends`.
    pub fn load(path: impl AsRef<Path>) -> Result<Config, ConfigError> {
        Self::load_with_text(path).map(|(config, _)| config)
    }

    /// Reads and validates a configuration file, merged over the bases it `extends`, and gives the
    /// resolved text with it: the whole configuration as one TOML document with no base left to find, which
    /// [`Config::from_toml`] turns into the same `Config` (what the daemon hands its nodes).
    pub fn load_with_text(path: impl AsRef<Path>) -> Result<(Config, String), ConfigError> {
        let path = path.as_ref();
        let layers = Layers::read(path)?;
        let config = Self::from_layers(&layers, &path.display().to_string())?;
        Ok((config, layers.resolved_text()))
    }

    /// The `[instance] name` of a file (its bases merged), read on its own: the instance a client talks to
    /// even when the rest of the file does not validate (a file edited since the daemon started, whose
    /// reload the daemon refuses).
    pub fn instance_of(path: impl AsRef<Path>) -> Result<String, ConfigError> {
        let layers = Layers::read(path.as_ref())?;
        let table = layers.merged();
        let name =
            table.get("instance").and_then(|i| i.get("name")).and_then(|n| n.as_str()).unwrap_or_default();
        if is_instance_name(name.trim()) {
            Ok(name.trim().to_string())
        } else {
            Err(ConfigError::Invalid {
                file: layers.file_of("instance.name").to_string(),
                key: "instance.name".into(),
                value: format!("{name:?}"),
                reason: INSTANCE_NAME_RULE.into(),
            })
        }
    }

    /// Validates configuration text; `origin` names it in messages. The text is whole: `extends` is refused
    /// (there is no file to find the base from; [`Config::load`] merges it, [`resolve`] gives the result).
    pub fn from_toml(text: &str, origin: &str) -> Result<Config, ConfigError> {
        Self::from_layers(&Layers::from_text(text, origin)?, origin)
    }

    /// Parses and validates the merged layers; an error names the file in which its key was written.
    fn from_layers(layers: &Layers, origin: &str) -> Result<Config, ConfigError> {
        let raw = layers.raw_config()?;
        validate::validate(raw, origin).map_err(|error| match error.key() {
            Some(key) => {
                let file = layers.file_of(key).to_string();
                error.in_file(&file)
            }
            None => error,
        })
    }

    /// The world (= arm base) pose of the board, placed so that the camera at q_d sees it as desired.
    pub fn base_from_board(&self, arm: &vservo_arm::SerialArm) -> IsometryMatrix3<f64> {
        arm.base_from_tool(&self.desired.joints) * self.tool_from_camera * self.desired.camera_from_board
    }

    /// The board as the camera sees it with the arm at `joints` and the board where the desired pose puts
    /// it: `camera_from_board = (base_from_tool(q) · tool_from_camera)⁻¹ · base_from_board`.
    pub fn camera_from_board_at(
        &self,
        arm: &vservo_arm::SerialArm,
        joints: &JointVector,
    ) -> IsometryMatrix3<f64> {
        let base_from_camera = arm.base_from_tool(joints) * self.tool_from_camera;
        base_from_camera.inverse() * self.base_from_board(arm)
    }

    /// The command the robot driver takes: an external driver's declaration; for the simulated driver,
    /// torque for the dynamic plant and position (the ideal robot) for the kinematic one.
    pub fn command_interface(&self) -> CommandInterface {
        match self.robot.driver {
            RobotDriver::External => self.robot.command,
            RobotDriver::Simulated => match self.plant.mode {
                vservo_sim::plant::PlantMode::Dynamic => CommandInterface::Torque,
                vservo_sim::plant::PlantMode::Kinematic => CommandInterface::Position,
            },
        }
    }

    /// What the gain design needs.
    pub fn gains_spec(&self) -> GainsSpec {
        GainsSpec {
            camera: self.camera,
            desired_features: self.desired.features,
            desired_depths: self.desired.depths,
            period_s: self.timing.vision_period_s,
            delay_frames: self.timing.pipeline_delay_frames,
            q: self.controller.q,
            r: self.controller.r,
            law: self.controller.law,
            options: self.controller.options,
        }
    }
}

/// The text of a configuration file merged over the bases it `extends`, not validated: one TOML document that
/// means what the file means, wherever it is put (a copy elsewhere, a test's edited copy, a node's stdin).
pub fn resolve(path: impl AsRef<Path>) -> Result<String, ConfigError> {
    Ok(Layers::read(path.as_ref())?.resolved_text())
}

/// What an instance name may be, as said in errors.
pub const INSTANCE_NAME_RULE: &str =
    "must be 1–64 letters, digits, '-' or '_' (it becomes part of shared-memory service names)";

/// Whether `name` may name an instance ([`INSTANCE_NAME_RULE`]).
pub fn is_instance_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

/// A pose from a translation (m) and roll-pitch-yaw angles (rad): R = Rz(yaw)·Ry(pitch)·Rx(roll).
pub fn pose_from_rpy(translation_m: Vector3<f64>, rpy: Vector3<f64>) -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(
        translation_m.into(),
        nalgebra::Rotation3::from_euler_angles(rpy.x, rpy.y, rpy.z),
    )
}
