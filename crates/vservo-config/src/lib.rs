//! # vservo-config — the configuration file
//!
//! This crate owns vservo's TOML schema (see `config/vservo.toml`, the default, for every key and its
//! meaning) and turns a file into a [`Config`] whose parts cannot hold invalid values: a positive-definite
//! R, a vision period that is a whole number of control periods, a desired pose inside the joint limits
//! with all four marks in front of the camera and inside the image. The rest of vservo never re-checks.
//!
//! Errors name the file, the key and the value ([`ConfigError`]). Unknown keys are errors. A file (and each
//! base it extends) is read only if it is a regular file of at most [`MAX_CONFIG_FILE_BYTES`] (1 MiB, the chain of bases together too): a FIFO,
//! a device such as `/dev/zero` or a directory is refused at once, naming it. A camera whose image is larger
//! than one `camera_image` sample ([`MAX_CAMERA_IMAGE_BYTES`]) is refused, naming the key.
//!
//! A file may be an overlay: `extends = "../vservo.toml"` (relative to the file) merges it over its base, its
//! own keys winning, tables key by key ([`Config::load`]); an error names the file in which the bad key was
//! written. [`resolve`] and [`Config::load_with_text`] give the merged text, a whole configuration that
//! [`Config::from_toml`] takes as it is (the text vservod hands its nodes). The scenario files in
//! `config/scenarios/` are such overlays of `config/vservo.toml`.
//!
//! Besides the paper's cell it holds: `[faults]` (target-lost and saturation times, the resume policy); the
//! arm (`[robot.arm]`: the PUMA 560, a DH table of the user's, or a URDF's chain of six or seven joints; a key
//! with a value per joint takes the arm's count; `[interpolator.null_space]` for a seven-joint arm) and its
//! motion limits; the robot driver and its command interface ([`CellConfig::command_interface`]); `[camera.truth]`
//! ([`CellConfig::true_camera`]: the simulated camera as it really is, where written); `[calibration]`
//! ([`CalibrationSettings`]: the calibration board and the poses; `printed_on_object` prints it on the
//! simulated board, its target tag one of the board's). A calibration file's principal point is in OpenCV's
//! pixels (+ ½ when read), and its `tool_from_camera`, where it has one, takes the place of
//! `camera.tool_from_camera`. Every numeric key has a range that keeps the daemon working (the tests replace
//! each by ±1e300 and NaN).
//!
//! Where things are: `lib.rs` has [`Config`] and how it is loaded; `sections.rs` one type per section;
//! `layers.rs` a file and the bases it `extends` (tables merged key by key, other values replaced; cycles and
//! missing bases refused; each error traced to the file that wrote its key; the lens — `focal_px` or
//! `fx_px`/`fy_px`, `principal_point_px`, `distortion`, `width_px`, `height_px`, `calibration_file` — is one
//! value, so a file writing any of it replaces its base's whole lens, and a relative `calibration_file` is
//! made relative to the file that wrote it); `raw.rs` the file as written, every name a key takes a serde enum
//! (an unknown name is a parser error naming the key and the accepted names); [`calibration`]
//! `camera.calibration_file`, a ROS camera_info or OpenCV FileStorage YAML (yaml-rust2; OpenCV's `%YAML:1.0`
//! line taken out), its errors naming the key in it; `validate/` one module per section (`timing`, `camera`,
//! `object`, `desired`, `controller` with `weight`, `vision`, `simulation`, `scenario`, `robot`, `arm`,
//! `motion`, `franka`, `runtime`, `operation` for faults, reacquire and viewer, `ros2` for the ROS 2 bridge,
//! `calibration_board`) on a shared `checker`, called in the order the sections build on each other;
//! `cell.rs` the core cell's part ([`CellConfig`], `Config::cell`: what the cell's stages run by, never the
//! shells' sections) with the rules computed from it; [`new_file`] how vservo writes a file where others may
//! plant one.
//!
//! The supervision and fault times (`runtime.*_s`, `faults.*_s`) are `std::time::Duration`s in [`Config`];
//! the periods and times the control and simulation math uses stay `f64` seconds. Every `Config` type is
//! `PartialEq`, so that a reload can compare values.
//!
//! ```
//! let text = include_str!("../../../config/vservo.toml");
//! let config = vservo_config::Config::from_toml(text, "vservo.toml").expect("the default config is valid");
//! assert_eq!(config.cell.timing.control_ticks_per_frame, 85);
//! ```

/// The longest `[camera.gstreamer] pipeline` taken (bytes).
pub const MAX_PIPELINE_BYTES: usize = 4096;

