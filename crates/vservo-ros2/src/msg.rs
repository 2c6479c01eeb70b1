//! The ROS 2 messages the bridge speaks, as serde structures in their `.msg` files' field order: serialized
//! by ros2-client as CDR (XCDR1, little-endian), they are what a ROS 2 node of that type reads. Each type
//! names its package and message ([`RosType`]); on the wire DDS calls it `<package>::msg::dds_::<Name>_`.

use serde::{Deserialize, Serialize};

/// A ROS 2 message type: its package and name (`sensor_msgs`, `JointState`).
pub trait RosType: ros2_client::Message {
    /// The package.
    const PACKAGE: &'static str;
    /// The message's name in its package.
    const NAME: &'static str;

    /// The DDS type name ROS 2 puts on the wire.
    fn dds_type_name() -> String {
        format!("{}::msg::dds_::{}_", Self::PACKAGE, Self::NAME)
    }
}

macro_rules! ros_type {
    ($type:ident, $package:literal, $name:literal) => {
        impl ros2_client::Message for $type {}
        impl RosType for $type {
            const PACKAGE: &'static str = $package;
            const NAME: &'static str = $name;
        }
    };
}

/// `builtin_interfaces/Time`: seconds and nanoseconds since 1970 (ROS time is the system clock's).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds past them, below 10⁹.
    pub nanosec: u32,
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The frame it is in.
    pub frame_id: String,
}

/// `sensor_msgs/JointState`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// When the joints were measured.
    pub header: Header,
    /// The joints' names.
    pub name: Vec<String>,
    /// Angles (rad).
    pub position: Vec<f64>,
    /// Rates (rad/s).
    pub velocity: Vec<f64>,
    /// Torques (N·m).
    pub effort: Vec<f64>,
}
ros_type!(JointState, "sensor_msgs", "JointState");

/// `geometry_msgs/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Quaternion`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

/// `geometry_msgs/Transform`: the child frame's pose in the parent's.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// The child's origin in the parent frame (m).
    pub translation: Vector3,
    /// The child's orientation in the parent frame.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// When, and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// parent_from_child.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}
ros_type!(TfMessage, "tf2_msgs", "TFMessage");

/// `sensor_msgs/Image`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// The exposure's time and the camera's optical frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// The pixel format (`mono8`).
    pub encoding: String,
    /// 0: little-endian.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// The pixels, row by row.
    pub data: Vec<u8>,
}
ros_type!(Image, "sensor_msgs", "Image");

/// `sensor_msgs/RegionOfInterest`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left column.
    pub x_offset: u32,
    /// Top row.
    pub y_offset: u32,
    /// Rows (0: the whole image).
    pub height: u32,
    /// Columns (0: the whole image).
    pub width: u32,
    /// Whether the region is of the rectified image.
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// As the images'.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// `plumb_bob`: OpenCV's k1, k2, p1, p2, k3.
    pub distortion_model: String,
    /// The distortion coefficients.
    pub d: Vec<f64>,
    /// The camera matrix, row-major.
    pub k: [f64; 9],
    /// The rectification (identity for a monocular camera).
    pub r: [f64; 9],
    /// The projection matrix, row-major.
    pub p: [f64; 12],
    /// Binning (0: none).
    pub binning_x: u32,
    /// Binning (0: none).
    pub binning_y: u32,
    /// The region (zero: the whole image).
    pub roi: RegionOfInterest,
}
ros_type!(CameraInfo, "sensor_msgs", "CameraInfo");

/// `geometry_msgs/Twist`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// m/s.
    pub linear: Vector3,
    /// rad/s.
    pub angular: Vector3,
}

/// `geometry_msgs/TwistStamped`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// When, and the frame the twist is in.
    pub header: Header,
    /// The twist.
    pub twist: Twist,
}
ros_type!(TwistStamped, "geometry_msgs", "TwistStamped");

/// `std_msgs/MultiArrayDimension`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// What the dimension counts.
    pub label: String,
    /// Its length.
    pub size: u32,
    /// The elements one step spans.
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// Outermost first.
    pub dim: Vec<MultiArrayDimension>,
    /// Elements before the first.
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// How `data` is laid out.
    pub layout: MultiArrayLayout,
    /// The values.
    pub data: Vec<f64>,
}
ros_type!(Float64MultiArray, "std_msgs", "Float64MultiArray");

/// `diagnostic_msgs/KeyValue`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeyValue {
    /// The name.
    pub key: String,
    /// The value, as text.
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`DiagnosticStatus::OK`], `WARN`, `ERROR` or `STALE`.
    pub level: u8,
    /// What it is about.
    pub name: String,
    /// A line for people.
    pub message: String,
    /// The hardware.
    pub hardware_id: String,
    /// The figures.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// All is well.
    pub const OK: u8 = 0;
    /// Working, with something to look at.
    pub const WARN: u8 = 1;
    /// Not working.
    pub const ERROR: u8 = 2;
    /// No recent data.
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// When.
    pub header: Header,
    /// One status per part.
    pub status: Vec<DiagnosticStatus>,
}
ros_type!(DiagnosticArray, "diagnostic_msgs", "DiagnosticArray");

/// `std_srvs/Trigger`'s request: no field (IDL structures need one member, which ROS 2 adds).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TriggerRequest {
    /// Always 0.
    pub structure_needs_at_least_one_member: u8,
}
impl ros2_client::Message for TriggerRequest {}

/// `std_srvs/Trigger`'s response.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TriggerResponse {
    /// Whether it was done.
    pub success: bool,
    /// What was done, or why not.
    pub message: String,
}
impl ros2_client::Message for TriggerResponse {}

/// `geometry_msgs/Point`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// The origin.
    pub position: Point,
    /// The orientation.
    pub orientation: Quaternion,
}

/// `vservo_msgs/SetTargetFeatures`'s request (clients/ros2/vservo_msgs): ξ_d in ROS's pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SetTargetFeaturesRequest {
    /// [x₁ y₁ … x₄ y₄] (px, a pixel's centre at whole coordinates, the lens's distortion taken out).
    pub features_px: [f64; 8],
}
impl ros2_client::Message for SetTargetFeaturesRequest {}

/// `vservo_msgs/SetTargetPose`'s request: where the camera should see the target.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SetTargetPoseRequest {
    /// The target's pose in the desired camera frame (m; a unit quaternion).
    pub camera_from_target: Pose,
}
impl ros2_client::Message for SetTargetPoseRequest {}

/// The response of `vservo_msgs/SetTargetFeatures` and `SetTargetPose` (the same fields).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetTargetResponse {
    /// Whether the daemon took the target.
    pub accepted: bool,
    /// Why not, or what was done.
    pub reason: String,
    /// The gains version in force after it.
    pub gains_version: u64,
    /// ξ_d in force after it (ROS's pixels).
    pub target_features_px: [f64; 8],
}
impl ros2_client::Message for SetTargetResponse {}
