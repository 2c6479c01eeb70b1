//! The poses `vservoctl calibrate` takes: the camera on a half sphere around the calibration board (relative to
//! it: a fixed camera sees the board the arm holds turned the other way), each pose checked reachable (inside
//! the joint limits, near the pose before it) and with the board in view before anything moves.
//!
//! Pose k of n looks at the board from azimuth 2πk/n about the board's normal, tilted from it alternately by
//! the configured tilt and by half of it, rolled about its optical axis by 0, +20° or −20°, and aimed a little
//! off the board's centre (so that the board's image moves about the image and the lens is seen at its edges).

use nalgebra::{Matrix3, Point2, Point3, Rotation3, Translation3, Vector3};
use vservo_arm::{JointVector, SerialArm};
use vservo_config::CalibrationSettings;
use vservo_scene::{CameraIntrinsics, CameraMount, IsometryMatrix3, TagGrid};

/// The share of the board's tags that must lie wholly in the image, with [`VIEW_MARGIN_PX`] to spare, for a
/// pose to count as having the board in view.
pub const TAGS_IN_VIEW: f64 = 0.8;
/// How far inside the image's edge a tag's corners must be (px).
pub const VIEW_MARGIN_PX: f64 = 8.0;
/// Roll of the camera about its optical axis, pose by pose (rad).
const ROLLS_RAD: [f64; 3] = [0.0, 0.35, -0.35];
/// How far off the board's centre the camera aims, as a share of the board's half extent.
const AIM_OFF_CENTRE: f64 = 0.25;

/// What the planner needs to know about the cell, all as the configuration believes it.
pub struct Cell<'a> {
    /// The arm.
    pub arm: &'a SerialArm,
    /// Where the arm is now: the first pose's inverse kinematics starts near it.
    pub start: JointVector,
    /// The camera's intrinsics and lens.
    pub camera: &'a CameraIntrinsics,
    /// Where the camera is: on the hand, or fixed with the board on the tool.
    pub mount: CameraMount,
    /// Where a hand camera's board stands in the arm's base (unused with a fixed camera, whose board is on the
    /// tool: `mount`).
    pub base_from_board: IsometryMatrix3<f64>,
}

/// One planned pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedPose {
    /// The joints.
    pub q: JointVector,
    /// The tool's pose they give.
    pub base_from_tool: IsometryMatrix3<f64>,
    /// The board as the camera should see it there.
    pub camera_from_board: IsometryMatrix3<f64>,
    /// Of the board's tags, how many lie wholly in the image.
    pub tags_in_view: usize,
}

/// Why a plan was refused (before anything moves).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanRefused {
    /// No joints inside the limits put the camera at the pose.
    #[error(
        "pose {pose} (camera {distance_m:.3} m from the board, tilted {tilt_deg:.1}°, azimuth {azimuth_deg:.0}°) is out of the arm's reach within its joint limits"
    )]
    Unreachable {
        /// Which pose (from 1).
        pose: usize,
        /// Its distance from the board (m).
        distance_m: f64,
        /// Its tilt from the board's normal (°).
        tilt_deg: f64,
        /// Its azimuth about the normal (°).
        azimuth_deg: f64,
    },
    /// A given pose has another number of joints than the arm.
    #[error("pose {pose} gives {given} joints; the arm has {joints}")]
    JointCount {
        /// Which pose (from 1).
        pose: usize,
        /// Joints given.
        given: usize,
        /// The arm's joints.
        joints: usize,
    },
    /// A given pose is outside a joint's limits (less the margin a joint move's goal keeps).
    #[error(
        "pose {pose} is outside joint {joint}'s limits ({} rad inside them at least)",
        vservo_arm::GOAL_MARGIN_RAD
    )]
    OutsideLimits {
        /// Which pose (from 1).
        pose: usize,
        /// Which joint (from 1).
        joint: usize,
    },
    /// Too few of the board's tags would be in the image.
    #[error(
        "pose {pose} would see {tags_in_view} of the board's {tags} tags wholly in the image; {needed} are needed (a shorter calibration.distance_m or a smaller calibration.tilt_deg brings more in)"
    )]
    BoardOutOfView {
        /// Which pose (from 1).
        pose: usize,
        /// Tags in view.
        tags_in_view: usize,
        /// Tags on the board.
        tags: usize,
        /// Tags needed.
        needed: usize,
    },
}