pub mod calibration;
mod cell;
mod collision;
pub mod edit;
mod error;
mod layers;
pub mod new_file;
mod raw;
mod sections;
mod validate;
pub use vservo_settings::simulation::MIN_SPEED_SCALE;

use std::path::Path;

pub use cell::CellConfig;
pub use collision::{CameraBox, Collision, Obstacle, Primitive, PrimitiveKind, Solid, Workspace};
pub use error::ConfigError;
use layers::Layers;
pub use layers::{LENS_KEYS, did_you_mean};
use nalgebra::Vector3;
pub use sections::*;
use vservo_scene::IsometryMatrix3;

/// A validated configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Where it came from (a path, or a name for text given directly), for messages.
    pub origin: String,
    /// The instance name: shared-memory services live under `vservo/<name>/`.
    pub instance: String,
    /// The core cell's part: timing, camera and mount, board and desired pose, law, vision, plant, interpolator,
    /// joint servo, scenario, robot and arm, reacquisition ([`CellConfig`]).
    pub cell: CellConfig,
    /// `[runtime]`: how the real-time shell runs the nodes.
    pub runtime: Runtime,
    /// `robot.arm.urdf`: the file an arm from a URDF was read from (for drivers that load it themselves).
    pub arm_urdf_file: Option<String>,
    /// `[faults]`: when a fault stops the cell, and how it resumes.
    pub faults: Faults,
    /// `[viewer]`: the live view in Foxglove.
    pub viewer: Viewer,
    /// `[ros2]`: the bridge to a ROS 2 graph.
    pub ros2: Ros2,
    /// `[franka]`: the Franka driver's settings, with `robot.driver = "franka"` (none otherwise).
    pub franka: Option<Franka>,
    /// `[camera.gstreamer]`: the GStreamer camera driver's settings, if the file has them.
    pub gstreamer: Option<GstreamerCamera>,
    /// `[calibration]`: the calibration board and poses, if the file has them.
    pub calibration: Option<CalibrationSettings>,
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
        Ok((config, layers.resolved_text()?))
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

    /// Parses and validates the merged layers; an error names the file in which its key was written, or, when
    /// that file and its bases are valid alone, the overlay whose keys made the key wrong (saying where the key
    /// itself was written).
    fn from_layers(layers: &Layers, origin: &str) -> Result<Config, ConfigError> {
        let raw = layers.raw_config()?;
        validate::validate(raw, origin).map_err(|error| {
            let Some(key) = error.key().map(str::to_string) else { return error };
            let written_in = layers.file_of(&key).to_string();
            let same_fault =
                |raw| validate::validate(raw, origin).err().is_some_and(|e| e.key() == Some(&key));
            match layers.first_failing(same_fault) {
                Some(culprit) if culprit != written_in => error.caused_by(culprit, &written_in),
                _ => error.in_file(&written_in),
            }
        })
    }

    /// Whether vservod starts the ROS 2 driver (`vservo-ros2-driver`): for the arm (`robot.driver = "ros2"`),
    /// the camera (`camera.source = "ros2"`) or both.
    pub fn runs_ros2_driver(&self) -> bool {
        self.cell.robot.driver == RobotDriver::Ros2 || self.cell.vision.source == VisionSource::Ros2
    }
}

/// The text of a configuration file merged over the bases it `extends`, not validated: one TOML document that
/// means what the file means, wherever it is put (a copy elsewhere, a test's edited copy, a node's stdin).
pub fn resolve(path: impl AsRef<Path>) -> Result<String, ConfigError> {
    Layers::read(path.as_ref())?.resolved_text()
}

/// The largest image a camera may have (bytes, 8-bit gray): what one sample of the `camera_image` service
/// carries (`vservo_protocol::MAX_IMAGE_BYTES`, docs/PROTOCOL.md). The configuration cannot depend on the
/// protocol crate (iceoryx2; and the protocol may one day size its services from the configuration), so the
/// number is repeated here and `vservo-runtime` asserts at compile time that the two agree.
pub const MAX_CAMERA_IMAGE_BYTES: usize = 1280 * 1024;

/// The largest configuration file read (bytes), and the most a file and the bases it extends hold together: a
/// file longer than this, or one that is not a regular file (a FIFO, a device such as `/dev/zero`, a
/// directory), is refused at once. The annotated default configuration is 25 kB; a file of a megabyte of
/// tables takes the TOML parser about 0.3 s and 55 MB (four megabytes: 1.2 s and 210 MB), so that no
/// configuration keeps a process from its SIGTERM for long. URDF and calibration files are read up to it too.
pub const MAX_CONFIG_FILE_BYTES: u64 = 1024 * 1024;

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
