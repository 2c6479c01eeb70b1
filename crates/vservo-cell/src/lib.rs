//! # vservo-cell — the four components of the cell, as step functions both shells run
//!
//! This crate owns the wiring of the pure components into the four stages of the loop (docs/ARCHITECTURE.md),
//! each built from the configuration's part for the cell ([`CellConfig`], never the shells' settings) by a [`Cell`]:
//!
//! - [`PlantStage`]: the simulated arm and its world (the board's motion), and a holding brake when commands
//!   stop; one call per 1 ms tick;
//! - [`VisionStage`]: simulated camera, extractor, mark tracking and the pipeline delay; one call per frame;
//! - [`ServoStage`]: the LQ law, its refusal of marks outside the image and what it does with fewer than four
//!   marks; one call per frame;
//! - [`RmrcStage`]: the interpolator and the joint servo, and how they follow the robot driver (a restart at
//!   rest after a stall or a new driver, the ticks it woke too late for); one call per tick.
//!
//! The lockstep shell calls them in one process on virtual time; the real-time shell runs each in its own
//! process. Neither adds control logic of its own, so the same configuration behaves the same in both: the
//! lockstep runs the same [`RmrcStage::follow`], [`RmrcStage::take_twist`] and servo refusal as the nodes.
//! Nothing here does I/O, reads a clock or allocates per call.
//!
//! ## Vision
//!
//! Per frame, the image comes from the simulated camera (joint state → `camera_from_board`: the camera's and
//! the board's poses at q by the mount, `CameraMount`: on the hand the forward kinematics × `tool_from_camera`
//! and the standing board, fixed the camera where it stands and the board on the tool → `Renderer::render`) or from a driver
//! ([`VisionStage::process_image`]; refused if its size or format is not the configured one) →
//! `Extractor::extract` with the previous frame's features as the prediction (`Prediction::Tracking`;
//! `Prediction::Layout` with ξ_d when there is none), or with an AprilTag target the tag's extractor fed the
//! tracked corners → ξ in the board's mark order, NaN and a reason for each mark that is not valid. Tracking
//! relocks on the observed positions; the features leave undistorted to pinhole pixels (`vision.undistort`).
//! The simulated camera renders the camera as it really is (`CellConfig::true_camera`, from `[camera.truth]`),
//! while the pose delivered with the features is the believed one; the pipeline delay is modelled for the
//! simulated camera only.
//!
//! ## Servo
//!
//! [`ServoStage`] gives the law's twist and a verdict ([`ServoVerdict`]: waiting, servoing, servoing on three
//! marks, reacquiring, marks missing, held in a safe stop) and the RMS feature error ([`feature_error_px`]).
//! A mark outside the image (`CameraIntrinsics::contains` at its observed, distorted position) is no
//! measurement and taken as missing ([`ServoStep::outside`] says which). Reacquiring: with fewer than three
//! marks, a proportional twist (`[reacquire]`: 1.5/s, at most 0.1 m/s and 0.5 rad/s) back to the camera pose
//! of the last frame with all four; the daemon's fault monitor counts it as a lost target
//! (`[faults] target_lost_s`).
//!
//! ## Rmrc
//!
//! [`RmrcStage`] turns the interpolator's reference into an [`ActuatorCommand`] (torques, or the joint
//! reference for a velocity or position driver), stepped at the driver's period; velocity and acceleration
//! limits are on for every driver but the simulated kinematic plant, the paper's ideal robot.
//! [`RmrcStage::follow`] takes each joint state it answers ([`DriverTick`]: epoch, tick, stamp) and decides
//! itself whether the driver carried on or stalled or restarted; then, and when the driver says it holds the
//! arm (`DriverTick::holding`), the reference restarts at rest from the measured joints
//! ([`Following::Resynced`], [`RmrcStage::since_tick`]); the ticks it was not asked to answer are stepped
//! through. [`RmrcStage::take_twist`] zeroes a twist whose verdict does not move the arm and refuses one
//! outside the robot's camera limits ([`TwistLimits`]); [`RmrcStage::move_joints_to`] takes the joints to a
//! goal inside the limits instead of the twists, [`RmrcStage::end_joint_move`] ends it.
//!
//! ## Gains and targets
//!
//! [`gains::design`] is the one place gains are designed: [`Cell::new`] designs through it (the daemon's start
//! check, every node, the lockstep), and so does the daemon's commander for each new version. [`target::place`]
//! turns a client's target (features, a pose relative to the board, teach) into ξ_d and depths, or a
//! [`target::TargetRefused`] naming why (outside the image or inside the barrier's margin, degenerate, out of
//! reach). [`Cell::simulated`] is the wholly simulated cell, the only one the lockstep runs.