/// Poses given as joints (`vservoctl calibrate --poses`), each checked inside the joint limits and with the
/// board in view.
pub fn given(cell: &Cell, grid: &TagGrid, joints: &[Vec<f64>]) -> Result<Vec<PlannedPose>, PlanRefused> {
    let needed = (TAGS_IN_VIEW * grid.len() as f64).ceil() as usize;
    let count = cell.arm.joint_count();
    let mut poses = Vec::with_capacity(joints.len());
    for (k, written) in joints.iter().enumerate() {
        let q = (written.len() == count).then(|| vservo_arm::joint_vector(written)).flatten();
        let Some(q) = q else {
            return Err(PlanRefused::JointCount { pose: k + 1, given: written.len(), joints: count });
        };
        if let Some((joint, _)) = cell
            .arm
            .limits()
            .zip(q.iter())
            .enumerate()
            .find(|(_, (limits, value))| !limits.holds_goal(**value))
        {
            return Err(PlanRefused::OutsideLimits { pose: k + 1, joint: joint + 1 });
        }
        let base_from_tool = cell.arm.base_from_tool(&q);
        let camera_from_board = cell.mount.base_from_camera(&base_from_tool).inverse()
            * cell.mount.base_from_board(&base_from_tool, &cell.base_from_board);
        let in_view = tags_in_view(cell.camera, grid, &camera_from_board);
        if in_view < needed {
            return Err(PlanRefused::BoardOutOfView {
                pose: k + 1,
                tags_in_view: in_view,
                tags: grid.len(),
                needed,
            });
        }
        poses.push(PlannedPose { q, base_from_tool, camera_from_board, tags_in_view: in_view });
    }
    Ok(poses)
}

/// The camera's pose in the board frame for pose `k` of `n`.
pub fn board_from_camera(
    k: usize,
    n: usize,
    settings: &CalibrationSettings,
    distance_m: f64,
) -> IsometryMatrix3<f64> {
    let azimuth = std::f64::consts::TAU * k as f64 / n as f64;
    let tilt = if k.is_multiple_of(2) { settings.tilt_rad } else { 0.5 * settings.tilt_rad };
    let roll = ROLLS_RAD[k % ROLLS_RAD.len()];
    let [low, high] = settings.board.tags_extent_in_board();
    // aimed off the centre, going round twice as fast as the azimuth (so the board's image visits every side of
    // the image from several directions)
    let aim = Point3::new(
        -AIM_OFF_CENTRE * 0.5 * (high.x - low.x) * (2.0 * azimuth).cos(),
        -AIM_OFF_CENTRE * 0.5 * (high.y - low.y) * (2.0 * azimuth).sin(),
        0.0,
    );
    // the camera on the board's −z side (its z axis points away from the camera)
    let offset =
        Vector3::new(tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), -tilt.cos()) * distance_m;
    let position = aim + offset;
    let z = -offset.normalize();
    // upright: the camera's x as near the board's x as the view allows, then rolled about the optical axis
    let x_upright = (Vector3::x() - z * z.x).normalize();
    let x = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(z), roll) * x_upright;
    let y = z.cross(&x);
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    IsometryMatrix3::from_parts(Translation3::from(position.coords), rotation)
}

/// How many of the grid's tags lie wholly in the image, [`VIEW_MARGIN_PX`] inside its edge.
pub fn tags_in_view(
    camera: &CameraIntrinsics,
    grid: &TagGrid,
    camera_from_board: &IsometryMatrix3<f64>,
) -> usize {
    grid.tags()
        .filter(|tag| {
            tag.corners_in_board().iter().all(|corner| {
                camera
                    .project_observed(&(camera_from_board * corner))
                    .is_some_and(|pixel: Point2<f64>| camera.contains_with_margin(&pixel, VIEW_MARGIN_PX))
            })
        })
        .count()
}

