//! The QoS of each kind of topic, as ROS 2's own profiles set them (rmw's `qos_profiles.h`): sensor data
//! best effort, the rest reliable.

use ros2_client::QosProfile;
use ros2_client::qos::{Durability, History, Reliability, WhenFull};

/// What a reliable publisher does when its window is full of unacknowledged samples: refuse the new one at
/// once (the bridge counts it) rather than block.
const DONT_BLOCK: Reliability = Reliability::Reliable { when_full: WhenFull::Fail };

/// `rmw_qos_profile_sensor_data`: images, camera info, joint states, features and twists: best effort,
/// the last 5.
pub const SENSOR_DATA: QosProfile = QosProfile::publisher_default()
    .reliability(Reliability::BestEffort)
    .durability(Durability::Volatile)
    .history(History::KeepLast { depth: 5 });

/// `rmw_qos_profile_default`: reliable, volatile, the last 10 (`diagnostics`).
pub const RELIABLE: QosProfile = QosProfile::publisher_default()
    .reliability(DONT_BLOCK)
    .durability(Durability::Volatile)
    .history(History::KeepLast { depth: 10 });

/// A ros2_control controller's commands (`rmw_qos_profile_default`, what its subscriber asks): reliable,
/// volatile, the last 10.
pub const COMMANDS: QosProfile = RELIABLE;

/// tf2's broadcaster: reliable, the last 100.
pub const TF: QosProfile = QosProfile::publisher_default()
    .reliability(DONT_BLOCK)
    .durability(Durability::Volatile)
    .history(History::KeepLast { depth: 100 });

/// `rmw_qos_profile_services_default`: reliable, volatile, the last 10.
pub const SERVICES: QosProfile = RELIABLE;
