//! Where the camera is fixed ([`CameraMount`]): on the hand (the paper's cell, the board standing in the
//! world) or in the world (an eye-to-hand cell, the board riding on the tool). The law servos on what the
//! camera sees, the board's pose in the camera frame, so it is the same for both mounts; what differs is which
//! of the two the arm moves, and so how a camera twist becomes a tool twist and where the board and camera are
//! for a joint vector. docs/ARCHITECTURE.md, "Mounts".

use nalgebra::{IsometryMatrix3, Vector3, Vector6};

/// Where the camera is fixed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraMount {
    /// On the hand: camera = tool · `tool_from_camera`; the board stands in the world.
    Hand {
        /// The camera in the tool frame.
        tool_from_camera: IsometryMatrix3<f64>,
    },
    /// Fixed in the world (`[camera] mount = "world"`): the camera at `base_from_camera` in the arm's base
    /// frame, the board on the tool at `tool_from_board`.
    World {
        /// The camera in the arm's base frame.
        base_from_camera: IsometryMatrix3<f64>,
        /// The board in the tool frame.
        tool_from_board: IsometryMatrix3<f64>,
    },
}

impl CameraMount {
    /// Whether the camera is on the hand.
    pub fn is_hand(&self) -> bool {
        matches!(self, Self::Hand { .. })
    }

    /// The camera in the base frame with the tool at `base_from_tool`.
    pub fn base_from_camera(&self, base_from_tool: &IsometryMatrix3<f64>) -> IsometryMatrix3<f64> {
        match self {
            Self::Hand { tool_from_camera } => base_from_tool * tool_from_camera,
            Self::World { base_from_camera, .. } => *base_from_camera,
        }
    }

    /// The board in the base frame with the tool at `base_from_tool`: where it stands
    /// (`base_from_standing_board`) for a hand camera, on the tool for a fixed one.
    pub fn base_from_board(
        &self,
        base_from_tool: &IsometryMatrix3<f64>,
        base_from_standing_board: &IsometryMatrix3<f64>,
    ) -> IsometryMatrix3<f64> {
        match self {
            Self::Hand { .. } => *base_from_standing_board,
            Self::World { tool_from_board, .. } => base_from_tool * tool_from_board,
        }
    }

    /// The camera's pose in the frame that holds the board still: the base for a hand camera, the tool for a
    /// fixed one. Its change between two frames is the camera's motion relative to a board that does not move
    /// on its own, what the law's estimate of the target's own motion subtracts.
    pub fn holder_from_camera(&self, base_from_tool: &IsometryMatrix3<f64>) -> IsometryMatrix3<f64> {
        match self {
            Self::Hand { tool_from_camera } => base_from_tool * tool_from_camera,
            Self::World { base_from_camera, .. } => base_from_tool.inverse() * base_from_camera,
        }
    }

    /// The tool pose at which the camera sees the board at `camera_from_board`, the board standing at
    /// `base_from_standing_board` for a hand camera.
    pub fn base_from_tool_seeing(
        &self,
        camera_from_board: &IsometryMatrix3<f64>,
        base_from_standing_board: &IsometryMatrix3<f64>,
    ) -> IsometryMatrix3<f64> {
        match self {
            Self::Hand { tool_from_camera } => {
                base_from_standing_board * camera_from_board.inverse() * tool_from_camera.inverse()
            }
            Self::World { base_from_camera, tool_from_board } => {
                base_from_camera * camera_from_board * tool_from_board.inverse()
            }
        }
    }

    /// The tool's twist in the base frame (velocity of the tool's origin, angular velocity; base axes) that
    /// moves the camera relative to the board as `camera_twist` says (velocity of the camera's origin,
    /// angular velocity; camera axes), the tool at `base_from_tool`. A hand camera moves with that twist; a
    /// fixed camera stays, and the board moves with the opposite one, −u taken at the camera's origin.
    pub fn tool_twist(
        &self,
        base_from_tool: &IsometryMatrix3<f64>,
        camera_twist: &Vector6<f64>,
    ) -> Vector6<f64> {
        let base_from_camera = self.base_from_camera(base_from_tool);
        let sign = if self.is_hand() { 1.0 } else { -1.0 };
        let rotation = base_from_camera.rotation.matrix();
        let v_camera: Vector3<f64> = rotation * camera_twist.fixed_rows::<3>(0) * sign;
        let omega: Vector3<f64> = rotation * camera_twist.fixed_rows::<3>(3) * sign;
        let camera_to_tool = base_from_tool.translation.vector - base_from_camera.translation.vector;
        let mut tool_twist = Vector6::zeros();
        tool_twist.fixed_rows_mut::<3>(0).copy_from(&(v_camera + omega.cross(&camera_to_tool)));
        tool_twist.fixed_rows_mut::<3>(3).copy_from(&omega);
        tool_twist
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3};

