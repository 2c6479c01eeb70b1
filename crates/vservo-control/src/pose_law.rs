//! The pose-based laws on the per-frame path (`controller.law = "pbvs"`, `"pbvs-target"`, `"2.5d"`): from the
//! board's pose the four marks give (`vservo_scene::CameraIntrinsics::board_pose_from_features`, the homography
//! of the undistorted marks), the error of [`PoseFeatures`] against the pose at which the board images at ξ_d,
//! predicted through the pipeline's delay, and the proportional law on it:
//!
//! ê(k) = e(k − d) + T L Σⱼ u(k − j),   u(k) = −λ L⁻¹ ê(k),
//!
//! so that ê shrinks by the factor 1 − λT a frame (λT ≤ 1, checked where the gains are made). The point the
//! target-path and 2½-D laws keep on a straight line in the image is the centre of the marks, not the board's
//! own origin (which may lie outside them). No allocation.

use nalgebra::{IsometryMatrix3, Translation3, Vector3};
use vservo_scene::{Board, CameraIntrinsics, FeatureVector};

use crate::pose_features::{PoseErrorRefused, PoseFeatures};
use crate::{LawOptions, Twist};

/// A pose-based law: its features, the desired pose and λ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseLaw {
    features: PoseFeatures,
    /// The centre of the marks in the board's frame, as a pose.
    board_from_centre: IsometryMatrix3<f64>,
    /// The marks' centre seen from the camera at the desired pose.
    desired_camera_from_centre: IsometryMatrix3<f64>,
    gain_per_s: f64,
    period_s: f64,
    max_speed_m_s: f64,
    max_rotation_rad_s: f64,
}

/// Why the pose-based law gave no twist on a frame (the servo then runs the image law on it).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PoseLawRefused {
    /// The pose error cannot be formed.
    #[error(transparent)]
    Error(#[from] PoseErrorRefused),
    /// L is singular (a rotation error of 2π, or the marks' centre at the centre of projection).
    #[error("the pose error's interaction matrix is singular")]
    Singular,
}

impl PoseLaw {
    /// The law on `features` towards the pose at which `board` images at `desired_features`, with λ and the speed
    /// caps of `options`; `None` when those features give no pose (degenerate, or behind the camera).
    pub fn new(
        features: PoseFeatures,
        camera: &CameraIntrinsics,
        board: &Board,
        desired_features: &FeatureVector,
        options: &LawOptions,
        period_s: f64,
    ) -> Option<Self> {
        let desired_camera_from_board = camera.board_pose_from_features(board, desired_features)?;
        let centre = board.marks_in_board.iter().fold(Vector3::zeros(), |sum, mark| sum + mark.coords)
            / board.marks_in_board.len() as f64;
        let board_from_centre = IsometryMatrix3::from_parts(Translation3::from(centre), Default::default());
        Some(Self {
            features,
            board_from_centre,
            desired_camera_from_centre: desired_camera_from_board * board_from_centre,
            gain_per_s: options.pose_gain_per_s,
            period_s,
            max_speed_m_s: options.pose_max_speed_m_s,
            max_rotation_rad_s: options.pose_max_rotation_rad_s,
        })
    }

    /// The twist for the board seen at `camera_from_board`, with `in_pipeline` the sum of the commands sent that
    /// the frame does not show yet: u = −λ L⁻¹ (e + T L Σ u), scaled down whole to the speed caps.
    pub fn twist(
        &self,
        camera_from_board: &IsometryMatrix3<f64>,
        in_pipeline: &Twist,
    ) -> Result<Twist, PoseLawRefused> {
        let camera_from_centre = camera_from_board * self.board_from_centre;
        let error = self.features.error(&camera_from_centre, &self.desired_camera_from_centre)?;
        let predicted = error.error + error.interaction * in_pipeline * self.period_s;
        let inverse = error.interaction.try_inverse().ok_or(PoseLawRefused::Singular)?;
        let twist = -self.gain_per_s * (inverse * predicted);
        let speed = twist.fixed_rows::<3>(0).norm() / self.max_speed_m_s;
        let rotation = twist.fixed_rows::<3>(3).norm() / self.max_rotation_rad_s;
        Ok(twist / speed.max(rotation).max(1.0))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Rotation3, Vector6};
    use vservo_scene::{Board, CameraIntrinsics};

    use super::*;