mod collision_guard;
mod exposure;
pub mod gains;
mod plant_stage;
mod rate_limit;
mod rmrc_stage;
mod servo_stage;
pub mod target;
mod vision_stage;

pub use plant_stage::{CommandReference, PlantStage};
pub use rmrc_stage::{ActuatorCommand, DriverTick, Following, RmrcStage, TwistLimits};
pub use servo_stage::{ServoInput, ServoStage, ServoStep, ServoVerdict, feature_error_px};
pub use vision_stage::{DeliveredFrame, VisionFrame, VisionStage};
pub use vservo_config::CommandInterface;

use nalgebra::{Rotation3, Translation3};
use vservo_arm::{JointVector, SerialArm};
use vservo_config::{CellConfig, RobotDriver};
use vservo_control::Gains;
use vservo_scene::IsometryMatrix3;
use vservo_sim::plant::PlantMode;

/// Why the cell could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CellError {
    /// No inverse-kinematics solution inside the joint limits for the starting camera pose.
    #[error("the starting camera pose has no inverse-kinematics solution inside the joint limits")]
    Unreachable,
    /// The gains could not be designed.
    #[error("gain design: {0}")]
    Gains(#[from] vservo_control::GainsError),
    /// The configuration asks for recorded or external images, which cannot close a simulated loop.
    #[error(
        "camera.source = {0:?}: only the simulated camera moves with the simulated arm (camera.source = \"simulated\")"
    )]
    NotSimulatedCamera(&'static str),
    /// The configuration asks for an external robot driver, which the lockstep simulator cannot run.
    #[error(
        "robot.driver = \"external\": the lockstep simulator runs the simulated arm only (robot.driver = \"simulated\")"
    )]
    NotSimulatedRobot,
    /// The collision geometry could not be built (`[collision]`, the arm's URDF shapes).
    #[error("collision: {0}")]
    Collision(vservo_collision::GeometryError),
}

impl From<vservo_collision::GeometryError> for CellError {
    fn from(error: vservo_collision::GeometryError) -> Self {
        Self::Collision(error)
    }
}

/// A configuration made ready to build the stages: the arm, the gains, the desired and starting poses.
#[derive(Debug, Clone)]
pub struct Cell {
    config: CellConfig,
    arm: SerialArm,
    gains: Gains,
    start_joints: JointVector,
    base_from_desired_camera: IsometryMatrix3<f64>,
    base_from_board_desired: IsometryMatrix3<f64>,
    /// The camera at the desired joints in the frame that holds the board still (the base for a hand camera).
    holder_from_desired_camera: IsometryMatrix3<f64>,
    /// The collision guard (`[collision]`), built once; each rmrc stage takes a copy.
    guard: Option<vservo_collision::Guard>,
}

impl Cell {
    /// A cell that is simulated whole (arm and camera), as the lockstep simulator needs.
    pub fn simulated(config: &CellConfig) -> Result<Self, CellError> {
        if config.vision.source != vservo_config::VisionSource::Simulated {
            return Err(CellError::NotSimulatedCamera(config.vision.source.name()));
        }
        if !config.robot.driver.is_simulated() {
            return Err(CellError::NotSimulatedRobot);
        }
        Self::new(config)
    }

    /// Designs the gains and places the arm at the scenario's starting camera pose by inverse kinematics
    /// (the solution nearest the desired joints; the simulated driver starts there).
    pub fn new(config: &CellConfig) -> Result<Self, CellError> {
        let arm = config.arm.clone();
        let gains = gains::design(config, None)?;
        let mount = config.mount();
        let base_from_desired_tool = arm.base_from_tool(&config.desired.joints);
        let base_from_desired_camera = mount.base_from_camera(&base_from_desired_tool);
        let holder_from_desired_camera = mount.holder_from_camera(&base_from_desired_tool);
        let base_from_board_desired = config.base_from_board(&arm);
        let scenario = &config.scenario;
        let displacement = IsometryMatrix3::from_parts(
            Translation3::from(scenario.initial_camera_translation_m),
            Rotation3::from_scaled_axis(scenario.initial_camera_rotation),
        );
        // the start is the camera displaced from the desired pose relative to the board: a hand camera moves
        // there, a fixed one sees the board moved by the inverse
        let base_from_tool_start = match config.fixed_camera {
            None => base_from_desired_camera * displacement * config.tool_from_camera.inverse(),
            Some(_) => mount.base_from_tool_seeing(
                &(displacement.inverse() * config.desired.camera_from_board),
                &base_from_board_desired,
            ),
        };
        let start_joints =
            arm.reach(&base_from_tool_start, &config.desired.joints).ok_or(CellError::Unreachable)?;
        let guard = collision_guard::guard(config, &arm)?;
        Ok(Self {
            config: config.clone(),
            arm,
            gains,
            start_joints,
            base_from_desired_camera,
            base_from_board_desired,
            holder_from_desired_camera,
            guard,
        })
    }

