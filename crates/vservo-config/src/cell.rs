//! The core cell's part of the configuration ([`CellConfig`]): what its four stages (vision, servo, rmrc,
//! plant) and their designs run by — timing, the camera and its mount, the board and the desired pose, the
//! law, vision, the simulated plant and joint servo, the interpolator, the scenario, the robot and its arm, the
//! reacquisition. Not the shells' settings (the runtime, supervision and faults, the viewer, ROS 2, the Franka,
//! the GStreamer camera, calibration): the cell never sees those.
//!
//! The whole [`Config`] holds it as its `cell` field; the few rules computed from these parts (the true
//! camera, the board's place, the gains' specification, the command interface) are its methods.

use vservo_arm::JointVector;
use vservo_scene::{Board, CameraIntrinsics, CameraMount, IsometryMatrix3};
use vservo_settings::control::GainsSpec;

use crate::{
    CameraTruth, Collision, CommandInterface, Controller, Desired, FixedCamera, JointServoSettings,
    PlantSettings, Reacquire, Robot, RobotDriver, Scenario, Timing, Vision,
};

/// The configuration's part the core cell runs by (the field `cell` of [`crate::Config`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CellConfig {
    /// Periods and delays.
    pub timing: Timing,
    /// The camera's intrinsics.
    pub camera: CameraIntrinsics,
    /// Where the camera sits on the hand: camera = tool · `tool_from_camera` (the identity, unused, for a
    /// fixed camera: [`CellConfig::mount`] is the rule for where the camera is).
    pub tool_from_camera: IsometryMatrix3<f64>,
    /// `camera.mount = "world"`: the camera fixed in the world and the board on the tool; `None`: the camera
    /// on the hand at `tool_from_camera`, the board standing in the world.
    pub fixed_camera: Option<FixedCamera>,
    /// The simulated camera as it really is, where `[camera.truth]` says it differs from `camera` and
    /// `tool_from_camera` (see [`CellConfig::true_camera`]). Only the simulated camera's rendering uses it;
    /// everything else works with what the cell believes.
    pub camera_truth: Option<CameraTruth>,
    /// The object.
    pub board: Board,
    /// The desired pose and what the camera sees there.
    pub desired: Desired,
    /// The controller's law and weights.
    pub controller: Controller,
    /// The image source and the feature extractor.
    pub vision: Vision,
    /// The simulated arm.
    pub plant: PlantSettings,
    /// The resolved-motion-rate interpolator.
    pub interpolator: vservo_settings::simulation::InterpolatorSettings,
    /// The joint servo.
    pub joint_servo: JointServoSettings,
    /// What the simulated cell does.
    pub scenario: Scenario,
    /// `[robot]`: the robot driver and the command it takes.
    pub robot: Robot,
    /// `[robot.arm]`: the arm's model (the PUMA 560 by default; a custom arm's DH table and limits).
    pub arm: vservo_arm::SerialArm,
    /// `[reacquire]`: how the servo steers back to lost marks.
    pub reacquire: Reacquire,
    /// `[collision]` and `[[scene.obstacles]]`: the guard, if the section is given.
    pub collision: Option<Collision>,
}

impl CellConfig {
    /// The simulated camera as it really is: `[camera.truth]` where written, else what the cell believes.
    pub fn true_camera(&self) -> CameraTruth {
        self.camera_truth.unwrap_or(CameraTruth {
            intrinsics: self.camera,
            tool_from_camera: self.tool_from_camera,
            base_from_camera: None,
        })
    }

    /// Where the camera is fixed: on the hand, or in the world with the board on the tool.
    pub fn mount(&self) -> CameraMount {
        match self.fixed_camera {
            None => CameraMount::Hand { tool_from_camera: self.tool_from_camera },
            Some(FixedCamera { base_from_camera, tool_from_board }) => {
                CameraMount::World { base_from_camera, tool_from_board }
            }
        }
    }