    fn options(gain_per_s: f64) -> LawOptions {
        LawOptions { pose_gain_per_s: gain_per_s, ..Default::default() }
    }

    fn paper_cell() -> (CameraIntrinsics, Board) {
        (CameraIntrinsics::paper(), Board::paper())
    }

    /// The camera moved by the twist `u` (its own frame) for `dt`.
    fn moved(camera_from_board: &IsometryMatrix3<f64>, u: &Twist, dt: f64) -> IsometryMatrix3<f64> {
        let step = IsometryMatrix3::from_parts(
            Translation3::from(Vector3::new(u[0], u[1], u[2]) * dt),
            Rotation3::from_scaled_axis(Vector3::new(u[3], u[4], u[5]) * dt),
        );
        step.inverse() * camera_from_board
    }

    #[test]
    fn every_law_brings_the_board_to_the_desired_pose_through_a_one_frame_delay() {
        let (camera, board) = paper_cell();
        let desired = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Default::default());
        let desired_features = camera.project_marks(&board, &desired).expect("in view");
        let start = IsometryMatrix3::from_parts(
            Translation3::new(0.04, -0.03, 0.58),
            Rotation3::from_scaled_axis(Vector3::new(0.1, -0.15, 0.6)),
        );
        for features in [PoseFeatures::CameraPath, PoseFeatures::TargetPath, PoseFeatures::TwoAndAHalfD] {
            let law = PoseLaw::new(features, &camera, &board, &desired_features, &options(4.0), 0.085)
                .expect("a pose");
            let (mut pose, mut sent) = (start, Twist::zeros());
            for _ in 0..60 {
                // the frame shows the pose before the last command acted
                let twist = law.twist(&pose, &sent).expect("a twist");
                pose = moved(&pose, &sent, 0.085);
                sent = twist;
            }
            let error = (desired.inverse() * pose).to_homogeneous() - nalgebra::Matrix4::identity();
            assert!(error.abs().max() < 1e-6, "{features:?}: {error}");
        }
    }

    #[test]
    fn at_the_desired_pose_the_twist_is_zero_and_a_command_in_flight_is_not_sent_twice() {
        let (camera, board) = paper_cell();
        let desired = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Default::default());
        let desired_features = camera.project_marks(&board, &desired).expect("in view");
        let law =
            PoseLaw::new(PoseFeatures::CameraPath, &camera, &board, &desired_features, &options(4.0), 0.085)
                .expect("a pose");
        let estimated = camera.board_pose_from_features(&board, &desired_features).expect("a pose");
        assert!(law.twist(&estimated, &Twist::zeros()).expect("a twist").norm() < 1e-9);
        // a command in flight that already brings the camera back: the law adds λT of it again, negated
        let in_flight = Vector6::new(0.01, 0.0, 0.0, 0.0, 0.0, 0.0);
        let twist = law.twist(&estimated, &in_flight).expect("a twist");
        assert!((twist + in_flight * (4.0 * 0.085)).norm() < 1e-9, "{twist}");
    }

    #[test]
    fn a_twist_above_a_cap_is_scaled_down_whole() {
        let (camera, board) = paper_cell();
        let desired = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Default::default());
        let desired_features = camera.project_marks(&board, &desired).expect("in view");
        let rolled = IsometryMatrix3::from_parts(
            Translation3::new(0.1, 0.0, 0.5),
            Rotation3::from_scaled_axis(Vector3::new(0.0, 0.0, 1.3)),
        );
        let free = LawOptions { pose_max_speed_m_s: 1e3, pose_max_rotation_rad_s: 1e3, ..options(6.0) };
        let capped = options(6.0);
        let law = |o: &LawOptions| {
            let law = PoseLaw::new(PoseFeatures::CameraPath, &camera, &board, &desired_features, o, 0.085);
            law.expect("a pose").twist(&rolled, &Twist::zeros()).expect("a twist")
        };
        let (fast, slow) = (law(&free), law(&capped));
        assert!(fast.fixed_rows::<3>(3).norm() > capped.pose_max_rotation_rad_s, "premise: {fast}");
        assert!((slow.fixed_rows::<3>(3).norm() - capped.pose_max_rotation_rad_s).abs() < 1e-12, "{slow}");
        assert!(slow.fixed_rows::<3>(0).norm() <= capped.pose_max_speed_m_s, "{slow}");
        assert!((slow.normalize() - fast.normalize()).norm() < 1e-12, "the direction kept: {slow} {fast}");
    }
}
