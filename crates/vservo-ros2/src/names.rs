//! The bridge's topic and service names, relative to its namespace as a ROS 2 node's are, and the DDS
//! names ROS 2 puts on the wire for them (`rt/` topics, `rq/…Request` and `rr/…Reply` services).

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
        Ros2Topic::Image => "camera/image_raw",
        Ros2Topic::CameraInfo => "camera/camera_info",
        Ros2Topic::Features => "vservo/features",
        Ros2Topic::CameraTwist => "vservo/camera_twist",
        Ros2Topic::Diagnostics => "diagnostics",
    }
}

/// A name in the namespace (`""` or `/a/b`), as an absolute ROS name.
pub fn absolute(namespace: &str, relative: &str) -> String {
    format!("{namespace}/{relative}")
}

/// The DDS topic a ROS 2 topic is on.
pub fn dds_topic(namespace: &str, relative: &str) -> String {
    format!("rt{}", absolute(namespace, relative))
}

/// The DDS topics of a ROS 2 service: its requests and its replies.
pub fn dds_service(namespace: &str, relative: &str) -> (String, String) {
    let name = absolute(namespace, relative);
    (format!("rq{name}Request"), format!("rr{name}Reply"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_names_follow_ros2() {
        assert_eq!(dds_topic("", topic(Ros2Topic::JointStates)), "rt/joint_states");
        assert_eq!(dds_topic("/cell1", topic(Ros2Topic::Image)), "rt/cell1/camera/image_raw");
        assert_eq!(
            dds_service("", SAFE_STOP),
            ("rq/vservo/safe_stopRequest".to_string(), "rr/vservo/safe_stopReply".to_string())
        );
    }

    #[test]
    fn every_topic_has_its_own_name() {
        let names: std::collections::BTreeSet<_> = Ros2Topic::ALL.iter().map(|t| topic(*t)).collect();
        assert_eq!(names.len(), Ros2Topic::ALL.len());
    }
}
