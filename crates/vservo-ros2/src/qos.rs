//! The QoS of each kind of topic. What the bridge publishes is reliable (a reliable writer is heard by reliable
//! and best-effort subscribers alike; a best-effort one by best-effort subscribers only, and a ROS node that
//! subscribes with the default profile — `robot_state_publisher`, `image_transport`'s raw subscriber, most tools
//! — asks for reliable) and never blocks: a sample a slow reader has not acknowledged is refused and counted.
//! What the ROS 2 driver reads is best effort (`rmw_qos_profile_sensor_data`), which matches writers of either
//! reliability. A topic's reliability, durability and depth can be written in `[ros2.qos.<topic>]`
//! ([`as_written`]).

use ros2_client::QosProfile;
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use vservo_config::{QosDurability, QosReliability, TopicQos};

/// `default` with what `[ros2.qos.<topic>]` writes in place of its own (a reliable writer still never blocks).
pub fn as_written(default: QosProfile, written: TopicQos) -> QosProfile {
    let mut qos = default;
    if let Some(reliability) = written.reliability {
        qos = qos.reliability(match reliability {
            QosReliability::Reliable => DONT_BLOCK,
            QosReliability::BestEffort => Reliability::BestEffort,
        });
    }
    if let Some(durability) = written.durability {
        qos = qos.durability(match durability {
            QosDurability::Volatile => Durability::Volatile,
            QosDurability::TransientLocal => Durability::TransientLocal,
        });
    }
    if let Some(depth) = written.depth {
        qos = qos.history(History::KeepLast { depth: depth as usize });
    }
    qos
}

/// What a reliable publisher does when its window is full of unacknowledged samples: refuse the new one at
/// once (the bridge counts it) rather than block.
const DONT_BLOCK: Reliability = Reliability::Reliable { when_full: WhenFull::Fail };

/// The bridge's streams (joint states, the image and camera info, features, twists): reliable without blocking,
/// volatile, the last 5.
pub const STREAMS: QosProfile = QosProfile::publisher_default()
    .reliability(DONT_BLOCK)
    .durability(Durability::Volatile)
    .history(History::KeepLast { depth: 5 });

/// `rmw_qos_profile_sensor_data`: what the ROS 2 driver reads (the arm's joint states, the camera's images):
/// best effort, the last 5.
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

/// tf2's static broadcaster: reliable, transient local (a reader that joins later gets the last), the last 1.
pub const TF_STATIC: QosProfile = QosProfile::publisher_default()
    .reliability(DONT_BLOCK)
    .durability(Durability::TransientLocal)
    .history(History::KeepLast { depth: 1 });

/// `rmw_qos_profile_services_default`: reliable, volatile, the last 10.
pub const SERVICES: QosProfile = RELIABLE;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_is_written_takes_the_place_of_the_default_and_the_rest_stays() {
        let written =
            TopicQos { reliability: Some(QosReliability::BestEffort), durability: None, depth: Some(1) };
        let qos = as_written(STREAMS, written);
        assert_eq!(qos.reliability, Reliability::BestEffort);
        assert_eq!(qos.durability, Durability::Volatile);
        assert_eq!(qos.history, History::KeepLast { depth: 1 });
        let latched = as_written(
            STREAMS,
            TopicQos { durability: Some(QosDurability::TransientLocal), ..TopicQos::default() },
        );
        assert_eq!(latched.reliability, DONT_BLOCK);
        assert_eq!(latched.durability, Durability::TransientLocal);
        assert_eq!(as_written(TF_STATIC, TopicQos::default()), TF_STATIC);
    }
}
