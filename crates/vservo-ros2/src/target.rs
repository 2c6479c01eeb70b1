//! Targets from the ROS graph (`vservo_msgs/SetTargetFeatures`, `SetTargetPose`) as the `vservo-client`
//! commands the daemon checks and acknowledges like any other client's: ROS's pixels to vservo's, a pose's
//! quaternion to the roll–pitch–yaw vservo takes (R = Rz·Ry·Rx), the daemon's reply back in ROS's pixels.

use nalgebra::{Quaternion, UnitQuaternion};
use vservo_scene::OPENCV_TO_VSERVO_PX;

use crate::msg::{Pose, SetTargetResponse};

/// How far a pose's quaternion may be from unit length and still be taken (normalised).
pub const UNIT_QUATERNION_TOLERANCE: f64 = 1e-3;

/// Why a target is refused before it reaches the daemon.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TargetRefused {
    /// The orientation is not a rotation.
    #[error(
        "camera_from_target.orientation is not a unit quaternion (norm {norm}; within {UNIT_QUATERNION_TOLERANCE} of 1 is taken)"
    )]
    NotUnit {
        /// Its norm.
        norm: f64,
    },
}

/// ξ_d in vservo's pixels from ROS's (a value that is not finite stays so: the daemon refuses it by name).
pub fn features_in_vservo_px(features_px: &[f64; 8]) -> [f64; 8] {
    features_px.map(|v| v + OPENCV_TO_VSERVO_PX)
}

/// The board's translation (m) and roll–pitch–yaw (rad, R = Rz·Ry·Rx) in the desired camera frame.
pub fn pose_as_translation_rpy(pose: &Pose) -> Result<([f64; 3], [f64; 3]), TargetRefused> {
    let o = pose.orientation;
    let q = Quaternion::new(o.w, o.x, o.y, o.z);
    let norm = q.norm();
    if !norm.is_finite() || (norm - 1.0).abs() > UNIT_QUATERNION_TOLERANCE {
        return Err(TargetRefused::NotUnit { norm });
    }
    let (roll, pitch, yaw) = UnitQuaternion::from_quaternion(q).euler_angles();
    let p = pose.position;
    Ok(([p.x, p.y, p.z], [roll, pitch, yaw]))
}

/// The daemon's answer, ξ_d back in ROS's pixels.
pub fn response(reply: &vservo_client::Reply) -> SetTargetResponse {
    SetTargetResponse {
        accepted: reply.accepted,
        reason: reply.reason.clone(),
        gains_version: reply.gains_version,
        target_features_px: reply.target_features_px.map(|v| v - OPENCV_TO_VSERVO_PX),
    }
}

/// A refusal before the daemon: nothing changed.
pub fn refusal(reason: String) -> SetTargetResponse {
    SetTargetResponse { accepted: false, reason, gains_version: 0, target_features_px: [f64::NAN; 8] }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Point, Quaternion as RosQuaternion};
    use nalgebra::{Rotation3, Vector3};

    #[test]
    fn a_pose_becomes_vservos_roll_pitch_yaw() {
        let (roll, pitch, yaw) = (0.1, -0.2, 0.3);
        // R = Rz(yaw)·Ry(pitch)·Rx(roll), built from the axes, not from nalgebra's Euler angles
        let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), pitch)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), roll);
        let q = UnitQuaternion::from_rotation_matrix(&rotation);
        let pose = Pose {
            position: Point { x: 0.01, y: -0.02, z: 0.5 },
            orientation: RosQuaternion { x: q.i, y: q.j, z: q.k, w: q.w },
        };
        let (translation, rpy) = pose_as_translation_rpy(&pose).expect("a unit quaternion");
        assert_eq!(translation, [0.01, -0.02, 0.5]);
        for (got, want) in rpy.iter().zip([roll, pitch, yaw]) {
            assert!((got - want).abs() < 1e-12, "{rpy:?}");
        }
    }

    #[test]
    fn a_quaternion_that_is_not_a_rotation_is_refused() {
        for orientation in [
            RosQuaternion { x: 0.0, y: 0.0, z: 0.0, w: 0.0 },
            RosQuaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.01 },
            RosQuaternion { x: f64::NAN, y: 0.0, z: 0.0, w: 1.0 },
        ] {
            let pose = Pose { position: Point::default(), orientation };
            assert!(
                matches!(pose_as_translation_rpy(&pose), Err(TargetRefused::NotUnit { .. })),
                "{orientation:?}"
            );
        }
    }

    #[test]
    fn pixels_cross_the_boundary_both_ways() {
        let ros = [150.0, 167.5, 317.5, 177.5, 338.5, 74.5, 171.5, 69.5];
        let vservo = features_in_vservo_px(&ros);
        assert_eq!(vservo[0], 150.5);
        let reply = vservo_client::Reply {
            accepted: true,
            reason: "ok".into(),
            gains_version: 2,
            target_features_px: vservo,
        };
        assert_eq!(response(&reply).target_features_px, ros);
    }
}
