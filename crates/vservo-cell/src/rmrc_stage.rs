//! The rmrc stage: the 1 ms interpolator and the joint servo behind it.

use vservo_arm::{JointVector, SerialArm};
use vservo_config::Config;
use vservo_control::Twist;
use vservo_sim::interpolator::{Interpolator, InterpolatorSettings, Reference};
use vservo_sim::joint_servo::JointServo;
use vservo_sim::plant::PlantMode;

/// What the rmrc sends the plant for one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ActuatorCommand {
    /// Joint torques (N·m), for the dynamic plant and a real arm's torque-controlled drives.
    Torque(JointVector),
    /// The joint reference itself, for the ideal (kinematic) robot.
    Kinematic {
        /// q_d (rad).
        q: JointVector,
        /// q̇_d (rad/s).
        qd: JointVector,
    },
}

/// The interpolator and the joint servo.
#[derive(Debug, Clone)]
pub struct RmrcStage {
    interpolator: Interpolator,
    joint_servo: JointServo,
    mode: PlantMode,
}

impl RmrcStage {
    pub(crate) fn new(
        config: &Config,
        settings: InterpolatorSettings,
        arm: SerialArm,
        q: JointVector,
    ) -> Self {
        Self {
            interpolator: Interpolator::new(settings, arm.clone(), config.tool_from_camera, q),
            joint_servo: JointServo::new(
                arm,
                config.joint_servo.law,
                config.joint_servo.kp,
                config.joint_servo.kv,
            ),
            mode: config.plant.mode,
        }
    }

    /// A new twist from the servo, received at simulated time `now_s`.
    pub fn set_twist(&mut self, twist: Twist, now_s: f64) {
        self.interpolator.set_twist(twist, now_s);
    }

    /// The reference of the last tick.
    pub fn reference(&self) -> &Reference {
        self.interpolator.reference()
    }

    /// The command for the tick that ends at `next_s`, given the measured joints at its start.
    pub fn step(&mut self, next_s: f64, q: &JointVector, qd: &JointVector) -> ActuatorCommand {
        let reference = *self.interpolator.step(next_s);
        match self.mode {
            PlantMode::Kinematic => ActuatorCommand::Kinematic { q: reference.q, qd: reference.qd },
            PlantMode::Dynamic => ActuatorCommand::Torque(self.joint_servo.torque(q, qd, &reference)),
        }
    }
}