/// The poses, in the order they are taken, each one's joints found near the last one's.
pub fn plan(
    cell: &Cell,
    settings: &CalibrationSettings,
    distance_m: f64,
) -> Result<Vec<PlannedPose>, PlanRefused> {
    let n = settings.poses;
    let needed = (TAGS_IN_VIEW * settings.board.len() as f64).ceil() as usize;
    let mut near = cell.start;
    let mut poses = Vec::with_capacity(n);
    for k in 0..n {
        let board_from_camera = board_from_camera(k, n, settings, distance_m);
        let camera_from_board = board_from_camera.inverse();
        let in_view = tags_in_view(cell.camera, &settings.board, &camera_from_board);
        if in_view < needed {
            return Err(PlanRefused::BoardOutOfView {
                pose: k + 1,
                tags_in_view: in_view,
                tags: settings.board.len(),
                needed,
            });
        }
        let base_from_tool = match cell.mount {
            CameraMount::Hand { tool_from_camera } => {
                cell.base_from_board * board_from_camera * tool_from_camera.inverse()
            }
            fixed => fixed.base_from_tool_seeing(&camera_from_board, &cell.base_from_board),
        };
        // the daemon moves the joints to goals inside the limits by a margin only: a solution closer is none
        let reached = cell
            .arm
            .reach(&base_from_tool, &near)
            .filter(|q| cell.arm.limits().zip(q.iter()).all(|(limits, value)| limits.holds_goal(*value)));
        let Some(q) = reached else {
            // the optical axis against the board's normal
            let tilt = board_from_camera.rotation.matrix()[(2, 2)].acos();
            return Err(PlanRefused::Unreachable {
                pose: k + 1,
                distance_m,
                tilt_deg: tilt.to_degrees(),
                azimuth_deg: 360.0 * k as f64 / n as f64,
            });
        };
        near = q;
        poses.push(PlannedPose { q, base_from_tool, camera_from_board, tags_in_view: in_view });
    }
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_arm::puma560;

    fn settings(poses: usize, tilt_deg: f64) -> CalibrationSettings {
        CalibrationSettings {
            board: TagGrid::new(5, 7, 0.028, 0.008, 0).expect("a grid"),
            poses,
            tilt_rad: tilt_deg.to_radians(),
            distance_m: None,
            output_file: None,
        }
    }

    #[test]
    fn each_camera_looks_at_the_board_from_its_tilt_and_azimuth() {
        let s = settings(12, 30.0);
        for k in 0..12 {
            let pose = board_from_camera(k, 12, &s, 0.4);
            let z = pose.rotation * Vector3::z();
            // the optical axis points into the board (its +z) from the camera's side
            assert!(z.z > 0.0 && pose.translation.vector.z < 0.0, "pose {k}");
            let tilt = z.z.acos().to_degrees();
            let expected = if k % 2 == 0 { 30.0 } else { 15.0 };
            assert!((tilt - expected).abs() < 1e-9, "pose {k}: tilt {tilt}");
            // the aim point is on the board plane, within the tags' extent
            let along = -pose.translation.vector.z / z.z;
            let aim = pose.translation.vector + z * along;
            assert!(aim.z.abs() < 1e-12 && aim.x.abs() < 0.04 && aim.y.abs() < 0.03, "pose {k}: {aim}");
            assert!(((pose.translation.vector - aim).norm() - 0.4).abs() < 1e-12);
            assert!((pose.rotation.matrix().determinant() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_plan_on_the_puma_reaches_every_pose_with_the_board_in_view_and_refuses_poses_out_of_reach() {
        let arm = puma560::puma560();
        let camera =
            CameraIntrinsics::new(600.0, Point2::new(320.0, 240.0), 640, 480).expect("valid intrinsics");
        let tool_from_camera = IsometryMatrix3::identity();
        // the board 0.35 m in front of the camera at the nominal pose, facing it
        let base_from_camera = arm.base_from_tool(&puma560::QN) * tool_from_camera;
        let base_from_board = base_from_camera
            * IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.35), Rotation3::identity());
        let mount = CameraMount::Hand { tool_from_camera };
        let cell = Cell { arm: &arm, start: puma560::QN, camera: &camera, mount, base_from_board };
        let poses = plan(&cell, &settings(12, 25.0), 0.35).expect("a plan");
        assert_eq!(poses.len(), 12);
        for pose in &poses {
            assert!(
                (arm.base_from_tool(&pose.q).to_homogeneous() - pose.base_from_tool.to_homogeneous()).norm()
                    < 1e-6
            );
            assert!(arm.limits().zip(pose.q.iter()).all(|(limits, q)| limits.holds_goal(*q)));
            assert!(pose.tags_in_view >= 28, "{}", pose.tags_in_view);
        }
        // 3 m away is beyond the PUMA's reach
        // 1.2 m from the board is beyond the PUMA's reach for some of the poses
        let refused = plan(&cell, &settings(12, 25.0), 1.2);
        assert!(matches!(refused, Err(PlanRefused::Unreachable { distance_m: 1.2, .. })), "{refused:?}");
    }
}
