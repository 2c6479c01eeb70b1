//! The bridge's topic and service names, relative to its namespace as a ROS 2 node's are (ros2-client puts
//! them on the wire as ROS 2 does: `rt/` topics, `rq/…Request` and `rr/…Reply` services).

use vservo_config::Ros2Topic;

/// The bridge's node name.
pub const NODE: &str = "vservo";

/// The service that brings the arm to rest (always served).
pub const SAFE_STOP: &str = "vservo/safe_stop";
/// The service that ends a safe stop (served only with `[ros2] allow_motion`).
pub const RESUME: &str = "vservo/resume";

/// The service that sets ξ_d (served only with `[ros2] allow_motion`).
pub const SET_TARGET_FEATURES: &str = "vservo/set_target_features";
/// The service that sets the camera's desired pose relative to the target (only with `allow_motion`).
pub const SET_TARGET_POSE: &str = "vservo/set_target_pose";

/// A topic's name relative to the namespace.
pub fn topic(topic: Ros2Topic) -> &'static str {
    match topic {
        Ros2Topic::JointStates => "joint_states",
        Ros2Topic::Tf => "tf",
        Ros2Topic::TfStatic => "tf_static",
        Ros2Topic::Image => "camera/image_raw",
        Ros2Topic::CameraInfo => "camera/camera_info",
        Ros2Topic::Features => "vservo/features",
        Ros2Topic::CameraTwist => "vservo/camera_twist",
        Ros2Topic::Diagnostics => "diagnostics",
        Ros2Topic::Obstacles => "vservo/obstacles",
    }
}

/// A name in the namespace (`""` or `/a/b`), as an absolute ROS name.
pub fn absolute(namespace: &str, relative: &str) -> String {
    format!("{namespace}/{relative}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The DDS names ros2-client gives our names: ROS 2's (`rt/` topics, `rq/…Request` services).
    #[test]
    fn wire_names_follow_ros2() {
        let node = ros2_client::NodeName::new("/", NODE).expect("a node name");
        let dds = |namespace: &str, relative: &str, prefix: &str, suffix: &str| {
            let name = ros2_client::Name::parse(&absolute(namespace, relative)).expect("a ROS name");
            name.to_dds_name(prefix, &node, suffix)
        };
        assert_eq!(dds("", topic(Ros2Topic::JointStates), "rt", ""), "rt/joint_states");
        assert_eq!(dds("/cell1", topic(Ros2Topic::Image), "rt", ""), "rt/cell1/camera/image_raw");
        assert_eq!(dds("", SAFE_STOP, "rq", "Request"), "rq/vservo/safe_stopRequest");
    }

    #[test]
    fn every_topic_has_its_own_name() {
        let names: std::collections::BTreeSet<_> = Ros2Topic::ALL.iter().map(|t| topic(*t)).collect();
        assert_eq!(names.len(), Ros2Topic::ALL.len());
    }
}
