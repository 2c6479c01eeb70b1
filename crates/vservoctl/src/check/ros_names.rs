//! The ROS 2 arm's joint names, heard on its joint states beside the instance's services: only where the
//! ROS 2 driver drives the arm (`[ros2.driver] arm`), on a thread of its own while the instance is watched.

use std::thread::JoinHandle;
use std::time::Duration;

use vservo_config::Config;

/// The listener, if one runs.
pub struct Listening(Option<JoinHandle<Option<Vec<String>>>>);

/// Starts listening for `window` on the arm's joint-states topic, if the ROS 2 driver drives the arm.
pub fn listen(config: &Config, window: Duration) -> Listening {
    if config.cell.robot.driver != vservo_config::RobotDriver::Ros2 {
        return Listening(None);
    }
    let settings = config.ros2.clone();
    let topic = config.ros2.driver.joint_states_topic.clone();
    Listening(Some(std::thread::spawn(move || {
        // not heard (no arm node, or DDS refused): the check says what the driver saw instead
        vservo_ros2::probe::joint_state_names(&settings, &topic, window).ok().flatten()
    })))
}

impl Listening {
    /// The names heard; `None` when not listening or none came.
    pub fn join(self) -> Option<Vec<String>> {
        self.0.and_then(|handle| handle.join().ok().flatten())
    }
}