    fn pose(t: [f64; 3], r: [f64; 3]) -> IsometryMatrix3<f64> {
        IsometryMatrix3::from_parts(
            Translation3::from(Vector3::from(t)),
            Rotation3::from_scaled_axis(Vector3::from(r)),
        )
    }

    /// The camera-from-board pose after a small time `dt` of the tool moving with `tool_twist` (base frame).
    fn camera_from_board_after(
        mount: &CameraMount,
        base_from_tool: &IsometryMatrix3<f64>,
        standing: &IsometryMatrix3<f64>,
        tool_twist: &Vector6<f64>,
        dt: f64,
    ) -> IsometryMatrix3<f64> {
        let v = tool_twist.fixed_rows::<3>(0).into_owned() * dt;
        let w = tool_twist.fixed_rows::<3>(3).into_owned() * dt;
        let rotation = Rotation3::from_scaled_axis(w);
        let moved = IsometryMatrix3::from_parts(
            Translation3::from(base_from_tool.translation.vector + v),
            rotation * base_from_tool.rotation,
        );
        mount.base_from_camera(&moved).inverse() * mount.base_from_board(&moved, standing)
    }

    #[test]
    fn both_mounts_move_the_camera_relative_to_the_board_as_the_twist_says() {
        let base_from_tool = pose([0.4, -0.1, 0.6], [0.3, -0.2, 1.1]);
        let standing = pose([0.5, 0.2, -0.1], [3.0, 0.1, 0.0]);
        let camera_twist = Vector6::new(0.02, -0.01, 0.03, 0.05, -0.04, 0.08);
        let hand = CameraMount::Hand { tool_from_camera: pose([0.0, 0.05, 0.1], [0.0, 0.0, 0.2]) };
        let world = CameraMount::World {
            base_from_camera: pose([0.8, 0.0, 1.2], [2.9, 0.2, -0.3]),
            tool_from_board: pose([0.0, 0.0, 0.05], [0.0, 0.1, 0.0]),
        };
        let dt = 1e-6;
        for mount in [hand, world] {
            let before = mount.base_from_camera(&base_from_tool).inverse()
                * mount.base_from_board(&base_from_tool, &standing);
            let tool_twist = mount.tool_twist(&base_from_tool, &camera_twist);
            let after = camera_from_board_after(&mount, &base_from_tool, &standing, &tool_twist, dt);
            // a camera moving with twist u relative to a still board sees it as (I − [u] dt) · before
            let camera_motion = pose(
                (camera_twist.fixed_rows::<3>(0) * dt).into(),
                (camera_twist.fixed_rows::<3>(3) * dt).into(),
            );
            let expected = camera_motion.inverse() * before;
            let error = (after.to_homogeneous() - expected.to_homogeneous()).abs().max();
            assert!(error < 1e-10, "{mount:?}: {error}");
        }
    }

    #[test]
    fn the_tool_seeing_a_pose_sees_it() {
        let standing = pose([0.5, 0.2, -0.1], [3.0, 0.1, 0.0]);
        let camera_from_board = pose([0.01, -0.02, 0.5], [0.1, 0.0, 0.3]);
        for mount in [
            CameraMount::Hand { tool_from_camera: pose([0.0, 0.05, 0.1], [0.0, 0.0, 0.2]) },
            CameraMount::World {
                base_from_camera: pose([0.8, 0.0, 1.2], [2.9, 0.2, -0.3]),
                tool_from_board: pose([0.0, 0.0, 0.05], [0.0, 0.1, 0.0]),
            },
        ] {
            let tool = mount.base_from_tool_seeing(&camera_from_board, &standing);
            let seen = mount.base_from_camera(&tool).inverse() * mount.base_from_board(&tool, &standing);
            assert!((seen.to_homogeneous() - camera_from_board.to_homogeneous()).abs().max() < 1e-12);
            let held = mount.holder_from_camera(&tool).inverse()
                * match mount {
                    CameraMount::Hand { .. } => standing,
                    CameraMount::World { tool_from_board, .. } => tool_from_board,
                };
            assert!((held.to_homogeneous() - camera_from_board.to_homogeneous()).abs().max() < 1e-12);
        }
    }
}
