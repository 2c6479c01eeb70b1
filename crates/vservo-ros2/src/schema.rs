//! The ROS 2 message definitions of the bridge's messages, as a ROS 2 MCAP file carries them (schema encoding
//! `ros2msg`: the message's `.msg` text, then each type it uses after a line of 80 `=` and `MSG: pkg/Type`,
//! as `rosbag2` writes them), and the messages' CDR (message encoding `cdr`: the 4-byte encapsulation header
//! of little-endian CDR, then the body).

use crate::msg::RosType;

/// Every type the bridge's messages use: its package, name and definition (as ROS 2 Jazzy's packages define it,
/// comments left out), each from its declaration (`ros_message!` in msg.rs).
macro_rules! declared {
    ($($type:ty),* $(,)?) => {
        [$((<$type as Definition>::PACKAGE, <$type as Definition>::NAME, <$type as Definition>::DEFINITION)),*]
    };
}
const DECLARED: [(&str, &str, &str); 28] = {
    use crate::msg::*;
    declared![
        Time,
        Header,
        JointState,
        Vector3,
        Quaternion,
        Transform,
        TransformStamped,
        TfMessage,
        Image,
        RegionOfInterest,
        CameraInfo,
        Twist,
        TwistStamped,
        MultiArrayDimension,
        MultiArrayLayout,
        Float64MultiArray,
        KeyValue,
        DiagnosticStatus,
        DiagnosticArray,
        Point,
        Pose,
        Duration,
        ColorRgba,
        CompressedImage,
        UvCoordinate,
        MeshFile,
        Marker,
        MarkerArray,
    ]
};

fn definition(name: &str) -> Option<&'static str> {
    DECLARED
        .iter()
        .find(|(package, type_name, _)| name.split_once('/') == Some((*package, *type_name)))
        .map(|(_, _, text)| *text)
}

/// The types a definition's fields name (`pkg/Type`), in order of appearance.
fn used_types(text: &str) -> impl DoubleEndedIterator<Item = &str> {
    text.lines()
        .filter_map(|line| line.split_whitespace().next())
        .filter(|field_type| field_type.contains('/'))
        .map(|field_type| field_type.split('[').next().unwrap_or(field_type))
}

/// A type's MCAP schema name (`sensor_msgs/msg/JointState`).
pub fn schema_name<T: RosType>() -> String {
    format!("{}/msg/{}", T::PACKAGE, T::NAME)
}

/// A type's `ros2msg` schema: its definition, then every type it uses, depth first, each once.
pub fn schema_text<T: RosType>() -> String {
    let name = format!("{}/{}", T::PACKAGE, T::NAME);
    let mut text = definition(&name).unwrap_or_default().to_string();
    let mut done = vec![name.clone()];
    let mut pending: Vec<String> = used_types(&text).rev().map(str::to_string).collect();
    while let Some(used) = pending.pop() {
        if done.contains(&used) {
            continue;
        }
        let Some(body) = definition(&used) else { continue };
        text.push_str(&format!("{}\nMSG: {used}\n{body}", "=".repeat(80)));
        pending.extend(used_types(body).rev().map(str::to_string));
        done.push(used);
    }
    text
}

/// A topic's message type: its MCAP schema name and `ros2msg` text.
pub fn of_topic(topic: vservo_config::Ros2Topic) -> (String, String) {
    use crate::msg::{
        CameraInfo, DiagnosticArray, Float64MultiArray, Image, JointState, MarkerArray, TfMessage,
        TwistStamped,
    };
    use vservo_config::Ros2Topic;
    fn both<T: RosType>() -> (String, String) {
        (schema_name::<T>(), schema_text::<T>())
    }
    match topic {
        Ros2Topic::JointStates => both::<JointState>(),
        Ros2Topic::Tf | Ros2Topic::TfStatic => both::<TfMessage>(),
        Ros2Topic::Image => both::<Image>(),
        Ros2Topic::CameraInfo => both::<CameraInfo>(),
        Ros2Topic::Features => both::<Float64MultiArray>(),
        Ros2Topic::CameraTwist => both::<TwistStamped>(),
        Ros2Topic::Diagnostics => both::<DiagnosticArray>(),
        Ros2Topic::Obstacles => both::<MarkerArray>(),
    }
}

