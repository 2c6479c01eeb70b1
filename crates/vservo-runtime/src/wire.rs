//! Conversions between the wire payloads and the core types they carry.

/// The gains' message, both ways: its public home is [`crate::gains`].
pub use crate::gains::{gains_message, law_gains};

/// A fixed-size vector as the array a payload carries.
pub fn to_array<const N: usize>(v: &nalgebra::SVector<f64, N>) -> [f64; N] {
    let mut out = [0.0; N];
    out.copy_from_slice(v.as_slice());
    out
}

// the messages have a slot for every joint an arm may have
const _: () = assert!(vservo_protocol::MAX_JOINTS == vservo_arm::MAX_JOINTS);

/// The arm's joints as `joint_state` and `joint_command` carry them: in the first slots, the others zero (as a
/// joint vector holds them).
pub fn joints_to_wire(joints: &vservo_arm::JointVector) -> [f64; vservo_protocol::MAX_JOINTS] {
    to_array(joints)
}

/// The first `joint_count` joints from the slots of `joint_state` or `joint_command`, the others zero.
pub fn joints_from_wire(
    slots: &[f64; vservo_protocol::MAX_JOINTS],
    joint_count: u32,
) -> vservo_arm::JointVector {
    vservo_arm::JointVector::from_fn(|j, _| if j < joint_count as usize { slots[j] } else { 0.0 })
}

/// The joint count the messages of `arm` carry (`joint_count`).
pub fn wire_joint_count(arm: &vservo_arm::SerialArm) -> u32 {
    arm.joint_count() as u32
}

/// The wire enum of a command interface.
pub fn command_mode(interface: vservo_config::CommandInterface) -> vservo_protocol::CommandMode {
    use vservo_protocol::CommandMode;
    match interface {
        vservo_config::CommandInterface::Torque => CommandMode::Torque,
        vservo_config::CommandInterface::Velocity => CommandMode::Velocity,
        vservo_config::CommandInterface::Position => CommandMode::Position,
    }
}

pub use vservo_scene::pose_rows::{pose_from_rows as pose_from_wire, pose_to_rows as pose_to_wire};
