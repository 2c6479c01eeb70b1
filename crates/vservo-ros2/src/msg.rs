//! The ROS 2 messages the bridge speaks, as serde structures in their `.msg` files' field order: serialized
//! by ros2-client as CDR (XCDR1, little-endian), they are what a ROS 2 node of that type reads. Each type
//! names its package and message ([`RosType`]); on the wire DDS calls it `<package>::msg::dds_::<Name>_`.
//! Each type is declared once ([`ros_message!`]): the struct's fields with their ROS types, from which its
//! `.msg` definition ([`Definition`]) is made, the text a bag (crate::schema) and clients/ros2/vservo_msgs carry.

use serde::{Deserialize, Serialize};

/// A ROS 2 type as its `.msg` file declares it: its package, its name and its definition (the fields, one per
/// line as `<ros type> <field>`, after its constants), all from one [`ros_message!`] declaration.
pub trait Definition {
    /// The package.
    const PACKAGE: &'static str;
    /// The type's name in its package.
    const NAME: &'static str;
    /// The `.msg` text: constants, then fields, in the struct's (and so the CDR's) order; comments left out.
    const DEFINITION: &'static str;
}

/// A ROS 2 message type that goes on a topic.
pub trait RosType: ros2_client::Message + Definition {
    /// The DDS type name ROS 2 puts on the wire.
    fn dds_type_name() -> String {
        format!("{}::msg::dds_::{}_", Self::PACKAGE, Self::NAME)
    }
}

/// Declares a ROS 2 type once: the serde struct in the `.msg` file's field order, each field with its ROS type,
/// and its [`Definition`] made from the same lines, so that the struct (and its CDR) and the text a bag or a
/// ROS tool reads cannot drift apart.
macro_rules! ros_message {
    (
        $(#[$meta:meta])*
        pub struct $type:ident = $package:literal / $name:literal {
            $( $(#[$field_meta:meta])* $field:ident $(as $ros_field:literal)? : $field_type:ty = $ros_type:literal, )*
        }
        $(constants $constants:literal;)?
    ) => {
        $(#[$meta])*
        #[derive(Serialize, Deserialize)]
        pub struct $type {
            $( $(#[$field_meta])* pub $field: $field_type, )*
        }

        impl Definition for $type {
            const PACKAGE: &'static str = $package;
            const NAME: &'static str = $name;
            const DEFINITION: &'static str =
                concat!($($constants,)? $( $ros_type, " ", ros_field_name!($field $(, $ros_field)?), "\n", )*);
        }
    };
}

/// A field's name in the `.msg` file: the Rust field's, or the one given with `as` (a ROS name that is a Rust
/// keyword, such as a marker's `type`).
macro_rules! ros_field_name {
    ($field:ident) => {
        stringify!($field)
    };
    ($field:ident, $ros_field:literal) => {
        $ros_field
    };
}

macro_rules! ros_type {
    ($type:ident) => {
        impl ros2_client::Message for $type {}
        impl RosType for $type {}
    };
}

ros_message! {
    /// `builtin_interfaces/Time`: seconds and nanoseconds since 1970 (ROS time is the system clock's).
    #[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
    pub struct Time = "builtin_interfaces" / "Time" {
        /// Whole seconds.
        sec: i32 = "int32",
        /// Nanoseconds past them, below 10⁹.
        nanosec: u32 = "uint32",
    }
}

ros_message! {
    /// `std_msgs/Header`.
    #[derive(Debug, Clone, Default, PartialEq, Eq)]
    pub struct Header = "std_msgs" / "Header" {
        /// When the data was taken.
        stamp: Time = "builtin_interfaces/Time",
        /// The frame it is in.
        frame_id: String = "string",
    }
}

ros_message! {
    /// `sensor_msgs/JointState`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct JointState = "sensor_msgs" / "JointState" {
        /// When the joints were measured.
        header: Header = "std_msgs/Header",
        /// The joints' names.
        name: Vec<String> = "string[]",
        /// Angles (rad).
        position: Vec<f64> = "float64[]",
        /// Rates (rad/s).
        velocity: Vec<f64> = "float64[]",
        /// Torques (N·m).
        effort: Vec<f64> = "float64[]",
    }
}
ros_type!(JointState);

ros_message! {
    /// `geometry_msgs/Vector3`.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct Vector3 = "geometry_msgs" / "Vector3" {
        /// x.
        x: f64 = "float64",
        /// y.
        y: f64 = "float64",
        /// z.
        z: f64 = "float64",
    }
}

ros_message! {
    /// `geometry_msgs/Quaternion`.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct Quaternion = "geometry_msgs" / "Quaternion" {
        /// x.
        x: f64 = "float64",
        /// y.
        y: f64 = "float64",
        /// z.
        z: f64 = "float64",
        /// w.
        w: f64 = "float64",
    }
}

ros_message! {
    /// `geometry_msgs/Transform`: the child frame's pose in the parent's.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct Transform = "geometry_msgs" / "Transform" {
        /// The child's origin in the parent frame (m).
        translation: Vector3 = "geometry_msgs/Vector3",
        /// The child's orientation in the parent frame.
        rotation: Quaternion = "geometry_msgs/Quaternion",
    }
}

ros_message! {
    /// `geometry_msgs/TransformStamped`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct TransformStamped = "geometry_msgs" / "TransformStamped" {
        /// When, and the parent frame.
        header: Header = "std_msgs/Header",
        /// The child frame.
        child_frame_id: String = "string",
        /// parent_from_child.
        transform: Transform = "geometry_msgs/Transform",
    }
}

ros_message! {
    /// `tf2_msgs/TFMessage`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct TfMessage = "tf2_msgs" / "TFMessage" {
        /// The transforms.
        transforms: Vec<TransformStamped> = "geometry_msgs/TransformStamped[]",
    }
}
ros_type!(TfMessage);