/// A message's CDR as ROS 2 writes it to a bag: the encapsulation header of little-endian CDR, then the body.
pub fn cdr<T: RosType>(message: &T) -> Result<Vec<u8>, cdr_encoding::Error> {
    let body = cdr_encoding::to_vec::<T, byteorder::LittleEndian>(message)?;
    let mut bytes = Vec::with_capacity(4 + body.len());
    bytes.extend_from_slice(&[0x00, 0x01, 0x00, 0x00]);
    bytes.extend_from_slice(&body);
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{
        CameraInfo, DiagnosticArray, Float64MultiArray, Header, Image, JointState, MarkerArray, TfMessage,
        Time, TwistStamped,
    };

    /// Whether every type a message's schema uses is defined here.
    fn fully_defined<T: RosType>() -> bool {
        let text = schema_text::<T>();
        let defined = |used: &str| definition(used).is_some();
        text.split(&"=".repeat(80)).all(|part| used_types(part).all(defined))
            && definition(&format!("{}/{}", T::PACKAGE, T::NAME)).is_some()
    }

    #[test]
    fn every_schema_is_complete() {
        assert!(fully_defined::<JointState>());
        assert!(fully_defined::<TfMessage>());
        assert!(fully_defined::<Image>());
        assert!(fully_defined::<CameraInfo>());
        assert!(fully_defined::<Float64MultiArray>());
        assert!(fully_defined::<TwistStamped>());
        assert!(fully_defined::<DiagnosticArray>());
        assert!(fully_defined::<MarkerArray>());
    }

    /// A marker's `.msg` text as ROS 2 Jazzy's visualization_msgs/msg/Marker.msg has it (comments left out;
    /// Jazzy's `ARROW_STRIP=12`, which Humble lacks, left out too: constants are not on the wire), the Rust
    /// field `kind` written as `type`.
    #[test]
    fn a_markers_definition_is_the_msg_files() {
        let text = <crate::msg::Marker as crate::msg::Definition>::DEFINITION;
        let fields: Vec<&str> = text.lines().filter(|line| !line.contains('=')).collect();
        assert_eq!(
            fields,
            [
                "std_msgs/Header header",
                "string ns",
                "int32 id",
                "int32 type",
                "int32 action",
                "geometry_msgs/Pose pose",
                "geometry_msgs/Vector3 scale",
                "std_msgs/ColorRGBA color",
                "builtin_interfaces/Duration lifetime",
                "bool frame_locked",
                "geometry_msgs/Point[] points",
                "std_msgs/ColorRGBA[] colors",
                "string texture_resource",
                "sensor_msgs/CompressedImage texture",
                "visualization_msgs/UVCoordinate[] uv_coordinates",
                "string text",
                "string mesh_resource",
                "visualization_msgs/MeshFile mesh_file",
                "bool mesh_use_embedded_materials",
            ]
        );
        assert!(text.starts_with("int32 ARROW=0\nint32 CUBE=1\n"));
    }

    #[test]
    fn a_schema_lists_each_type_it_uses_once() {
        let text = schema_text::<TfMessage>();
        assert!(text.starts_with("geometry_msgs/TransformStamped[] transforms\n"));
        for used in
            ["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Transform", "geometry_msgs/Vector3"]
        {
            assert_eq!(text.matches(&format!("MSG: {used}\n")).count(), 1, "{used} in {text}");
        }
        assert_eq!(schema_name::<TfMessage>(), "tf2_msgs/msg/TFMessage");
    }

    #[test]
    fn cdr_of_a_joint_state_by_hand() {
        let message = JointState {
            header: Header { stamp: Time { sec: 1, nanosec: 2 }, frame_id: "b".into() },
            name: vec!["j".into()],
            position: vec![0.5],
            velocity: vec![],
            effort: vec![],
        };
        let bytes = cdr(&message).expect("serializes");
        let expected: Vec<u8> = [
            &[0, 1, 0, 0][..],     // encapsulation: CDR, little-endian
            &1i32.to_le_bytes(),   // stamp.sec
            &2u32.to_le_bytes(),   // stamp.nanosec
            &2u32.to_le_bytes(),   // frame_id: length with the NUL
            b"b\0",                //
            &[0, 0],               // to 4
            &1u32.to_le_bytes(),   // name: one string
            &2u32.to_le_bytes(),   //
            b"j\0",                //
            &[0, 0],               // to 4
            &1u32.to_le_bytes(),   // position: one, its float at 32 from the body's start (8-aligned)
            &0.5f64.to_le_bytes(), //
            &0u32.to_le_bytes(),   // velocity, effort: none
            &0u32.to_le_bytes(),
        ]
        .concat();
        assert_eq!(bytes, expected);
    }
}
