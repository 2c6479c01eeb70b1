//! Conversions between the wire payloads and the core types they carry.

use vservo_scene::IsometryMatrix3;

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

/// A pose as `sim_world.base_from_board` carries it: 3×4 [R | t] row-major.
pub fn pose_to_wire(pose: &IsometryMatrix3<f64>) -> [f64; 12] {
    let (r, t) = (pose.rotation.matrix(), pose.translation.vector);
    let mut out = [0.0; 12];
    for row in 0..3 {
        for col in 0..3 {
            out[4 * row + col] = r[(row, col)];
        }
        out[4 * row + 3] = t[row];
    }
    out
}

/// The pose from a 3×4 [R | t] row-major array; `None` if a number is not finite or R is not a rotation
/// (RᵀR = I and det R = 1 to 1e-6).
pub fn pose_from_wire(m: &[f64; 12]) -> Option<IsometryMatrix3<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let rotation = nalgebra::Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
    let orthonormal = (rotation.transpose() * rotation - nalgebra::Matrix3::identity()).amax() < 1e-6;
    if !orthonormal || (rotation.determinant() - 1.0).abs() > 1e-6 {
        return None;
    }
    Some(IsometryMatrix3::from_parts(
        nalgebra::Vector3::new(m[3], m[7], m[11]).into(),
        nalgebra::Rotation3::from_matrix_unchecked(rotation),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_survive_the_wire_and_non_finite_ones_are_refused() {
        let pose = IsometryMatrix3::from_parts(
            nalgebra::Translation3::new(1.2, -0.15, 0.66),
            nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 1.1),
        );
        assert_eq!(pose_from_wire(&pose_to_wire(&pose)), Some(pose));
        let mut broken = pose_to_wire(&pose);
        broken[7] = f64::INFINITY;
        assert_eq!(pose_from_wire(&broken), None);
        // a matrix that is not a rotation is no pose
        let mut scaled = pose_to_wire(&pose);
        scaled[0] *= 1.01;
        assert_eq!(pose_from_wire(&scaled), None);
        let mirrored = [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        assert_eq!(pose_from_wire(&mirrored), None);
    }
}