ros_message! {
    /// `sensor_msgs/Image`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct Image = "sensor_msgs" / "Image" {
        /// The exposure's time and the camera's optical frame.
        header: Header = "std_msgs/Header",
        /// Rows.
        height: u32 = "uint32",
        /// Columns.
        width: u32 = "uint32",
        /// The pixel format (`mono8`).
        encoding: String = "string",
        /// 0: little-endian.
        is_bigendian: u8 = "uint8",
        /// Bytes per row.
        step: u32 = "uint32",
        /// The pixels, row by row.
        data: Vec<u8> = "uint8[]",
    }
}
ros_type!(Image);

ros_message! {
    /// `sensor_msgs/RegionOfInterest`.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct RegionOfInterest = "sensor_msgs" / "RegionOfInterest" {
        /// Left column.
        x_offset: u32 = "uint32",
        /// Top row.
        y_offset: u32 = "uint32",
        /// Rows (0: the whole image).
        height: u32 = "uint32",
        /// Columns (0: the whole image).
        width: u32 = "uint32",
        /// Whether the region is of the rectified image.
        do_rectify: bool = "bool",
    }
}

ros_message! {
    /// `sensor_msgs/CameraInfo`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct CameraInfo = "sensor_msgs" / "CameraInfo" {
        /// As the images'.
        header: Header = "std_msgs/Header",
        /// Rows.
        height: u32 = "uint32",
        /// Columns.
        width: u32 = "uint32",
        /// `plumb_bob`: OpenCV's k1, k2, p1, p2, k3.
        distortion_model: String = "string",
        /// The distortion coefficients.
        d: Vec<f64> = "float64[]",
        /// The camera matrix, row-major.
        k: [f64; 9] = "float64[9]",
        /// The rectification (identity for a monocular camera).
        r: [f64; 9] = "float64[9]",
        /// The projection matrix, row-major.
        p: [f64; 12] = "float64[12]",
        /// Binning (0: none).
        binning_x: u32 = "uint32",
        /// Binning (0: none).
        binning_y: u32 = "uint32",
        /// The region (zero: the whole image).
        roi: RegionOfInterest = "sensor_msgs/RegionOfInterest",
    }
}
ros_type!(CameraInfo);

ros_message! {
    /// `geometry_msgs/Twist`.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct Twist = "geometry_msgs" / "Twist" {
        /// m/s.
        linear: Vector3 = "geometry_msgs/Vector3",
        /// rad/s.
        angular: Vector3 = "geometry_msgs/Vector3",
    }
}

ros_message! {
    /// `geometry_msgs/TwistStamped`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct TwistStamped = "geometry_msgs" / "TwistStamped" {
        /// When, and the frame the twist is in.
        header: Header = "std_msgs/Header",
        /// The twist.
        twist: Twist = "geometry_msgs/Twist",
    }
}
ros_type!(TwistStamped);

ros_message! {
    /// `std_msgs/MultiArrayDimension`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct MultiArrayDimension = "std_msgs" / "MultiArrayDimension" {
        /// What the dimension counts.
        label: String = "string",
        /// Its length.
        size: u32 = "uint32",
        /// The elements one step spans.
        stride: u32 = "uint32",
    }
}

ros_message! {
    /// `std_msgs/MultiArrayLayout`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct MultiArrayLayout = "std_msgs" / "MultiArrayLayout" {
        /// Outermost first.
        dim: Vec<MultiArrayDimension> = "std_msgs/MultiArrayDimension[]",
        /// Elements before the first.
        data_offset: u32 = "uint32",
    }
}

ros_message! {
    /// `std_msgs/Float64MultiArray`.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct Float64MultiArray = "std_msgs" / "Float64MultiArray" {
        /// How `data` is laid out.
        layout: MultiArrayLayout = "std_msgs/MultiArrayLayout",
        /// The values.
        data: Vec<f64> = "float64[]",
    }
}
ros_type!(Float64MultiArray);

ros_message! {
    /// `diagnostic_msgs/KeyValue`.
    #[derive(Debug, Clone, Default, PartialEq, Eq)]
    pub struct KeyValue = "diagnostic_msgs" / "KeyValue" {
        /// The name.
        key: String = "string",
        /// The value, as text.
        value: String = "string",
    }
}

