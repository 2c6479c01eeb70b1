//! `[desired]`: the desired joints inside the arm's range, and the board's pose there, every mark in front of
//! the camera and inside the image.

use nalgebra::Point2;
use vservo_arm::{JointVector, SerialArm};
use vservo_scene::{Board, CameraIntrinsics, MARKS};

use super::checker::Checker;
use crate::raw::RawDesired;
use crate::{ConfigError, Desired};

/// The desired pose and what the camera sees there.
pub fn desired(
    check: &Checker,
    d: &RawDesired,
    arm: &SerialArm,
    camera: &CameraIntrinsics,
    board: &Board,
) -> Result<Desired, ConfigError> {
    let joints = joints(check, d, arm)?;
    // a board beyond 5 m is no visual-servo cell (its marks would be a few pixels)
    let camera_from_board = check.pose("desired.camera_from_board", &d.camera_from_board, 5.0)?;
    let (features, depths) = camera.project_marks_with_depths(board, &camera_from_board).map_err(|e| {
        check.invalid("desired.camera_from_board", format!("{:?}", d.camera_from_board), e.to_string())
    })?;
    for mark in 0..MARKS {
        let pixel = Point2::new(features[2 * mark], features[2 * mark + 1]);
        // (inside the image where the lens shows it)
        if !camera.contains(&camera.observed_of_pinhole(&pixel)) {
            return Err(check.invalid(
                "desired.camera_from_board",
                format!("{:?}", d.camera_from_board),
                format!(
                    "mark {} images at ({:.1}, {:.1}) px, outside the {}×{} image",
                    mark + 1,
                    pixel.x,
                    pixel.y,
                    camera.width_px(),
                    camera.height_px()
                ),
            ));
        }
    }
    Ok(Desired { joints, camera_from_board, features, depths })
}

/// `desired.joints_rad`: a finite angle per joint, inside the arm's range.
fn joints(check: &Checker, d: &RawDesired, arm: &SerialArm) -> Result<JointVector, ConfigError> {
    let key = "desired.joints_rad";
    let joints = check.per_joint(key, &d.joints_rad, arm, (-100.0, 100.0), "rad")?;
    arm.check_positions(&joints).map_err(|v| {
        check.invalid(key, format!("{:?}", d.joints_rad), format!("{v} (the {}'s range)", arm.name))
    })?;
    Ok(joints)
}
