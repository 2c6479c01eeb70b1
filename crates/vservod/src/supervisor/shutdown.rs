//! The shutdown order: stop the servo and vision first (the servo's last twist is zero), let the rmrc ramp
//! the arm to rest at its acceleration limits while the plant runs, then stop the rmrc and the plant.
//! Nodes that do not exit in time are killed. The order and the at-rest decision are pure
//! ([`STOP_ORDER`], [`at_rest`]); [`stop_safely`] carries them out.

use std::time::{Duration, Instant};

use nix::sys::signal::Signal;
use vservo_protocol::{JointCommandMsg, JointStateMsg, NodeRole};
use vservo_runtime::AT_REST_RAD_S;

use super::launch::Supervised;
use super::observe::{LoopHeard, Ports};
use crate::faults::FaultMonitor;

/// The nodes in the order they stop, in two steps: first those that command motion, then — once the arm
/// is at rest, or the time is up — those that bring it to rest and hold it.
pub const STOP_ORDER: [[NodeRole; 2]; 2] =
    [[NodeRole::Servo, NodeRole::Vision], [NodeRole::Rmrc, NodeRole::Plant]];
/// How long the servo and vision get to exit after SIGTERM before they are killed.
const FIRST_STEP_EXIT: Duration = Duration::from_millis(400);
/// How long the rmrc and the plant get to exit after SIGTERM before they are killed.
const SECOND_STEP_EXIT: Duration = Duration::from_millis(300);
/// How long a killed node gets to be reaped.
const KILLED_EXIT: Duration = Duration::from_millis(100);
/// How often the arm's speed is looked at while it comes to rest.
const REST_POLL: Duration = Duration::from_millis(10);

/// The fastest reference and measured joint speeds (rad/s) of a command and a state, over the joints each
/// says it carries (`joint_count`; the slots past them are not the arm's).
pub fn speeds(command: &JointCommandMsg, state: &JointStateMsg) -> (f64, f64) {
    let fastest = |v: &[f64; vservo_protocol::MAX_JOINTS], count: u32| {
        let count = (count as usize).min(vservo_protocol::MAX_JOINTS);
        v[..count].iter().fold(0.0f64, |m, x| m.max(x.abs()))
    };
    (fastest(&command.qd_ref_rad_s, command.joint_count), fastest(&state.qd_rad_s, state.joint_count))
}

/// The arm is at rest: the rmrc's reference has stopped and no joint moves faster than
/// [`AT_REST_RAD_S`] (the nodes' own rule when they outlive the daemon).
pub fn at_rest((reference_rad_s, joint_rad_s): (f64, f64)) -> bool {
    reference_rad_s == 0.0 && joint_rad_s < AT_REST_RAD_S
}

/// Stops every node in [`STOP_ORDER`], the arm brought to rest in between (at most `timeout`).
pub fn stop_safely(
    nodes: &mut [Supervised],
    ports: &Ports,
    heard: &mut LoopHeard,
    timeout: Duration,
    monitor: &mut FaultMonitor,
) {
    let started = Instant::now();
    let [first, second] = STOP_ORDER;
    stop_roles(nodes, &first, FIRST_STEP_EXIT);
    let loop_alive =
        second.iter().all(|role| nodes.iter().any(|n| n.record.role == *role && n.process.is_some()));
    if loop_alive {
        match wait_for_rest(nodes, ports, heard, started + timeout, monitor) {
            Ok(speeds) => tracing::info!(
                after_s = started.elapsed().as_secs_f64(),
                joint_speed_rad_s = speeds.1,
                "the arm is at rest"
            ),
            Err(speeds) => tracing::warn!(
                timeout_s = timeout.as_secs_f64(),
                reference_speed_rad_s = speeds.0,
                joint_speed_rad_s = speeds.1,
                "the arm did not come to rest in time; stopping the drives anyway (the plant holds it)"
            ),
        }
    }
    stop_roles(nodes, &second, SECOND_STEP_EXIT);
}

/// Drains the loop until the arm is at rest (its speeds) or `deadline` passes (the last speeds seen).
fn wait_for_rest(
    nodes: &mut [Supervised],
    ports: &Ports,
    heard: &mut LoopHeard,
    deadline: Instant,
    monitor: &mut FaultMonitor,
) -> Result<(f64, f64), (f64, f64)> {
    let mut last = (f64::NAN, f64::NAN);
    while Instant::now() < deadline {
        std::thread::sleep(REST_POLL);
        heard.drain(ports, nodes, monitor);
        if let (Some(state), Some(command)) = (&heard.joint_state, &heard.command) {
            last = speeds(command, state);
            if at_rest(last) {
                return Ok(last);
            }
        }
    }
    Err(last)
}

/// SIGTERM to each node of `roles` that runs, each given `grace` to exit, then SIGKILL.
fn stop_roles(nodes: &mut [Supervised], roles: &[NodeRole], grace: Duration) {
    let stopping = |n: &Supervised| roles.contains(&n.record.role);
    for node in nodes.iter().filter(|n| stopping(n)) {
        node.signal(Signal::SIGTERM);
    }
    for node in nodes.iter_mut().filter(|n| stopping(n)) {
        if !wait_for_exit(node, grace) {
            node.signal(Signal::SIGKILL);
            wait_for_exit(node, KILLED_EXIT);
        }
    }
}

/// Waits up to `timeout` for the node's process to end; whether it did.
fn wait_for_exit(node: &mut Supervised, timeout: Duration) -> bool {
    let until = Instant::now() + timeout;
    while node.process.is_some() {
        if let Some(exit) = node.reap() {
            node.record.stopped(Some(exit));
            return true;
        }
        if Instant::now() >= until {
            return false;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    node.record.stopped(None);
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_commands_motion_stops_before_what_brings_the_arm_to_rest() {
        let position = |role| STOP_ORDER.iter().position(|step| step.contains(&role)).expect("stopped");
        assert!(position(NodeRole::Servo) < position(NodeRole::Rmrc));
        assert!(position(NodeRole::Vision) < position(NodeRole::Rmrc));
        assert!(position(NodeRole::Rmrc) <= position(NodeRole::Plant));
        // every role is stopped, once
        let mut all: Vec<u32> = STOP_ORDER.concat().into_iter().map(|r| r as u32).collect();
        let mut roles: Vec<u32> = NodeRole::ALL.into_iter().map(|r| r as u32).collect();
        all.sort();
        roles.sort();
        assert_eq!(all, roles);
    }

    #[test]
    fn the_arm_is_at_rest_once_the_reference_stopped_and_the_joints_are_slow() {
        assert!(at_rest((0.0, AT_REST_RAD_S / 2.0)));
        assert!(!at_rest((0.0, AT_REST_RAD_S)), "still moving");
        assert!(!at_rest((1e-9, 0.0)), "the reference still moves");
        assert!(!at_rest((f64::NAN, f64::NAN)), "nothing heard");
    }

    #[test]
    fn speeds_are_the_arms_joints_only() {
        let command =
            JointCommandMsg { qd_ref_rad_s: [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0], ..Default::default() };
        let state = JointStateMsg { qd_rad_s: [0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 3.0], ..Default::default() };
        // six joints: a stray seventh slot is not the arm's
        assert_eq!(speeds(&command, &state), (0.0, 0.1));
        let seven = |c: JointCommandMsg, s: JointStateMsg| {
            (JointCommandMsg { joint_count: 7, ..c }, JointStateMsg { joint_count: 7, ..s })
        };
        let (command, state) = seven(command, state);
        assert_eq!(speeds(&command, &state), (5.0, 3.0));
    }
}
