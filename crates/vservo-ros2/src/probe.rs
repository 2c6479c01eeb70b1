//! Hearing a ROS 2 arm from outside the driver: the joint names its `sensor_msgs/JointState` stream
//! carries (`vservoctl check` compares them with the names the driver looks for).

use std::time::{Duration, Instant};

use ros2_client::{MessageTypeName, Name};
use vservo_config::Ros2;

use crate::msg::{Definition, JointState};
use crate::qos;

/// The names in the first joint state heard on `topic` (absolute) within `window`; `None` when none came.
pub fn joint_state_names(
    settings: &Ros2,
    topic: &str,
    window: Duration,
) -> anyhow::Result<Option<Vec<String>>> {
    let (_context, mut node) = crate::domain::node(settings, "vservoctl_check")?;
    let name = Name::parse(topic).map_err(|e| anyhow::anyhow!("the ROS name {topic:?}: {e:?}"))?;
    let ros_topic = node
        .create_topic(&name, MessageTypeName::new(JointState::PACKAGE, JointState::NAME), &qos::SENSOR_DATA)
        .map_err(|e| anyhow::anyhow!("the topic {topic}: {e:?}"))?;
    let subscription = node
        .create_subscription::<JointState>(&ros_topic, None)
        .map_err(|e| anyhow::anyhow!("subscribing to {topic}: {e:?}"))?;
    let until = Instant::now() + window;
    while Instant::now() < until {
        if let Ok(Some((state, _))) = subscription.take() {
            return Ok(Some(state.name));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(None)
}
