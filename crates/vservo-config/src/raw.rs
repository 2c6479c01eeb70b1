//! The file as written: serde structures that mirror the TOML, refusing unknown keys. Every name a key takes
//! is an enum here, parsed once by serde: an unknown name is a parser error that names the key and lists
//! the accepted names.

use serde::Deserialize;

use crate::{CommandInterface, ResumePolicy};

mod collision;
mod names;

pub use collision::*;
pub use names::*;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawConfig {
    pub instance: RawInstance,
    pub timing: RawTiming,
    pub camera: RawCamera,
    pub object: RawObject,
    pub desired: RawDesired,
    pub controller: RawController,
    pub vision: RawVision,
    pub plant: RawPlant,
    pub interpolator: RawInterpolator,
    pub joint_servo: RawJointServo,
    pub scenario: RawScenario,
    #[serde(default)]
    pub runtime: RawRuntime,
    #[serde(default)]
    pub robot: RawRobot,
    #[serde(default)]
    pub faults: RawFaults,
    #[serde(default)]
    pub reacquire: RawReacquire,
    #[serde(default)]
    pub viewer: RawViewer,
    #[serde(default)]
    pub ros2: RawRos2,
    #[serde(default)]
    pub franka: Option<RawFranka>,
    #[serde(default)]
    pub target: RawTarget,
    #[serde(default)]
    pub calibration: Option<RawCalibration>,
    #[serde(default)]
    pub collision: Option<RawCollision>,
    #[serde(default)]
    pub scene: RawScene,
}

/// `[calibration]`: the board `vservoctl calibrate` looks at and the poses it takes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCalibration {
    pub board_rows: i64,
    pub board_columns: i64,
    pub tag_size_m: f64,
    pub gap_m: f64,
    #[serde(default)]
    pub first_id: i64,
    #[serde(default)]
    pub printed_on_object: bool,
    #[serde(default = "default_calibration_poses")]
    pub poses: i64,
    #[serde(default = "default_calibration_tilt_deg")]
    pub tilt_deg: f64,
    #[serde(default)]
    pub distance_m: Option<f64>,
    #[serde(default)]
    pub output_file: Option<String>,
}

fn default_calibration_poses() -> i64 {
    12
}

fn default_calibration_tilt_deg() -> f64 {
    25.0
}

/// `[target]`: what the four features are (docs/VISION.md).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawTarget {
    pub kind: RawTargetKind,
    pub family: RawTagFamily,
    pub id: i64,
    pub tag_size_m: f64,
    pub centre_in_board_m: [f64; 2],
    /// `kind = "bundle"`: the bundle's tags.
    pub tags: Vec<RawBundleTag>,
}

/// One tag of `[target] tags`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBundleTag {
    pub id: i64,
    pub tag_size_m: f64,
    pub centre_in_board_m: [f64; 2],
}