    /// The collision guard, as built from `[collision]` (each rmrc stage runs a copy).
    pub fn guard(&self) -> Option<&vservo_collision::Guard> {
        self.guard.as_ref()
    }

    /// The configuration.
    pub fn config(&self) -> &CellConfig {
        &self.config
    }

    /// The arm model.
    pub fn arm(&self) -> &SerialArm {
        &self.arm
    }

    /// The designed gains.
    pub fn gains(&self) -> &Gains {
        &self.gains
    }

    /// The joints at the scenario's starting camera pose (rad).
    pub fn start_joints(&self) -> &JointVector {
        &self.start_joints
    }

    /// The camera at the desired pose, in the base frame.
    pub fn base_from_desired_camera(&self) -> &IsometryMatrix3<f64> {
        &self.base_from_desired_camera
    }

    /// The plant at rest at the starting joints, at tick 0.
    pub fn plant(&self) -> PlantStage {
        self.plant_resumed(&self.start_joints, 0)
    }

    /// The plant at rest at `q`, at `tick` (a restarted plant continues where the arm stopped).
    pub fn plant_resumed(&self, q: &JointVector, tick: u64) -> PlantStage {
        PlantStage::new(
            &self.config,
            self.arm.clone(),
            *q,
            tick,
            self.base_from_desired_camera,
            self.base_from_board_desired,
        )
    }

    /// The vision pipeline.
    pub fn vision(&self) -> VisionStage {
        VisionStage::new(&self.config, self.arm.clone())
    }

    /// The servo at rest; for an arm whose reference keeps jerk limits (which a twist's change cannot follow
    /// within a frame as the law assumes), its twist shaped to what the arm follows ([`rate_limit`]).
    pub fn servo(&self) -> ServoStage {
        let mut servo = ServoStage::new(
            self.law_geometry(),
            &self.gains,
            self.config.reacquire,
            self.holder_from_desired_camera,
        );
        if self.keeps_limits() && self.config.interpolator.jerk_limit.is_some() {
            servo.set_arm_response(rate_limit::arm_response(&self.config, &self.arm));
        }
        servo
    }

    /// Whether the arm's reference keeps its acceleration, jerk and tool limits: always, but for the
    /// simulated kinematic plant that follows its position reference at once, the ideal robot of the paper's
    /// check (docs/REPRODUCTION.md), which moves the camera exactly as commanded. A kinematic plant with drives
    /// (a velocity or a lag: the arm files' simulated arms), the dynamic plant and any other driver, an
    /// external one above all, keep the limits.
    pub fn keeps_limits(&self) -> bool {
        !(self.config.robot.driver == RobotDriver::Simulated
            && self.config.plant.mode == PlantMode::Kinematic
            && self.config.plant.kinematic.is_ideal())
    }

    /// What the law takes from the configuration and never changes.
    pub fn law_geometry(&self) -> vservo_control::LawGeometry {
        vservo_control::LawGeometry {
            camera: self.config.camera,
            board: self.config.board,
            period_s: self.config.timing.vision_period_s,
            delay_frames: self.config.timing.pipeline_delay_frames,
        }
    }

    /// The interpolator and joint servo, their reference at rest at `q`, stepping by the driver's period and
    /// commanding in its interface.
    pub fn rmrc(&self, q: &JointVector) -> RmrcStage {
        let mut settings = self.config.interpolator;
        settings.control_period_s = self.config.robot.period_s;
        if !self.keeps_limits() {
            settings.acceleration_limit = JointVector::from_element(f64::INFINITY);
            settings.jerk_limit = None;
            settings.tool_speed_limit_m_s = f64::INFINITY;
            settings.tool_rotation_limit_rad_s = f64::INFINITY;
        }
        RmrcStage::new(&self.config, settings, self.arm.clone(), *q, self.guard.clone())
    }
}