ros_message! {
    /// `diagnostic_msgs/DiagnosticStatus`.
    #[derive(Debug, Clone, Default, PartialEq, Eq)]
    pub struct DiagnosticStatus = "diagnostic_msgs" / "DiagnosticStatus" {
        /// [`DiagnosticStatus::OK`], `WARN`, `ERROR` or `STALE`.
        level: u8 = "byte",
        /// What it is about.
        name: String = "string",
        /// A line for people.
        message: String = "string",
        /// The hardware.
        hardware_id: String = "string",
        /// The figures.
        values: Vec<KeyValue> = "diagnostic_msgs/KeyValue[]",
    }
    constants "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n";
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

ros_message! {
    /// `diagnostic_msgs/DiagnosticArray`.
    #[derive(Debug, Clone, Default, PartialEq, Eq)]
    pub struct DiagnosticArray = "diagnostic_msgs" / "DiagnosticArray" {
        /// When.
        header: Header = "std_msgs/Header",
        /// One status per part.
        status: Vec<DiagnosticStatus> = "diagnostic_msgs/DiagnosticStatus[]",
    }
}
ros_type!(DiagnosticArray);

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

ros_message! {
    /// `geometry_msgs/Point`.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct Point = "geometry_msgs" / "Point" {
        /// x (m).
        x: f64 = "float64",
        /// y (m).
        y: f64 = "float64",
        /// z (m).
        z: f64 = "float64",
    }
}

ros_message! {
    /// `geometry_msgs/Pose`.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct Pose = "geometry_msgs" / "Pose" {
        /// The origin.
        position: Point = "geometry_msgs/Point",
        /// The orientation.
        orientation: Quaternion = "geometry_msgs/Quaternion",
    }
}

ros_message! {
    /// `vservo_msgs/SetTargetFeatures`'s request (clients/ros2/vservo_msgs): ξ_d in ROS's pixels.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct SetTargetFeaturesRequest = "vservo_msgs" / "SetTargetFeatures_Request" {
        /// [x₁ y₁ … x₄ y₄] (px, a pixel's centre at whole coordinates, the lens's distortion taken out).
        features_px: [f64; 8] = "float64[8]",
    }
}
impl ros2_client::Message for SetTargetFeaturesRequest {}

ros_message! {
    /// `vservo_msgs/SetTargetPose`'s request: where the camera should see the target.
    #[derive(Debug, Clone, Copy, Default, PartialEq)]
    pub struct SetTargetPoseRequest = "vservo_msgs" / "SetTargetPose_Request" {
        /// The target's pose in the desired camera frame (m; a unit quaternion).
        camera_from_target: Pose = "geometry_msgs/Pose",
    }
}
impl ros2_client::Message for SetTargetPoseRequest {}

ros_message! {
    /// The response of `vservo_msgs/SetTargetFeatures` and `SetTargetPose` (the same fields).
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct SetTargetResponse = "vservo_msgs" / "SetTarget_Response" {
        /// Whether the daemon took the target.
        accepted: bool = "bool",
        /// Why not, or what was done.
        reason: String = "string",
        /// The gains version in force after it.
        gains_version: u64 = "uint64",
        /// ξ_d in force after it (ROS's pixels).
        target_features_px: [f64; 8] = "float64[8]",
    }
}
impl ros2_client::Message for SetTargetResponse {}

mod markers;
pub use markers::{ColorRgba, CompressedImage, Duration, Marker, MarkerArray, MeshFile, UvCoordinate};

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.srv` file's lines that are not comments or blank.
    fn declared_lines(text: &str) -> String {
        text.lines()
            .filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
            .map(|l| format!("{l}\n"))
            .collect()
    }

    /// The vservo_msgs services a ROS user builds (clients/ros2/vservo_msgs/srv) are the structs the bridge
    /// serves: request, `---`, response, field by field.
    #[test]
    fn the_vservo_msgs_services_are_the_declared_structs() {
        let service = |request: &str| format!("{request}---\n{}", SetTargetResponse::DEFINITION);
        assert_eq!(
            declared_lines(include_str!("../../../clients/ros2/vservo_msgs/srv/SetTargetFeatures.srv")),
            service(SetTargetFeaturesRequest::DEFINITION)
        );
        assert_eq!(
            declared_lines(include_str!("../../../clients/ros2/vservo_msgs/srv/SetTargetPose.srv")),
            service(SetTargetPoseRequest::DEFINITION)
        );
    }

    /// A declaration's definition is its fields in order, after its constants.
    #[test]
    fn a_definition_is_the_declared_fields_in_order() {
        assert_eq!(Header::DEFINITION, "builtin_interfaces/Time stamp\nstring frame_id\n");
        assert!(
            DiagnosticStatus::DEFINITION
                .starts_with("byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\n")
        );
        assert_eq!((JointState::PACKAGE, JointState::NAME), ("sensor_msgs", "JointState"));
        assert_eq!(TfMessage::dds_type_name(), "tf2_msgs::msg::dds_::TFMessage_");
    }
}