impl Default for RawTarget {
    fn default() -> Self {
        Self {
            kind: RawTargetKind::Marks,
            family: RawTagFamily::Tag36h11,
            id: 0,
            tag_size_m: 0.1,
            centre_in_board_m: [0.0, 0.0],
            tags: Vec::new(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawViewer {
    pub enabled: bool,
    pub address: String,
    pub port: i64,
    pub max_clients: i64,
}

impl Default for RawViewer {
    fn default() -> Self {
        Self { enabled: false, address: "127.0.0.1".into(), port: 8765, max_clients: 4 }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawRos2 {
    pub enabled: bool,
    pub domain_id: i64,
    pub namespace: String,
    pub interface: String,
    pub publish: Vec<crate::Ros2Topic>,
    pub image_every: i64,
    pub joint_state_rate_hz: f64,
    pub joint_names: Vec<String>,
    pub allow_motion: bool,
    pub driver: RawRos2Driver,
    pub qos: std::collections::BTreeMap<crate::Ros2Topic, RawTopicQos>,
}

/// `[ros2.qos.<topic>]`: what of the topic's QoS is written (the rest stays the bridge's default).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTopicQos {
    #[serde(default)]
    pub reliability: Option<crate::QosReliability>,
    #[serde(default)]
    pub durability: Option<crate::QosDurability>,
    #[serde(default)]
    pub depth: Option<i64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawRos2Driver {
    pub joint_states_topic: String,
    pub command_topic: String,
    pub image_topic: String,
    pub hold_after_s: f64,
    pub clock_tolerance_s: f64,
}

impl Default for RawRos2Driver {
    fn default() -> Self {
        Self {
            joint_states_topic: "/joint_states".into(),
            command_topic: "/forward_velocity_controller/commands".into(),
            image_topic: "/camera/image_raw".into(),
            hold_after_s: 0.02,
            clock_tolerance_s: 0.05,
        }
    }
}

impl Default for RawRos2 {
    fn default() -> Self {
        Self {
            enabled: false,
            domain_id: 0,
            namespace: String::new(),
            interface: String::new(),
            publish: crate::Ros2Topic::ALL.to_vec(),
            image_every: 1,
            joint_state_rate_hz: 100.0,
            joint_names: Vec::new(),
            allow_motion: false,
            driver: RawRos2Driver::default(),
            qos: std::collections::BTreeMap::new(),
        }
    }
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawReacquire {
    pub gain_per_s: Option<f64>,
    pub max_speed_m_s: Option<f64>,
    pub max_rotation_rad_s: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawFaults {
    pub target_lost_s: f64,
    pub saturation_s: f64,
    pub resume: ResumePolicy,
    pub resume_after_s: f64,
    pub camera_timeout_periods: i64,
}

impl Default for RawFaults {
    fn default() -> Self {
        Self {
            target_lost_s: 1.0,
            saturation_s: 0.5,
            resume: ResumePolicy::Command,
            resume_after_s: 2.0,
            camera_timeout_periods: 6,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawRobot {
    pub driver: RawRobotDriver,
    pub start: Option<RawStart>,
    pub command: Option<CommandInterface>,
    pub period_s: Option<f64>,
    pub state_timeout_periods: i64,
    pub max_camera_speed_m_s: f64,
    pub max_camera_rotation_rad_s: f64,
    pub speed_scale: Option<f64>,
    pub arm: RawArm,
}

impl Default for RawRobot {
    fn default() -> Self {
        Self {
            driver: RawRobotDriver::Simulated,
            start: None,
            command: None,
            period_s: None,
            state_timeout_periods: 50,
            max_camera_speed_m_s: 2.0,
            max_camera_rotation_rad_s: 6.0,
            speed_scale: None,
            arm: RawArm::default(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawArm {
    pub preset: RawArmPreset,
    pub urdf: Option<String>,
    pub base_link: Option<String>,
    pub tip_link: Option<String>,
    pub dh: Option<Vec<[f64; 4]>>,
    pub joint_limits_rad: Option<Vec<[f64; 2]>>,
    pub velocity_limits_rad_s: Option<Vec<f64>>,
    pub acceleration_limits_rad_s2: Option<Vec<f64>>,
    pub jerk_limits_rad_s3: Option<Vec<f64>>,
    pub tool_speed_limit_m_s: Option<f64>,
    pub tool_rotation_limit_rad_s: Option<f64>,
}

impl Default for RawArm {
    fn default() -> Self {
        Self {
            preset: RawArmPreset::Puma560,
            urdf: None,
            base_link: None,
            tip_link: None,
            dh: None,
            joint_limits_rad: None,
            velocity_limits_rad_s: None,
            acceleration_limits_rad_s2: None,
            jerk_limits_rad_s3: None,
            tool_speed_limit_m_s: None,
            tool_rotation_limit_rad_s: None,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawRuntime {
    pub lock_memory: bool,
    pub timer_slack_ns: i64,
    pub telemetry_period_s: f64,
    pub restart_backoff_initial_s: f64,
    pub restart_backoff_max_s: f64,
    pub hold_after_missed_ticks: i64,
    pub stop_timeout_s: f64,
    pub hang_timeout_s: f64,
    pub plant: RawNodeRealtime,
    pub rmrc: RawNodeRealtime,
    pub servo: RawNodeRealtime,
    pub vision: RawNodeRealtime,
}

impl Default for RawRuntime {
    fn default() -> Self {
        Self {
            lock_memory: true,
            timer_slack_ns: 1,
            telemetry_period_s: 0.1,
            restart_backoff_initial_s: 0.1,
            restart_backoff_max_s: 5.0,
            hold_after_missed_ticks: 20,
            stop_timeout_s: 1.0,
            hang_timeout_s: 1.0,
            plant: RawNodeRealtime { fifo_priority: 80, cpus: Vec::new() },
            rmrc: RawNodeRealtime { fifo_priority: 79, cpus: Vec::new() },
            servo: RawNodeRealtime { fifo_priority: 60, cpus: Vec::new() },
            vision: RawNodeRealtime { fifo_priority: 0, cpus: Vec::new() },
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawNodeRealtime {
    pub fifo_priority: i64,
    #[serde(default)]
    pub cpus: Vec<i64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawInstance {
    pub name: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTiming {
    pub vision_period_s: f64,
    pub pipeline_delay_frames: i64,
    pub control_period_s: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCamera {
    #[serde(default)]
    pub focal_px: Option<f64>,
    #[serde(default)]
    pub fx_px: Option<f64>,
    #[serde(default)]
    pub fy_px: Option<f64>,
    #[serde(default)]
    pub principal_point_px: Option<[f64; 2]>,
    #[serde(default)]
    pub width_px: Option<i64>,
    #[serde(default)]
    pub height_px: Option<i64>,
    #[serde(default)]
    pub distortion: Option<[f64; 5]>,
    #[serde(default)]
    pub calibration_file: Option<String>,
    #[serde(default)]
    pub source: RawCameraSource,
    #[serde(default)]
    pub directory: String,
    #[serde(default)]
    pub mount: RawCameraMount,
    #[serde(default)]
    pub tool_from_camera: Option<RawPose>,
    #[serde(default)]
    pub base_from_camera: Option<RawPose>,
    /// `[camera.gstreamer]`: read by the GStreamer camera driver (vservo-gst-camera) only.
    #[serde(default)]
    pub gstreamer: Option<RawGstreamer>,
    /// `[camera.truth]`: the simulated camera as it really is, where that differs from the above.
    #[serde(default)]
    pub truth: Option<RawCameraTruth>,
}

/// `[camera.truth]`: each key optional, the believed value where left out.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawCameraTruth {
    pub fx_px: Option<f64>,
    pub fy_px: Option<f64>,
    pub principal_point_px: Option<[f64; 2]>,
    pub distortion: Option<[f64; 5]>,
    pub tool_from_camera: Option<RawPose>,
    pub base_from_camera: Option<RawPose>,
}

/// `[camera.gstreamer]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawGstreamer {
    pub pipeline: String,
    #[serde(default)]
    pub appsink: Option<String>,
    #[serde(default)]
    pub exposure_us: Option<f64>,
    #[serde(default)]
    pub gain_db: Option<f64>,
    #[serde(default)]
    pub stall_periods: Option<i64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPose {
    pub translation_m: [f64; 3],
    pub rotation_rpy_deg: [f64; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawObject {
    pub mark_diameter_m: f64,
    pub marks_in_board_m: Vec<[f64; 2]>,
    /// Derived from the tag when none is written for it (`layers::tag_board`).
    #[serde(default)]
    pub board_extent_m: Option<[[f64; 2]; 2]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawDesired {
    pub joints_rad: Vec<f64>,
    pub camera_from_board: RawPose,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawController {
    pub law: RawLaw,
    pub q: toml::Value,
    pub r: toml::Value,
    pub r_units: RawInputUnits,
    #[serde(default)]
    pub interaction: Option<RawInteraction>,
    #[serde(default)]
    pub border_margin_px: Option<f64>,
    #[serde(default)]
    pub feedforward: Option<bool>,
    #[serde(default)]
    pub pose_gain_per_s: Option<f64>,
    #[serde(default)]
    pub pose_max_speed_m_s: Option<f64>,
    #[serde(default)]
    pub pose_max_rotation_rad_s: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawVision {
    #[serde(default = "undistort_by_default")]
    pub undistort: bool,
    pub threshold: toml::Value,
    pub min_mark_area_px: i64,
    pub max_mark_area_px: i64,
    pub max_elongation: f64,
    pub min_ellipse_fill: f64,
    pub gate_px: f64,
    pub render: RawRender,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRender {
    pub background_gray: f64,
    pub board_gray: f64,
    pub mark_gray: f64,
    pub noise_sigma_gray: f64,
    pub noise_seed: i64,
    pub lighting_gradient: [f64; 2],
    pub supersampling: i64,
    #[serde(default)]
    pub exposure_s: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlant {
    pub mode: RawPlantMode,
    pub rk4_substeps: i64,
    #[serde(default)]
    pub kinematic_follows: RawKinematicFollows,
    #[serde(default)]
    pub kinematic_lag_s: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawInterpolator {
    pub twist_hold: RawTwistHold,
    pub manipulability_threshold: f64,
    pub max_damping: f64,
    pub stale_twist_frames: f64,
    pub stop_ramp_s: f64,
    /// Optional: the arm's own (`robot.arm.acceleration_limits_rad_s2`, or the PUMA 560's) unless narrowed here.
    #[serde(default)]
    pub acceleration_limit_rad_s2: Option<Vec<f64>>,
    /// Optional caps on the tool's speed (m/s) and angular speed (rad/s), below the arm's own.
    #[serde(default)]
    pub tool_speed_limit_m_s: Option<f64>,
    #[serde(default)]
    pub tool_rotation_limit_rad_s: Option<f64>,
    /// Optional, so that a configuration written before seven-joint arms (an installed /etc/vservo/vservo.toml
    /// kept over an upgrade) still loads.
    #[serde(default)]
    pub null_space: RawNullSpace,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawNullSpace {
    pub limit_zone_rad: f64,
    pub limit_gain: f64,
    pub posture_rad: Option<Vec<f64>>,
    pub posture_gain: f64,
}

/// config/vservo.toml's values (vservo_settings::simulation::NullSpaceTask's defaults).
impl Default for RawNullSpace {
    fn default() -> Self {
        Self { limit_zone_rad: 0.3, limit_gain: 2.0, posture_rad: None, posture_gain: 0.5 }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawJointServo {
    pub law: RawJointServoLaw,
    pub kp: [f64; 6],
    pub kv: [f64; 6],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawScenario {
    pub duration_s: f64,
    pub initial_camera_translation_m: [f64; 3],
    pub initial_camera_rotation_deg: [f64; 3],
    pub object_motion: RawObjectMotion,
    pub step_at_s: f64,
    pub step_translation_m: [f64; 3],
    pub circle_radius_m: f64,
    pub circle_rev_per_min: f64,
    #[serde(default)]
    pub occlusions: Vec<RawOcclusion>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawOcclusion {
    pub mark: i64,
    pub from_s: f64,
    pub until_s: f64,
}

/// `[franka]`: the Franka driver (`robot.driver = "franka"`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawFranka {
    pub address: String,
    pub port: i64,
    pub simulator: bool,
    pub limit_rate: bool,
    pub answer_within_s: f64,
    pub hold_after_s: f64,
}

/// config/vservo.toml's documented defaults.
impl Default for RawFranka {
    fn default() -> Self {
        Self {
            address: "172.16.0.2".to_string(),
            port: 1337,
            simulator: false,
            limit_rate: true,
            answer_within_s: 0.0005,
            hold_after_s: 0.02,
        }
    }
}

/// `vision.undistort` when not written: the features are undistorted.
fn undistort_by_default() -> bool {
    true
}