    /// The mount of the simulated camera as it really is (`[camera.truth]`'s `tool_from_camera` on the hand, its
    /// `base_from_camera` fixed; the board on the tool where the believed camera puts it).
    pub fn true_mount(&self) -> CameraMount {
        let truth = self.true_camera();
        match self.mount() {
            CameraMount::Hand { .. } => CameraMount::Hand { tool_from_camera: truth.tool_from_camera },
            CameraMount::World { base_from_camera, tool_from_board } => CameraMount::World {
                base_from_camera: truth.base_from_camera.unwrap_or(base_from_camera),
                tool_from_board,
            },
        }
    }

    /// The camera's pose in the frame it is fixed to, as believed: its name (`tool_from_camera` on the hand,
    /// `base_from_camera` fixed) and value.
    pub fn camera_in_mount(&self) -> (&'static str, IsometryMatrix3<f64>) {
        match self.mount() {
            CameraMount::Hand { tool_from_camera } => ("tool_from_camera", tool_from_camera),
            CameraMount::World { base_from_camera, .. } => ("base_from_camera", base_from_camera),
        }
    }

    /// The simulated camera's pose in the frame it is fixed to, as it really is.
    pub fn true_camera_in_mount(&self) -> IsometryMatrix3<f64> {
        match self.true_mount() {
            CameraMount::Hand { tool_from_camera } => tool_from_camera,
            CameraMount::World { base_from_camera, .. } => base_from_camera,
        }
    }

    /// The world (= arm base) pose of the board at the desired joints, where the camera there sees it as
    /// desired (a hand camera's board stands there).
    pub fn base_from_board(&self, arm: &vservo_arm::SerialArm) -> IsometryMatrix3<f64> {
        match self.fixed_camera {
            None => {
                arm.base_from_tool(&self.desired.joints)
                    * self.tool_from_camera
                    * self.desired.camera_from_board
            }
            Some(fixed) => fixed.base_from_camera * self.desired.camera_from_board,
        }
    }

    /// The camera in the base frame with the arm at `joints`.
    pub fn base_from_camera_at(
        &self,
        arm: &vservo_arm::SerialArm,
        joints: &JointVector,
    ) -> IsometryMatrix3<f64> {
        self.mount().base_from_camera(&arm.base_from_tool(joints))
    }

    /// The board as the camera sees it with the arm at `joints` (a hand camera's board where the desired pose
    /// puts it): `camera_from_board = base_from_camera(q)⁻¹ · base_from_board(q)`.
    pub fn camera_from_board_at(
        &self,
        arm: &vservo_arm::SerialArm,
        joints: &JointVector,
    ) -> IsometryMatrix3<f64> {
        match self.fixed_camera {
            None => {
                let base_from_camera = arm.base_from_tool(joints) * self.tool_from_camera;
                base_from_camera.inverse() * self.base_from_board(arm)
            }
            Some(fixed) => {
                fixed.base_from_camera.inverse() * arm.base_from_tool(joints) * fixed.tool_from_board
            }
        }
    }

    /// The command the robot driver takes: an external driver's declaration; for the simulated driver,
    /// torque for the dynamic plant and position (the ideal robot) for the kinematic one.
    pub fn command_interface(&self) -> CommandInterface {
        match self.robot.driver {
            RobotDriver::External | RobotDriver::Ros2 | RobotDriver::Franka => self.robot.command,
            RobotDriver::Simulated => match self.plant.mode {
                vservo_settings::simulation::PlantMode::Dynamic => CommandInterface::Torque,
                vservo_settings::simulation::PlantMode::Kinematic => CommandInterface::Position,
            },
        }
    }

    /// What the gain design needs.
    pub fn gains_spec(&self) -> GainsSpec {
        GainsSpec {
            camera: self.camera,
            desired_features: self.desired.features,
            desired_depths: self.desired.depths,
            period_s: self.timing.vision_period_s,
            delay_frames: self.timing.pipeline_delay_frames,
            q: self.controller.q,
            r: self.controller.r,
            law: self.controller.law,
            options: self.controller.options,
        }
    }
}
