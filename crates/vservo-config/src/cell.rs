//! The core cell's part of the configuration ([`CellConfig`]): what its four stages (vision, servo, rmrc,
//! plant) and their designs run by — timing, the camera and its mount, the board and the desired pose, the
//! law, vision, the simulated plant and joint servo, the interpolator, the scenario, the robot and its arm, the
//! reacquisition. Not the shells' settings (the runtime, supervision and faults, the viewer, ROS 2, the Franka,
//! the GStreamer camera, calibration): the cell never sees those.
//!
//! The few rules computed from these parts (the true camera, the board's place, the gains' specification, the
//! command interface) are written once here, for [`CellConfig`] and for the whole [`Config`].

use vservo_arm::JointVector;
use vservo_scene::{Board, CameraIntrinsics, IsometryMatrix3};
use vservo_settings::control::GainsSpec;

use crate::{
    CameraTruth, CommandInterface, Config, Controller, Desired, JointServoSettings, PlantSettings, Reacquire,
    Robot, RobotDriver, Scenario, Timing, Vision,
};

/// The configuration's part the core cell runs by ([`Config::cell`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CellConfig {
    /// Periods and delays.
    pub timing: Timing,
    /// The camera's intrinsics.
    pub camera: CameraIntrinsics,
    /// Where the camera sits on the hand: camera = tool · `tool_from_camera`.
    pub tool_from_camera: IsometryMatrix3<f64>,
    /// The simulated camera as it really is, where `[camera.truth]` says it differs (see
    /// [`CellConfig::true_camera`]).
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
    /// `[robot.arm]`: the arm's model.
    pub arm: vservo_arm::SerialArm,
    /// `[reacquire]`: how the servo steers back to lost marks.
    pub reacquire: Reacquire,
}

impl Config {
    /// The core cell's part of this configuration.
    pub fn cell(&self) -> CellConfig {
        CellConfig {
            timing: self.timing,
            camera: self.camera,
            tool_from_camera: self.tool_from_camera,
            camera_truth: self.camera_truth,
            board: self.board,
            desired: self.desired,
            controller: self.controller,
            vision: self.vision.clone(),
            plant: self.plant,
            interpolator: self.interpolator,
            joint_servo: self.joint_servo,
            scenario: self.scenario,
            robot: self.robot,
            arm: self.arm.clone(),
            reacquire: self.reacquire,
        }
    }

    /// The simulated camera as it really is: `[camera.truth]` where written, else what the cell believes.
    pub fn true_camera(&self) -> CameraTruth {
        true_camera(self.camera_truth, self.camera, self.tool_from_camera)
    }

    /// The world (= arm base) pose of the board, placed so that the camera at q_d sees it as desired.
    pub fn base_from_board(&self, arm: &vservo_arm::SerialArm) -> IsometryMatrix3<f64> {
        base_from_board(arm, &self.desired, &self.tool_from_camera)
    }

    /// The board as the camera sees it with the arm at `joints` and the board where the desired pose puts
    /// it: `camera_from_board = (base_from_tool(q) · tool_from_camera)⁻¹ · base_from_board`.
    pub fn camera_from_board_at(
        &self,
        arm: &vservo_arm::SerialArm,
        joints: &JointVector,
    ) -> IsometryMatrix3<f64> {
        camera_from_board_at(arm, joints, &self.desired, &self.tool_from_camera)
    }

    /// The command the robot driver takes: an external driver's declaration; for the simulated driver,
    /// torque for the dynamic plant and position (the ideal robot) for the kinematic one.
    pub fn command_interface(&self) -> CommandInterface {
        command_interface(&self.robot, &self.plant)
    }

    /// What the gain design needs.
    pub fn gains_spec(&self) -> GainsSpec {
        gains_spec(&self.camera, &self.desired, &self.timing, &self.controller)
    }
}

impl CellConfig {
    /// The simulated camera as it really is: `[camera.truth]` where written, else what the cell believes.
    pub fn true_camera(&self) -> CameraTruth {
        true_camera(self.camera_truth, self.camera, self.tool_from_camera)
    }

    /// The world (= arm base) pose of the board, placed so that the camera at q_d sees it as desired.
    pub fn base_from_board(&self, arm: &vservo_arm::SerialArm) -> IsometryMatrix3<f64> {
        base_from_board(arm, &self.desired, &self.tool_from_camera)
    }

    /// The board as the camera sees it with the arm at `joints` (see [`Config::camera_from_board_at`]).
    pub fn camera_from_board_at(
        &self,
        arm: &vservo_arm::SerialArm,
        joints: &JointVector,
    ) -> IsometryMatrix3<f64> {
        camera_from_board_at(arm, joints, &self.desired, &self.tool_from_camera)
    }

    /// The command the robot driver takes (see [`Config::command_interface`]).
    pub fn command_interface(&self) -> CommandInterface {
        command_interface(&self.robot, &self.plant)
    }

    /// What the gain design needs.
    pub fn gains_spec(&self) -> GainsSpec {
        gains_spec(&self.camera, &self.desired, &self.timing, &self.controller)
    }
}

fn true_camera(
    truth: Option<CameraTruth>,
    camera: CameraIntrinsics,
    tool_from_camera: IsometryMatrix3<f64>,
) -> CameraTruth {
    truth.unwrap_or(CameraTruth { intrinsics: camera, tool_from_camera })
}

fn base_from_board(
    arm: &vservo_arm::SerialArm,
    desired: &Desired,
    tool_from_camera: &IsometryMatrix3<f64>,
) -> IsometryMatrix3<f64> {
    arm.base_from_tool(&desired.joints) * tool_from_camera * desired.camera_from_board
}

fn camera_from_board_at(
    arm: &vservo_arm::SerialArm,
    joints: &JointVector,
    desired: &Desired,
    tool_from_camera: &IsometryMatrix3<f64>,
) -> IsometryMatrix3<f64> {
    let base_from_camera = arm.base_from_tool(joints) * tool_from_camera;
    base_from_camera.inverse() * base_from_board(arm, desired, tool_from_camera)
}

fn command_interface(robot: &Robot, plant: &PlantSettings) -> CommandInterface {
    match robot.driver {
        RobotDriver::External | RobotDriver::Ros2 | RobotDriver::Franka => robot.command,
        RobotDriver::Simulated => match plant.mode {
            vservo_settings::simulation::PlantMode::Dynamic => CommandInterface::Torque,
            vservo_settings::simulation::PlantMode::Kinematic => CommandInterface::Position,
        },
    }
}

fn gains_spec(
    camera: &CameraIntrinsics,
    desired: &Desired,
    timing: &Timing,
    controller: &Controller,
) -> GainsSpec {
    GainsSpec {
        camera: *camera,
        desired_features: desired.features,
        desired_depths: desired.depths,
        period_s: timing.vision_period_s,
        delay_frames: timing.pipeline_delay_frames,
        q: controller.q,
        r: controller.r,
        law: controller.law,
        options: controller.options,
    }
}
